"""Running a study: resumable (one JSON file per finished setting), parallel over settings, with a progress bar.

DIR/study.json      which study and variant the folder holds (a folder of another study is refused)
DIR/reference.json  the reference, computed once
DIR/runs/*.json     one record per finished setting: a rerun skips these, so an interrupted study resumes
"""
from __future__ import annotations

import json
import multiprocessing
import os
import tempfile
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

from ..output_json import _clean
from .base import Study, StudyError, setting_key


def write_json_atomic(path: Path, data) -> None:
    """Write to a temporary sibling, then rename: a file is either the old one or the complete new one."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    with os.fdopen(fd, "w") as f:
        json.dump(_clean(data), f, indent=1, allow_nan=False)  # NaN -> null: never a silent NaN
    os.replace(tmp, path)


def prepare_folder(out: Path, study: Study, variant: str) -> None:
    """Create DIR (and DIR/runs), check it is writable, refuse a folder holding another study or variant."""
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
        probe = out / f".write-test-{os.getpid()}"
        probe.write_text("ok")
        probe.unlink()
    except OSError as exc:
        raise StudyError(f"--out {out}: cannot write there ({exc.strerror or exc})") from None
    meta_file = out / "study.json"
    if meta_file.is_file():
        meta = json.loads(meta_file.read_text())
        if (meta.get("study"), meta.get("variant")) != (study.name, variant):
            raise StudyError(f"--out {out}: holds study {meta.get('study')!r} ({meta.get('variant')}); "
                             f"not mixing it with {study.name!r} ({variant}): choose another folder")
    elif any(p for p in out.iterdir() if p.name != "runs") or any((out / "runs").iterdir()):
        raise StudyError(f"--out {out}: not empty and not a study folder (no study.json): choose another folder")
    else:
        write_json_atomic(meta_file, {"study": study.name, "variant": variant, "title": study.title})


def load_reference(study: Study, variant: str, out: Path) -> dict:
    path = out / "reference.json"
    if path.is_file():
        return json.loads(path.read_text())
    t0 = time.perf_counter()
    try:
        ref = study.reference(variant)
    except Exception as exc:  # noqa: BLE001 - any failure of the reference stops the study before its runs
        raise StudyError(f"study {study.name!r}: the reference failed: {type(exc).__name__}: {exc}") from None
    if not ref.get("success", True):
        raise StudyError(f"study {study.name!r}: the reference did not converge: {ref.get('status', '?')}")
    ref["wall_s"] = time.perf_counter() - t0
    write_json_atomic(path, ref)
    return ref


def finished_records(out: Path) -> dict[str, dict]:
    recs = {}
    for p in sorted((out / "runs").glob("*.json")):
        try:
            recs[p.stem] = json.loads(p.read_text())
        except (OSError, json.JSONDecodeError):
            continue  # a torn file cannot exist (atomic writes), but never trust one: the setting runs again
    return recs


_WARM: set = set()  # studies that already ran once in this process


def _work(name: str, variant: str, setting: dict) -> dict:
    """One setting in a worker process. A process's first setting of a study runs twice, the first run untimed:
    it pays the one-time costs (loading kernel libraries and solver plugins) no later setting pays."""
    from . import get_study
    study = get_study(name)
    try:
        if name not in _WARM:
            _WARM.add(name)
            study.run(dict(setting), variant)
        rec = study.run(dict(setting), variant)
    except Exception as exc:  # noqa: BLE001 - a crashed setting is a failed record, not a crashed study
        rec = {"status": f"error: {type(exc).__name__}: {exc}", "success": False, "wall_s": None}
    return {**setting, **rec}


def run_settings(study: Study, variant: str, settings: list[dict], out: Path, reference: dict, jobs: int,
                 progress: bool) -> list[dict]:
    """Run the settings not finished yet; each record is written as soon as it is done."""
    from tqdm import tqdm

    done = finished_records(out)
    pending = [s for s in settings if setting_key(s) not in done]
    bar = tqdm(total=len(settings), initial=len(settings) - len(pending), desc=study.name, unit="setting",
               disable=not progress, dynamic_ncols=True)

    def store(rec: dict) -> None:
        err = None
        if rec.get("success"):
            err = study.error(rec, reference)
        rec["error"] = err
        setting = {a.name: rec[a.name] for a in study.axes}
        write_json_atomic(out / "runs" / f"{setting_key(setting)}.json", rec)
        done[setting_key(setting)] = rec
        bar.update(1)

    try:
        if jobs <= 1 or len(pending) <= 1:
            for s in pending:
                store(_work(study.name, variant, s))
        else:
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else None)
            with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
                futures = {pool.submit(_work, study.name, variant, s) for s in pending}
                try:
                    while futures:
                        finished, futures = wait(futures, return_when=FIRST_COMPLETED)
                        for f in finished:
                            store(f.result())
                except BaseException:
                    for f in futures:
                        f.cancel()
                    raise
    finally:
        bar.close()
    return [done[setting_key(s)] for s in settings if setting_key(s) in done]
