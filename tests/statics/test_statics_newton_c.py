"""The statics Newton loop in C (ancf_sym.statics.newton_loop) against the Python loop it replaces (statics_newton).

Both loops do the same floating-point operations in the same order: the same kernels on the same inputs, the
scatters summed in index order (numpy's bincount), sums pairwise as numpy's sum adds them, the same LAPACK calls
(dpbtrf / dpbtrs, dgbsv) on the same band. So every decision (Cholesky or LU, a step accepted on its potential,
the shift, the convergence / stall / round-off / divergence tests) comes out the same, and the runs agree: equal
status, iteration count and history, and x within 1e-12 L. That bound leaves room only for the last bits of a sum
added in another order (a numpy whose summation the C loop does not mirror): such a difference of a few eps in a
residual moves Newton's converged answer by a few eps times the condition of the tangent, ~1e-13 L here; a
different decision anywhere would move it by a whole update (>= 1e-11 L even in the last converged step).
"""
from __future__ import annotations

import signal

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.statics import newton as statics_newton
from ancf_sym.statics.inertia import STABILITY_EPS
from ancf_sym.statics import BIOT_MAX_ITER, BIOT_TOL, StaticProblem
from ancf_sym.study.statics_studies import elastica_scene, zhang_scene

from test_beam_locking import _cantilever as beam3d_cantilever
from test_statics_newton import _two_members, cantilever


def _free_cable() -> Scene:
    """A cable with no support under a tip force: Newton diverges (a rigid motion has no restoring force)."""
    s = Scene(dim=2, gravity=(0, 0))
    s.member("c", [(0, 0), (1, 0)], 4, Material(E=1e7, density=1.0), Section(area=1e-2, I=1e-7), axial="green",
             gravity=False)
    s.force("c", "end", (0.0, -1.0))
    return s


def _cable3d(n: int) -> Scene:
    """Paper 000's cantilever in space (Green strain, gravity along -z)."""
    s = Scene(dim=3, gravity=(0, 0, -9.81))
    s.member("beam", [(0, 0, 0), (3.0, 0, 0)], n, Material(E=20e9, density=7200),
             Section(area=7.854e-5, I=4.909e-10), axial="green", gravity=True)
    s.clamp("beam", "start")
    return s


# case -> (scene, which KernelNewton ("light" or "biot"), solve keywords, the branch counts the C run must show)
CASES = {
    "zhang green 18": (lambda: zhang_scene("green", 18, 5), "light", {}, {"indefinite": 0}),
    "zhang decoupled 6, rod-Biot start (indefinite: LU step)":
        (lambda: zhang_scene("decoupled", 6, 5), "biot", {"tol": BIOT_TOL, "max_iter": BIOT_MAX_ITER},
         {"indefinite": 1, "shifted": 0}),
    "decoupled 6 from the straight beam (shifted steps)":
        (lambda: cantilever(6, "decoupled"), "light", {}, {"shifted": 1}),
    "green 3 from the straight beam (shifted step, stalls)": (lambda: cantilever(3, "green"), "light", {}, {"shifted": 1}),
    "green 6 from the straight beam": (lambda: cantilever(6, "green"), "light", {}, {}),
    "elastica green 10": (lambda: elastica_scene("green", 10, 5), "light", {}, {}),
    "elastica decoupled 10": (lambda: elastica_scene("decoupled", 10, 5), "light", {}, {}),
    "green 1200, element-local positions": (lambda: cantilever(1200, "green"), "light", {}, {}),
    "beam3d 8, scalar kernels (no batch)": (lambda: beam3d_cantilever("continuum", 8, 0.3, 2, -1e3), "light", {}, {}),
    "cable3d 400, element-local positions": (lambda: _cable3d(400), "light", {}, {}),
    "load 0.4": (lambda: zhang_scene("green", 18, 5), "light", {"load": 0.4}, {}),
    "max_step 0.1 L (stalls)": (lambda: zhang_scene("green", 18, 5), "light", {"max_step": 0.1}, {}),
    "max_iter 3": (lambda: zhang_scene("decoupled", 6, 5), "light", {"max_iter": 3}, {}),
    "free cable (diverges)": (_free_cable, "light", {"max_iter": 10}, {}),
}


def _newton(problem: StaticProblem, which: str):
    if which == "biot":
        problem.solve()  # builds the Biot start's KernelNewton (its own evaluation variant)
        return problem._biot
    return problem.light


