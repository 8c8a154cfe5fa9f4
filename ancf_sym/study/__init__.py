"""What accuracy costs in time: sweeps of a setting space against a reference, with a report.

    from ancf_sym.study import run_study
    report = run_study("zhang_cantilever", "out/study", jobs=2)   # or scheduler="tcp://host:8786" (Dask)
    print(report.answer)                  # the cheapest setting reaching the study's target error

Also `ancf-sym study NAME --out DIR`. Studies: see STUDIES (name -> one-line title) or `ancf-sym study --list`.
"""
from __future__ import annotations

import datetime
import os
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ancf_sym.study.base import Study, StudyError, parse_sweep, setting_key
from ancf_sym.study.runner import finished_records, load_reference, prepare_folder, run_settings
from ancf_sym.study.sweep import run_sweep
from ancf_sym.study.catalog import get_study, studies

@dataclass
class StudyReport:
    name: str
    out: Path
    records: list  # one dict per finished setting (axes, error, wall_s, status, ...)
    reference: dict
    answer: str  # the cheapest setting reaching the target (or the closest one)
    planned: int

    @property
    def complete(self) -> bool:
        return len(self.records) == self.planned


def run_study(name: str, out: str | Path, *, quick: bool = False, jobs: int | None = None,
              sweep: dict[str, list] | list[str] | None = None, target: float | None = None,
              progress: bool = True, command: str | None = None, scheduler: Any = None) -> StudyReport:
    """Run (or resume) the study `name` into `out` and write its report.

    quick: the small sweep of the test suite; jobs: worker processes (default: the number of cores);
    sweep: {axis: values} or ["axis=v1,v2", ...] replacing an axis' values; target: error the answer aims at.
    scheduler: a Dask scheduler address ('tcp://host:8786') or a distributed.Client: the settings run on that
    cluster's workers instead of the local pool (needs the cluster extra: pip install 'ancf_sym[cluster]').
    Bad input raises StudyError before any run; an interrupted study keeps its finished settings (rerun resumes).
    """
    study = get_study(name)
    if isinstance(sweep, list):
        sweep = parse_sweep(study, sweep)
    elif sweep:
        sweep = parse_sweep(study, [f"{k}={','.join(str(v) for v in vs)}" for k, vs in sweep.items()])
    if target is not None and not (isinstance(target, (int, float)) and 0 < target < float("inf")):
        raise StudyError(f"--target must be a positive number, got {target!r}")
    cores = os.cpu_count() or 1
    if jobs is None:
        jobs = cores
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise StudyError(f"--jobs must be a positive integer, got {jobs!r}")
    if study.max_jobs is not None and jobs > study.max_jobs:
        jobs = study.max_jobs  # the study's timings need it (stated in the report)
    if scheduler is not None:
        from ancf_sym.study.sweep import dask_client
        client, close = dask_client(scheduler)  # (bad address or a missing extra: refused before any run)
        if close:
            client.close()
    variant = "quick" if quick else "full"
    settings = study.settings(variant, sweep)
    out = Path(out)
    prepare_folder(out, study, variant)
    reference = load_reference(study, variant, out, progress)
    target_given = target is not None
    target = float(target if target is not None else study.target)
    meta = {"target_given": target_given, "variant": variant, "jobs": jobs if scheduler is None else "Dask cluster", "cores": cores, "date": datetime.date.today().isoformat(),
            "timing": study.extra.get("timing", "wall time of the run, min over repeats"),
            "command": command or f"ancf-sym study {name} --out {shlex.quote(str(out))}" + (" --quick" if quick else "")}
    from ancf_sym.study.report import write_report
    try:
        records = run_settings(study, variant, settings, out, reference, jobs, progress, scheduler)
    except KeyboardInterrupt:
        done = finished_records(out)
        records = [done[setting_key(s)] for s in settings if setting_key(s) in done]
        write_report(out, study, records, reference, target, meta, len(settings))
        print(f"interrupted: {len(records)} of {len(settings)} settings finished and kept in {out}/runs; "
              "run the same command again to resume", file=sys.stderr)
        raise
    answer = write_report(out, study, records, reference, target, meta, len(settings))
    return StudyReport(name, out, records, reference, answer, len(settings))


__all__ = ["run_study", "run_sweep", "studies", "get_study", "Study", "StudyError", "StudyReport"]
