"""Running a study: resumable (one JSON file per finished setting), parallel over settings, with a progress bar.

DIR/study.json      which study and variant the folder holds (a folder of another study is refused)
DIR/reference.json  the reference, computed once
DIR/reference/*.json  the reference's parts (e.g. each of its converged runs) as each finishes: an interrupted
                    reference resumes from them
DIR/runs/*.json     one record per finished setting: a rerun skips these, so an interrupted study resumes
"""
from __future__ import annotations

import inspect
import json
import os
import sys
import time
from functools import partial
from pathlib import Path
from typing import Any

from ancf_sym.study.base import Study, StudyError
from ancf_sym.study.sweep import finished_records as _finished, run_sweep, write_json_atomic


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


class ReferenceParts:
    """The parts of a long reference computation (a study's `reference(variant, parts)`): each part announced on
    stderr with its own progress, stored in DIR/reference/<key>.json as soon as it is done and read back instead
    of recomputed when the study runs again (after a Ctrl-C, say)."""

    def __init__(self, study: str, folder: Path, progress: bool, total: int | None = None):
        self.study, self.folder, self.progress, self.total = study, folder, progress, total
        self.count = 0
        self.wall_s = 0.0  # the parts' own compute times, also of those computed by an earlier, interrupted run

    def announce(self, text: str) -> None:
        if self.progress:
            print(f"{self.study}: {text}", file=sys.stderr, flush=True)

    def run(self, key: str, label: str, compute, span: float | None = None, checkpoints: bool = False) -> dict:
        """compute(report) -> JSON-able dict, where report(done, span) shows its progress (e.g. simulated time
        of span seconds); stored under `key`. A stored part is returned without computing it again.

        checkpoints: compute(report, state, save) instead, where save(dict) stores an intermediate state (e.g. the
        coordinates and velocities at a time) in DIR/reference/<key>.partial.json and `state` is the last one saved
        (None the first time): an interrupted part resumes from its last checkpoint."""
        self.count += 1
        of = f" {self.count}/{self.total}" if self.total else f" {self.count}"
        path = self.folder / f"{key}.json"
        if path.is_file():
            try:
                part = json.loads(path.read_text())
                self.announce(f"reference part{of} ({label}): stored, reused ({path})")
                self.wall_s += float(part.get("part_wall_s") or 0.0)
                return part
            except (OSError, json.JSONDecodeError):
                pass  # (writes are atomic, but never trust a file): compute it again
        partial = self.folder / f"{key}.partial.json"
        state = None
        if checkpoints and partial.is_file():
            try:
                state = json.loads(partial.read_text())
                self.announce(f"reference part{of} ({label}): resumed from its checkpoint ({partial})")
            except (OSError, json.JSONDecodeError):
                state = None
        from ancf_sym.util.interrupts import progress_bar as tqdm
        bar = tqdm(total=span, desc=f"{self.study}: reference part{of} ({label})", disable=not self.progress,
                   dynamic_ncols=True, leave=True, file=sys.stderr,
                   bar_format="{desc}: {percentage:3.0f}% {bar} [{elapsed}<{remaining}]" if span else None)

        def report(done: float, total: float | None = None) -> None:
            bar.n = done
            bar.refresh()
        self.folder.mkdir(parents=True, exist_ok=True)

        def save(state: dict) -> None:
            write_json_atomic(partial, state)
        try:
            t0 = time.perf_counter()
            if checkpoints:
                part = compute(report, state, save)
            else:
                part = compute(report)
            if span:
                report(span)
        finally:
            bar.close()
        # (a resumed part's own record may count the time of the pieces an earlier, interrupted run computed)
        part = {**part, "part_wall_s": max(time.perf_counter() - t0, float(part.get("wall_s") or 0.0))}
        self.wall_s += part["part_wall_s"]
        write_json_atomic(path, part)
        partial.unlink(missing_ok=True)
        return part


def load_reference(study: Study, variant: str, out: Path, progress: bool = True) -> dict:
    """The study's reference: read from DIR/reference.json, else computed (announced at once, its parts
    stored as they finish when the study's reference has parts) and stored."""
    path = out / "reference.json"
    if path.is_file():
        return json.loads(path.read_text())
    t0 = time.perf_counter()
    parted = "parts" in inspect.signature(study.reference).parameters
    parts = ReferenceParts(study.name, out / "reference", progress)
    if progress:
        print(f"{study.name}: computing the reference first ({variant} variant"
              + ("; its parts are stored in " + str(out / "reference") + " as they finish" if parted else "")
              + "); the settings follow", file=sys.stderr, flush=True)
    try:
        ref = study.reference(variant, parts=parts) if parted else study.reference(variant)
    except KeyboardInterrupt:
        if progress:
            files = [f.name for f in (out / "reference").glob("*.json")] if (out / "reference").is_dir() else []
            kept = sum(1 for f in files if not f.endswith(".partial.json"))
            ckpt = len(files) - kept
            print(f"{study.name}: interrupted while computing the reference; {kept} finished part(s)"
                  + (f" and {ckpt} checkpoint(s) of the part under way" if ckpt else "") + f" kept in "
                  f"{out / 'reference'}: run the same command again to resume", file=sys.stderr, flush=True)
        raise
    except Exception as exc:  # noqa: BLE001 - any failure of the reference stops the study before its runs
        raise StudyError(f"study {study.name!r}: the reference failed: {type(exc).__name__}: {exc}") from None
    if not ref.get("success", True):
        raise StudyError(f"study {study.name!r}: the reference did not converge: {ref.get('status', '?')}")
    # a resumed reference counts the parts an earlier run computed at their own cost
    ref["wall_s"] = max(parts.wall_s, time.perf_counter() - t0) if parted else time.perf_counter() - t0
    write_json_atomic(path, ref)
    return ref


_WARM: set = set()  # studies that already ran once in this process


def _work(name: str, variant: str, setting: dict) -> dict:
    """One setting in a worker process. A process's first setting of a study runs twice, the first run untimed:
    it pays the one-time costs (loading kernel libraries and solver plugins) no later setting pays."""
    from ancf_sym.study.catalog import get_study
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
