"""What a new user meets in the first hour: kernels that return NumPy without warnings, results that say who solved
them and print short, errors on a wrong name that list the right ones, `ancf-sym --version`, Ctrl-C at any moment
of the start-up, and a study whose reference announces itself, is stored part by part and resumes.

The facts checked are exact (types, shapes, names, counts, exit codes, the order of messages); where a number is
compared its tolerance is stated beside it."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
import warnings

import casadi as ca
import numpy as np
import pytest

import ancf_sym
from ancf_sym import Material, Scene, Section, kernels, run_dynamics, solve_static
from ancf_sym.util.names import UnknownName


def _cantilever(n: int = 6) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("beam", [(0, 0), (3, 0)], elements=n, material=Material(E=20e9, density=7200),
             section=Section(area=7.854e-5, I=4.909e-10), axial="decoupled")
    s.clamp("beam", at="start")
    return s


def test_kernel_call_with_numbers_returns_numpy_without_warnings():
    L, EI = 0.5, 2.0
    q = [0, 0, 0, 1, 0, 0, L, 0.05, 0, 1, 0.2, 0]
    k = kernels.load("cable3d", "bending")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # CasADi's FutureWarning on NumPy arithmetic with DMs would fail here
        e, g, H = k(q, [L, EI])
        assert isinstance(e, float) and g.shape == (12, 1) and H.shape == (12, 12)
        assert isinstance(g, np.ndarray) and isinstance(H, np.ndarray)
        # the Hessian of a scalar energy is symmetric; round-off of a few hundred flops on O(EI/L^3) entries
        assert np.allclose(H, H.T, rtol=0, atol=1e-10 * np.abs(H).max())
        _ = H @ g + g * 2.0 - np.abs(g)  # plain NumPy arithmetic
    # the same numbers as CasADi's own DM call (the plain Function)
    e2, g2, H2 = ca.Function(k)(q, [L, EI])
    assert e == float(e2) and np.array_equal(g, np.asarray(g2)) and np.array_equal(H, np.asarray(H2))
    # symbols in, symbols out
    es, gs, Hs = k(ca.MX.sym("q", 12), ca.MX.sym("p", 2))
    assert isinstance(es, ca.MX) and gs.shape == (12, 1) and Hs.shape == (12, 12)


def test_static_result_says_who_solved_it_and_prints_short():
    r = solve_static(_cantilever())
    assert r.success and r.path == "newton"
    # Newton alone produced the answer: its own status and its iterations, no IPOPT word
    assert r.solved_by.startswith("Newton (converged, ") and "IPOPT" not in r.solved_by
    text = repr(r)
    assert len(text) < 400 and "succeeded" in text and "tip('beam')" in text and "potential" in text, text
    html = r._repr_html_()
    assert html.startswith("<div>") and "solved by" in html and "<table>" in html
    with pytest.raises(KeyError, match=r"no member 'bem'.*\['beam'\]"):
        r.tip("bem")
    with pytest.raises(UnknownName, match=r"no energy label 'strain'.*'axial', 'bending', 'gravity'"):
        r.energies["strain"]
    assert r.energies.get("strain") is None  # dict behaviour kept for get/in


def test_dynamic_result_prints_short_and_names_its_sensors():
    sensors = [{"name": f"p{i}", "kind": "position", "member": "beam", "at": "end"} for i in range(3)]
    r = run_dynamics(_cantilever(4), {"dt": 1e-3, "t_end": 0.02, "output_dt": 1e-3, "sensors": sensors})
    text = repr(r)
    assert len(text) < 600 and r.status in text and f"{r.steps} steps" in text, text
    assert "<table>" in r._repr_html_()
    with pytest.raises(UnknownName, match=r"no sensor 'tip'.*\['p0', 'p1', 'p2'\]"):
        r.sensors["tip"]
    assert r.sensors["p1"].shape == (len(r.t), 2)


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "ancf_sym.cli", *args], capture_output=True, text=True, **kw)


def test_version(tmp_path):
    r = _cli("--version", cwd=tmp_path)  # (not the project root: its source tree has no compiled kernels)
    assert r.returncode == 0 and r.stdout.strip() == f"ancf-sym {ancf_sym.__version__}", r.stdout + r.stderr


@pytest.mark.parametrize("delay", [0.4, 0.8, 1.5])
def test_ctrl_c_during_start_up_exits_cleanly(tmp_path, delay):
    """SIGINT at several moments of the start (loading NumPy, CasADi, the study registry, the reference's first
    run): exit 130, one line, no traceback, whenever it lands. (The first delay leaves the interpreter its own
    start-up, tens of ms, before the package's code runs: a signal there is Python's, not the package's.)"""
    # (the full study, not --quick: its reference alone runs for tens of seconds, so that every delay lands inside the
    # run; the quick study can finish within 1.5 s on a warm machine)
    proc = subprocess.Popen([sys.executable, "-m", "ancf_sym.cli", "study", "rope", "--out", str(tmp_path / "r")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    time.sleep(delay)
    assert proc.poll() is None, "the study ended before the signal: the test needs a longer run"
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    # 130, or killed by SIGINT (-2; a shell shows 130 as well): CPython ends that way when a KeyboardInterrupt went
    # through code an extension runs with PyRun_String while it loads (CasADi's SWIG module), even once handled
    assert proc.returncode in (130, -signal.SIGINT) and "Traceback" not in err, err
    assert "interrupted (Ctrl-C)" in err.splitlines()[-1], err


def _tip(n: int, dt: float, t_end: float) -> np.ndarray:
    """A tip history with a known mesh error C/n^4 and step error D dt^5, so that the reference's Richardson
    extrapolation has something to extrapolate."""
    t = np.arange(0.0, t_end + 1e-12, 0.01)
    return np.stack([np.sin(t), -t * t], axis=1) * (1 + 1.0 / n**4 + 1e3 * dt**5)


REC = {"status": "completed", "success": True, "wall_s": 0.01, "loop_s": 0.01, "setup_s": 0.0, "steps": 1,
       "newton_iterations": 1, "factorizations": 1}


def _fakes(calls: list, stop_at: int | None = None):
    """Stand-ins for the studies' dynamics runs: the settings' run (_tip_history) and the reference's run in
    checkpointed pieces (_segmented_history, here two pieces); KeyboardInterrupt at the reference's call stop_at,
    after its first piece was saved."""
    def tip_history(scene, integrator, dt, t_end, member, progress=None):
        calls.append((integrator, scene.members["rope"].elements, dt, None))
        return dict(REC), _tip(scene.members["rope"].elements, dt, t_end)

    def segmented(scene, dt, t_end, member, report=None, state=None, save=None):
        n = scene.members["rope"].elements
        calls.append(("radau", n, dt, None if state is None else state["piece"]))
        if state is None:
            save({"piece": 1})
            if report is not None:
                report(t_end / 2)
        if stop_at is not None and len(calls) == stop_at:
            raise KeyboardInterrupt
        return {**REC, "tip": _tip(n, dt, t_end).tolist()}
    return tip_history, segmented


def test_study_reference_is_announced_stored_by_parts_and_resumed(tmp_path, monkeypatch, capsys):
    from ancf_sym.study import dynamics_studies, run_study
    out = tmp_path / "rope"
    sweep = {"integrator": ["hht"], "dt": [2e-3], "n": [8]}
    calls: list = []
    tip_history, segmented = _fakes(calls, stop_at=3)
    monkeypatch.setattr(dynamics_studies, "_tip_history", tip_history)
    monkeypatch.setattr(dynamics_studies, "_segmented_history", segmented)
    with pytest.raises(KeyboardInterrupt):  # Ctrl-C in the second piece of the reference's third run
        run_study("rope", out, quick=True, jobs=1, sweep=sweep, target=2e-3)
    err = capsys.readouterr().err
    assert err.index("computing the reference first") < err.index("reference part 1/4")
    assert "interrupted while computing the reference; 2 finished part(s) and 1 checkpoint(s)" in err
    stored = sorted(f.name for f in (out / "reference").iterdir())
    assert len(stored) == 3 and sum(f.endswith(".partial.json") for f in stored) == 1, stored
    assert not (out / "reference.json").exists()

    calls.clear()
    tip_history, segmented = _fakes(calls)
    monkeypatch.setattr(dynamics_studies, "_tip_history", tip_history)
    monkeypatch.setattr(dynamics_studies, "_segmented_history", segmented)
    rep = run_study("rope", out, quick=True, jobs=1, sweep=sweep, target=2e-3)
    err = capsys.readouterr().err
    assert err.count("stored, reused") == 2 and "resumed from its checkpoint" in err and "part 4/4" in err
    # the stored parts are not run again, the interrupted one continues from its checkpoint (piece 1)
    ref_calls = [c for c in calls if c[0] == "radau"]
    assert [c[3] for c in ref_calls] == [1, None], calls
    assert calls[-1][:2] == ("hht", 8), calls
    assert not list((out / "reference").glob("*.partial.json"))
    ref = json.loads((out / "reference.json").read_text())
    assert ref["success"] and ref["wall_s"] > 0 and rep.complete
    # report.md states the target that was given, not the study's default (1e-2)
    report = (out / "report.md").read_text()
    assert "<= 0.002 (as given)" in report and "Default target 1e-2" in report
    # a third run reads reference.json: no reference run at all
    calls.clear()
    run_study("rope", out, quick=True, jobs=1, sweep=sweep)
    assert "radau" not in [c[0] for c in calls] and "the study's default" in (out / "report.md").read_text()


def test_reference_in_pieces_equals_one_run():
    """The reference's checkpointed Radau run (pieces restarted from the saved coordinates and velocities) follows
    the one-piece run: a one-step method with a fixed step, so the pieces differ only by each step's Newton
    tolerance (the residual tolerance on ~1e3 N forces moves the tip by ~1e-10 m; asserted at 1e-8 of the 2.4 m
    tip travel, far below the reference's own error bound of ~1e-5)."""
    from ancf_sym.study import dynamics_studies as D
    rec, tip = D._tip_history(D.rope_scene(8), "radau", 2e-3, 1.0, "rope")
    saved: list = []
    seg = D._segmented_history(D.rope_scene(8), 2e-3, 1.0, "rope", save=saved.append)
    a, b = np.asarray(tip), np.asarray(seg["tip"])
    assert a.shape == b.shape == (101, 2) and seg["steps"] == rec["steps"] == 500
    travel = np.linalg.norm(a - a[0], axis=1).max()
    assert np.abs(a - b).max() < 1e-8 * travel
    assert len(saved) == D.REFERENCE_SEGMENTS - 1  # a checkpoint after every piece but the last
    # resuming from a checkpoint gives the same history
    resumed = D._segmented_history(D.rope_scene(8), 2e-3, 1.0, "rope", state=json.loads(json.dumps(saved[4])))
    assert np.abs(np.asarray(resumed["tip"]) - b).max() < 1e-8 * travel
