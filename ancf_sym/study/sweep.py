"""Sweeps: one function over many settings, in this process, a local process pool or on a Dask cluster.

    from ancf_sym.study import run_sweep
    records = run_sweep(tip_after_one_second, [{"n": n, "dt": dt} for n in (8, 16) for dt in (1e-3, 5e-4)],
                        out="out/sweep", jobs=2)            # or scheduler="tcp://host:8786" / a distributed.Client

`func(setting) -> dict` must be a module-level function (it is pickled by name) that builds its scene from the
setting: workers compile nothing they are sent, they load their own kernels and build their own step graphs
(which the step-graph cache then reuses across the settings a worker runs). With `out`, every finished setting is
written at once to `out/<setting key>.json` and a rerun skips those (an interrupted sweep resumes). On a cluster, a
setting whose worker dies is run again on another worker (Dask reschedules it); each setting is stored once.
"""
from __future__ import annotations

import json
import multiprocessing
import os
import tempfile
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any, Callable

from ancf_sym.io.json_out import json_ready
from ancf_sym.study.base import StudyError, setting_key


def write_json_atomic(path: Path, data) -> None:
    """Write to a temporary sibling, then rename: a file is either the old one or the complete new one."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    with os.fdopen(fd, "w") as f:
        json.dump(json_ready(data), f, indent=1, allow_nan=False)  # NaN -> null: never a silent NaN
    os.replace(tmp, path)


def finished_records(folder: Path) -> dict[str, dict]:
    """Records of the finished settings in `folder` (one JSON file per setting), by setting key."""
    recs = {}
    for p in sorted(Path(folder).glob("*.json")):
        try:
            recs[p.stem] = json.loads(p.read_text())
        except (OSError, json.JSONDecodeError):
            continue  # a torn file cannot exist (atomic writes), but never trust one: the setting runs again
    return recs


def _safe(func: Callable[[dict], dict], setting: dict) -> dict:
    """func(setting) merged into the setting; an exception is a failed record, not a crashed sweep."""
    try:
        rec = func(dict(setting))
    except Exception as exc:  # noqa: BLE001
        rec = {"status": f"error: {type(exc).__name__}: {exc}", "success": False, "wall_s": None}
    return {**setting, **rec}


def dask_client(scheduler: Any):
    """(client, close it afterwards) from an address or a distributed.Client."""
    try:
        import distributed
    except ImportError:
        raise StudyError("scheduler: Dask's distributed is not installed: pip install 'ancf_sym[cluster]' "
                         "(or pip install distributed)") from None
    if isinstance(scheduler, distributed.Client):
        return scheduler, False
    if not isinstance(scheduler, str) or not scheduler:
        raise StudyError(f"scheduler must be an address such as 'tcp://host:8786' or a distributed.Client, "
                         f"got {scheduler!r}")
    try:
        return distributed.Client(scheduler, timeout="20s"), True
    except (OSError, TimeoutError) as exc:
        raise StudyError(f"scheduler {scheduler!r}: cannot connect ({exc})") from None


def run_sweep(func: Callable[[dict], dict], settings: list[dict], *, out: str | Path | None = None,
              jobs: int = 1, scheduler: Any = None, progress: bool = True, desc: str = "sweep",
              on_record: Callable[[dict], dict] | None = None) -> list[dict]:
    """Run func over the settings; returns the records (setting merged with func's dict) in the settings' order.

    out: folder of one JSON per finished setting (resumable; settings already there are not run again).
    jobs: local worker processes (1: in this process); scheduler: a Dask scheduler address or distributed.Client
    (then jobs is ignored: the cluster's workers run the settings). on_record(record) -> record runs in this
    process on each finished record before it is stored (e.g. an error against a reference)."""
    from ancf_sym.util.interrupts import progress_bar as tqdm

    keys = [setting_key(s) for s in settings]
    if len(set(keys)) != len(keys):
        raise StudyError("run_sweep: two settings have the same key (settings must differ)")
    folder = Path(out) if out is not None else None
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    done = finished_records(folder) if folder is not None else {}
    pending = [s for s, k in zip(settings, keys) if k not in done]
    bar = tqdm(total=len(settings), initial=len(settings) - len(pending), desc=desc, unit="setting",
               disable=not progress, dynamic_ncols=True)

    def store(setting: dict, rec: dict) -> None:
        if on_record is not None:
            rec = on_record(rec)
        key = setting_key(setting)
        if folder is not None:
            write_json_atomic(folder / f"{key}.json", rec)
        done[key] = rec
        bar.update(1)

    try:
        if scheduler is not None and pending:
            _run_dask(func, pending, scheduler, store)
        elif jobs <= 1 or len(pending) <= 1:
            for s in pending:
                store(s, _safe(func, s))
        else:
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else None)
            with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
                futures = {pool.submit(_safe, func, s): s for s in pending}
                left = set(futures)
                try:
                    while left:
                        finished, left = wait(left, return_when=FIRST_COMPLETED)
                        for f in finished:
                            store(futures[f], f.result())
                except BaseException:
                    for f in left:
                        f.cancel()
                    raise
    finally:
        bar.close()
    return [done[k] for k in keys if k in done]


def _run_dask(func, pending: list[dict], scheduler, store) -> None:
    """Submit every pending setting to the cluster and store each result once, as it arrives. A worker that dies
    mid-setting makes the scheduler run that setting again elsewhere (distributed's allowed-failures)."""
    from distributed import as_completed
    client, close = dask_client(scheduler)
    try:
        futures = {client.submit(_safe, func, s, pure=False, key=f"ancf-sym-{setting_key(s)}-{os.urandom(4).hex()}"):
                   s for s in pending}
        try:
            for f in as_completed(list(futures)):
                store(futures[f], f.result())
        except BaseException:
            client.cancel(list(futures))
            raise
    finally:
        if close:
            client.close()
