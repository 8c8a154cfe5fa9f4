"""Running a study: resumable (one JSON file per finished setting), parallel over settings, with a progress bar.

DIR/study.json      which study and variant the folder holds (a folder of another study is refused)
DIR/reference.json  the reference, computed once
DIR/runs/*.json     one record per finished setting: a rerun skips these, so an interrupted study resumes
"""
from __future__ import annotations

import json
import os
import time
from functools import partial
from pathlib import Path
from typing import Any

from .base import Study, StudyError
from .sweep import finished_records as _finished, run_sweep, write_json_atomic


def finished_records(out: Path) -> dict[str, dict]:
    """The finished settings of the study folder `out` (out/runs/*.json) by setting key."""
    return _finished(out / "runs")


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
                 progress: bool, scheduler: Any = None) -> list[dict]:
    """Run the settings not finished yet (local pool of `jobs` processes, or the Dask cluster at `scheduler`);
    each record is written as soon as it is done."""

    def with_error(rec: dict) -> dict:
        rec["error"] = study.error(rec, reference) if rec.get("success") else None
        return rec

    return run_sweep(partial(_work, study.name, variant), settings, out=out / "runs", jobs=jobs,
                     scheduler=scheduler, progress=progress, desc=study.name, on_record=with_error)