@pytest.mark.parametrize("case", list(CASES))
def test_c_loop_takes_the_python_loops_steps(case, monkeypatch):
    scene, which, kw, branches = CASES[case]
    p = StaticProblem(scene())
    kn = _newton(p, which)
    args = (p.asm.x0, kw.get("tol", 1e-10), kw.get("max_iter", 60), p.work)
    opts = {"load": kw.get("load", 1.0), "max_step": kw.get("max_step", np.inf), "finish": STABILITY_EPS}
    c = kn.solve(*args, **opts)
    assert kn._loop, "this scene is one the C loop takes"
    counts = kn._loop.counts
    for key, least in branches.items():
        assert counts[key] >= least if least else counts[key] == 0, (key, counts)
    monkeypatch.setattr(statics_newton, "PYTHON_LOOP", True)
    py = kn.solve(*args, **opts)
    assert (c.status, c.iterations, len(c.history)) == (py.status, py.iterations, len(py.history))
    assert np.max(np.abs(c.x - py.x)) <= 1e-12 * p.asm.mesh.length_scale
    # the finish at a converged answer: its potential (to round-off of the summed element energies, 1e-12 of the
    # load work) and the stability test, as the Python loop and the stability check find them
    assert c.stable == py.stable
    if c.converged:
        assert abs(c.potential - py.potential) <= 1e-12 * p.work
        assert c.stable == p.stability(c.x)[0]
        if opts["load"] == 1.0 and which == "light":  # (the Biot start minimises another strain energy)
            assert abs(c.potential - p.asm.energy(c.x)) <= 1e-12 * p.work
    else:
        assert np.isnan(c.potential) and np.isnan(py.potential) and c.stable is None
    if case.startswith("elastica"):  # (the evaluation keeps where the loop evaluated last: callers read it)
        ev = kn.ev
        g, e = ev.g.copy(), ev.energy
        ev.evaluate(ev.at)
        assert np.allclose(ev.g, g, rtol=1e-12, atol=0) and e == pytest.approx(ev.energy, rel=1e-12)


@pytest.mark.parametrize("scene", [lambda: zhang_scene("green", 18, 5), lambda: zhang_scene("decoupled", 6, 5),
                                   lambda: elastica_scene("green", 10, 5), lambda: cantilever(60, "green")],
                         ids=["zhang green 18", "zhang decoupled 6", "elastica green 10", "green 60"])
def test_solve_static_answers_unchanged(scene, monkeypatch):
    """The whole solve (Biot start, Newton, stability check) with the C loop and with the Python loop: the same
    path, iterations and tip (within 1e-12 m, the runs' bound above for L ~ 1-3 m)."""
    c = solve_static(scene())
    monkeypatch.setattr(statics_newton, "PYTHON_LOOP", True)
    py = StaticProblem(scene()).solve()
    assert c.success and py.success
    assert (c.path, c.iterations, c.stable) == (py.path, py.iterations, py.stable)
    assert np.max(np.abs(c.tip("beam") - py.tip("beam"))) <= 1e-12


def test_penalty_springs_keep_the_python_loop():
    """Penalty rows are evaluated outside the kernels (statics_eval): such scenes keep the Python loop, and solve."""
    p = StaticProblem(_two_members("green"))
    r = p.solve()
    assert p.light._loop is False and r.success


def test_ctrl_c_stops_the_c_loop_between_iterations():
    """The C loop checks Python's signals before every iteration: a handler that raises stops the solve from inside
    the loop (the run's status is still unset, some evaluations done), as Ctrl-C does. A timer signals every 5 ms;
    its handler raises only while the C loop runs, so the test fails if the loop never looks at signals."""
    p = StaticProblem(cantilever(600, "green"))
    kn = p.light
    kn.solve(p.asm.x0, 1e-10, 1, p.work)  # binds the loop
    run = kn._loop._run

    class Stop(Exception):
        pass

    def handler(signum, frame):
        if run.status == -1 and run.evaluations >= 1:
            raise Stop

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, 0.005, 0.005)
    try:
        with pytest.raises(Stop):
            for _ in range(50):
                kn.solve(p.asm.x0, 1e-300, 40, p.work)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)
    assert kn.ev.at is not None and np.all(np.isfinite(kn.ev.g))  # the evaluation holds the loop's last point
    assert kn.solve(p.asm.x0, 1e-10, 60, p.work).converged  # and the next solve runs as ever
