"""The statics engine's convergence test: relative, the same at any mesh size, never the start state under load.

Paper 000's cantilever (L = 3 m, E = 20 GPa, gravity, clamped). Before the relative test: from 3828 elements the
solve was refused (an absolute residual tolerance tied to the gradient's round-off floor, which grows like n^3 while
the nodal loads shrink like 1/n), and `tol=1e-2` at 6000 elements returned the straight start as an equilibrium.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.statics import StaticProblem

L = 3.0


def cantilever(n: int, axial: str = "biot", E: float = 20e9, gravity: bool = True) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81) if gravity else (0, 0))
    s.member("beam", [(0, 0), (L, 0)], n, Material(E=E, density=7200), Section(area=7.854e-5, I=4.909e-10),
             axial=axial, gravity=gravity)
    s.clamp("beam", "start")
    return s


def continued_tip(problem: StaticProblem, x: np.ndarray, steps: int = 4) -> np.ndarray:
    """Tip after `steps` more full Newton steps (the discrete solution, to round-off)."""
    run = problem.newton.solve(x, 1e-300, steps, problem.work)
    return problem.S.full(problem.newton.x)[problem.asm.mesh.members["beam"].offset:][-4:-2] if run.iterations \
        else x[-4:-2]


@pytest.mark.parametrize("n", [60, 6000])
def test_answer_is_the_discrete_solution_at_any_mesh_size(n):
    """Newton converges on the first path at 60 and 6000 elements (6000 was refused before); the answer lies within
    1e-9 m of the discrete solution (checked by continuing Newton: the promise of tol = 1e-10 is ~tol^2 L after the
    last update, so 1e-9 m leaves room for round-off only). The tip is paper 000's, 1.5732 / -2.3670 m (Biot)."""
    p = StaticProblem(cantilever(n))
    r = p.solve()
    assert r.success and r.path == "newton" and r.stable is True, (r.status, r.attempts)
    assert r.increment <= 1e-10 and r.energy_decrement <= 1e-10
    tip = r.tip("beam")
    assert np.linalg.norm(continued_tip(p, r.x) - tip) < 1e-9
    assert tip == pytest.approx([1.5732, -2.3670], abs=2e-4)


@pytest.mark.parametrize("tol", [1e-2, 0.5])
def test_a_loose_tol_never_accepts_the_start_state(tol):
    """tol is relative: the last applied Newton update was at most tol L. The start's update is the loads' response
    (5.7 m here) and is applied before any test, so the answer has moved; with the update <= tol L the answer is
    within tol L of the solution (the updates contract from there)."""
    ref = solve_static(cantilever(600)).tip("beam")
    r = solve_static(cantilever(600), tol=tol)
    assert r.success and r.iterations >= 1
    assert np.linalg.norm(r.tip("beam") - ref) <= tol * L


def test_nothing_loads_it_solved_at_the_start():
    """No gravity, no load: the start shape is the equilibrium (was refused as 'round-off floor above loads')."""
    s = cantilever(10, gravity=False)
    r = solve_static(s)
    assert r.success and r.path == "start" and r.iterations == 0 and r.stable is True
    assert np.array_equal(r.x, r.assembly.x0)


def test_stability_reported_above_1500_coordinates():
    """A clamped column past its Euler load with 500 elements (2000 coordinates; the dense check stopped at 1500):
    the straight state is a saddle (inertia: one negative eigenvalue), below the load it is stable."""
    def column(lam):
        s = Scene(dim=2)
        s.member("c", [(0, 0), (0, 1)], 500, Material(E=1e7, density=1.0), Section(area=1e-2, I=1e-7),
                 axial="decoupled", gravity=False)
        s.clamp("c", "start")
        s.force("c", "end", (0.0, -lam * np.pi**2 / 4))
        return s
    r = solve_static(column(2.0), escape_saddle=False)
    assert r.success and r.stable is False
    assert solve_static(column(0.9), escape_saddle=False).stable is True


def test_interrupted_ipopt_raises_keyboard_interrupt(monkeypatch):
    """IPOPT swallows SIGINT and returns 'User_Requested_Stop': the solve must stop (KeyboardInterrupt), not go on
    to the next attempt as if IPOPT had merely failed."""
    p = StaticProblem(cantilever(4))

    class Stopped:
        def __call__(self, **kw):
            return {"x": p.asm.x0, "lam_g": np.zeros(p.asm.exact.m)}

        def stats(self):
            return {"return_status": "User_Requested_Stop", "iter_count": 3}

    monkeypatch.setattr(p, "solver", lambda line_search, opts: Stopped())
    with pytest.raises(KeyboardInterrupt):
        p._run(p.asm.x0, None, 1.0, False, None)


def test_indefinite_tangent_steps_go_downhill():
    """Paper 000's cantilever on 6 decoupled elements: Newton passes through states where the tangent is indefinite;
    plain Newton steps there climbed out of the valley again and again (stalled after 11 iterations, then 24 more in
    load steps). Shifted steps that must lower the potential converge in the first Newton run, to the discrete
    solution (continued Newton moves the tip < 1e-9 m), whose tip lies within the 6-element discretisation error
    (the zhang_cantilever study: 5.8e-4 of the 2.6 m displacement, < 2e-3 m) of the rod's 1.5732 / -2.3670 m."""
    p = StaticProblem(cantilever(6, axial="decoupled"))
    run = p.newton.solve(p.asm.x0, 1e-10, 30, p.work)  # from the straight beam, without the Biot start
    assert run.converged, run.status
    tip = p.asm.member_coordinates(run.x, "beam")[-1, :2]
    assert np.linalg.norm(continued_tip(p, run.x) - tip) < 1e-9
    assert tip == pytest.approx([1.5732, -2.3670], abs=2e-3)


