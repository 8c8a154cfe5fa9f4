"""Studies and sweeps on a Dask cluster (the cluster extra): a 2-worker LocalCluster gives the same records as the
in-process run, and a setting whose worker dies mid-run is run again and stored once."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from ancf_sym.study import StudyError, run_study, run_sweep

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as c:
        yield c


def test_study_on_a_local_cluster_matches_jobs_1(tmp_path, client):
    """Settings are deterministic solves (IPOPT from the same start): the cluster's records must equal the
    in-process ones in every field but the timings (exactly: same code, same inputs, same kernels)."""
    sweep = {"n": [2, 4, 6], "strain": ["decoupled", "biot"]}
    one = run_study("elastica", tmp_path / "one", quick=True, jobs=1, progress=False, sweep=sweep)
    dask = run_study("elastica", tmp_path / "dask", quick=True, progress=False, sweep=sweep, scheduler=client)
    assert dask.complete and len(dask.records) == 6
    drop = {"wall_s"}
    assert [{k: v for k, v in r.items() if k not in drop} for r in dask.records] == \
        [{k: v for k, v in r.items() if k not in drop} for r in one.records]
    assert "Dask cluster" in (tmp_path / "dask" / "report.md").read_text()


def slow_setting(setting: dict) -> dict:
    """A sweep function that marks each start (a file per start) and takes long enough to be killed mid-run."""
    Path(setting["log"], f"{setting['i']}-{os.getpid()}-{time.monotonic_ns()}").touch()
    time.sleep(1.0)
    return {"square": setting["i"] ** 2, "pid": os.getpid(), "success": True}


def test_a_setting_whose_worker_dies_is_run_again_and_stored_once(tmp_path, client):
    """Kill the worker process running a setting after the first record arrives: Dask reschedules that setting on
    a live worker; the sweep completes with every setting's record once, each one right."""
    log = tmp_path / "log"
    log.mkdir()
    settings = [{"i": i, "log": str(log)} for i in range(6)]
    killed = {}

    def kill_a_busy_worker(rec: dict) -> dict:
        if not killed:
            busy = {w: ks for w, ks in client.processing().items() if ks}
            addr = next(iter(busy))
            pid = client.run(os.getpid, workers=[addr])[addr]
            killed["i"] = {int(str(k).split("i=")[1].split(",")[0]) for k in busy[addr]}  # its settings
            os.kill(pid, signal.SIGKILL)
            killed["pid"] = pid
        return rec

    recs = run_sweep(slow_setting, settings, out=tmp_path / "runs", scheduler=client, progress=False,
                     on_record=kill_a_busy_worker)
    assert killed
    assert [r["square"] for r in recs] == [i * i for i in range(6)]
    assert len(list((tmp_path / "runs").glob("*.json"))) == 6
    starts = [p.name.split("-")[:2] for p in log.iterdir()]
    # a setting the killed worker had started was started again on another worker, and stored from there
    cut = [i for i in killed["i"] if [str(i), str(killed["pid"])] in starts]
    assert cut
    for i in cut:
        assert any(s[0] == str(i) and s[1] != str(killed["pid"]) for s in starts)
        assert recs[i]["pid"] != killed["pid"]
    # resumable: a second sweep into the same folder runs nothing
    again = run_sweep(slow_setting, settings, out=tmp_path / "runs", scheduler=client, progress=False)
    assert again == recs and len(list(log.iterdir())) == len(starts)


def test_bad_scheduler_is_refused_before_any_run(tmp_path):
    with pytest.raises(StudyError, match="scheduler"):
        run_study("elastica", tmp_path / "x", quick=True, progress=False, scheduler=42)
    assert not (tmp_path / "x").exists()