@pytest.mark.parametrize("n", [3, 6, 9])
def test_decoupled_starts_from_its_rod_with_biot_strain(n):
    """The decoupled strain's equivalent rod with Biot strain r_D,x - 1 instead of Green (r_D,x^2 - 1) / 2: the two
    energies differ by O(strain^2) ~ 1e-10 relative here (strain ~1e-5 under gravity), so its solution lies inside
    the decoupled Newton's quadratic basin: at most 3 updates from there to 1e-10 (the coupled Biot solution was no
    start: 6 elements 13 + 21 iterations). The answer is the one Newton reaches from the straight beam (within
    1e-9 m, the accuracy asked of every answer)."""
    p = StaticProblem(cantilever(n, axial="decoupled"))
    r = p.solve()
    first = r.attempts[0]
    assert r.success and first["biot_start"]["used"] and first["iterations"] <= 3, r.attempts
    run = p.newton.solve(p.asm.x0, 1e-10, 60, p.work)
    assert run.converged
    assert np.linalg.norm(p.asm.member_coordinates(run.x, "beam")[-1, :2] - r.tip("beam")) < 1e-9


def _two_members(axial: str) -> Scene:
    """Two Green/decoupled cables joined by a penalty hinge, the first clamped, gravity and a tip moment: fused and
    unfused kernels, penalty rows, a moment term and eliminated supports in one scene."""
    s = Scene(dim=2, gravity=(0, -9.81))
    kw = dict(material=Material(E=2e9, density=7800), section=Section(area=1e-4, I=1e-9), axial=axial)
    s.member("a", [(0, 0), (0.5, 0)], 5, **kw)
    s.member("b", [(0.5, 0), (1.0, 0.2)], 4, **kw)
    s.clamp("a", "start")
    s.hinge(("a", "end"), ("b", "start"), method="penalty")
    s.moment("b", "end", 0.3)
    return s


@pytest.mark.parametrize("axial", ["green", "decoupled"])
def test_kernel_evaluation_is_the_assembly_reduced(axial):
    """The Newton's evaluation on the free coordinates (kernels called directly, fused where possible, gathered by
    index maps, penalties added) is the Assembly's gradient and Hessian reduced to the free coordinates, and its
    Biot variant is the Assembly of the same scene with each axial kernel swapped for its start measure's (Green ->
    coupled Biot, decoupled -> the decoupled rod with Biot strain): the same kernel values summed in another order,
    so they agree to round-off (1e-10 of the largest entry leaves ~5 orders of magnitude for the summation order).
    Member "a" (5 elements) is evaluated padded to whole SIMD batches (8): the padding's outputs must be dropped."""
    import dataclasses

    from ancf_sym.model.assembly import Assembly, MappedKernel
    from ancf_sym.statics.evaluation import BIOT
    p = StaticProblem(_two_members(axial))
    R, ev = p.S, p.light.ev
    assert any(n > ft.N for ft, n in zip(ev.fts, ev.padded))  # the padded path is the one checked
    x = R.full(R.reduce(p.asm.x0) + 0.02 * np.random.default_rng(1).standard_normal(R.nf))
    for evaluation, start in ((ev, False), (ev.variant(BIOT), True)):
        asm = Assembly(_two_members(axial))
        if start:
            asm.mapped = [MappedKernel(dataclasses.replace(mk.term, effect=BIOT.get(mk.term.effect, mk.term.effect)))
                          for mk in asm.mapped]
            asm.curved = [mk for mk in asm.mapped if not mk.linear]
        ref = asm.evaluate(x)
        g_ref = R.reduce_force(ref.gradient + asm.constant_force())
        K_ref = (R.E.T @ ref.hessian @ R.E).toarray()
        evaluation.evaluate(x)
        K = evaluation.matrix().toarray()
        assert np.max(np.abs(evaluation.g - g_ref)) <= 1e-10 * np.max(np.abs(g_ref))
        assert np.max(np.abs(K - K_ref)) <= 1e-10 * np.max(np.abs(K_ref))
        assert evaluation.energy - float(asm.constant_force() @ x) == pytest.approx(ref.energy, rel=1e-10)
        ab, bw = evaluation.band(), evaluation.bw
        for d in range(bw + 1):  # LAPACK upper band: ab[bw - d, j] = K[j - d, j]
            assert np.allclose(ab[bw - d, d:], np.diagonal(K, d), rtol=0, atol=1e-10 * np.max(np.abs(K_ref)))


def test_clamp_reaction_is_the_weight_on_every_solve_of_a_cached_problem():
    """The clamp's multipliers balance the loads: by translation invariance the elastic forces sum to zero, so the
    clamp's force rows carry the whole weight rho A L g (down) and no horizontal force. The second solve of a scene
    with the same content reuses the cached problem (and its multiplier structure): it must report the same balance.
    Tolerance 1e-8 of the weight: the residual after the converged update is far below tol x the loads, and its
    round-off eps x max|K| x span (~1e-9 N at EA/l ~ 4e6 N) is below 1e-10 of the weight."""
    weight = 7200 * 7.854e-5 * L * 9.81
    for _ in range(2):
        r = solve_static(cantilever(8, "green"))
        assert r.success
        fx, fy = r.constraint_forces["clamp beam@start"][:2]
        assert abs(fx) <= 1e-8 * weight
        assert fy == pytest.approx(-weight, rel=1e-8)
