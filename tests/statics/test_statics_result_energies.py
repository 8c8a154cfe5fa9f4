"""A static result's energies by label and its full gradient (clamp reactions) come from the energy-only kernels
and the Newton evaluation (statics_eval.ResultEnergies), not from the Assembly's general evaluation: they must be
the Assembly's values.

Tolerance: both evaluate the same symbolic energies; they differ in the order of summation and in the kernels'
code (fused and SIMD-batched against one scalar kernel per effect), i.e. by round-off of the summed contributions.
Energies: 1e3 eps x the sum of the absolute per-label energies. Gradient: 10 x the residual's round-off level
eps x max|K| x span that the Newton solve reports (inside the kernels, forces ~ stiffness x span are formed and
cancel: EA (r_x . r_x - 1) carries eps EA)."""
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.statics import problem_for
from ancf_sym.study.statics_studies import elastica_scene, zhang_scene

EPS = np.finfo(float).eps


def _penalty_frame() -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    mat, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    s.member("a", [(0, 0), (0.5, 0)], 3, mat, sec)
    s.member("b", [(0.5, 0), (0.5, -0.5)], 5, mat, sec, axial="green")
    s.clamp("a", "start")
    s.rigid(("a", "end"), ("b", "start"), method="penalty", penalty=(1e3, 0.1))
    s.force("b", "end", (40.0, -100.0))
    return s


def _cable3d() -> Scene:
    s = Scene(dim=3, gravity=(0, 0, -9.81))
    s.member("beam", [(0, 0, 0), (1.0, 0, 0)], 7, Material(E=5e9, density=1200), Section.circle(0.004),
             axial="decoupled", gauss=3)
    s.clamp("beam", "start")
    s.moment("beam", "end", (0.0, 0.0, 0.002))
    return s


SCENES = {
    "decoupled 6": lambda: zhang_scene("decoupled", 6, 5),
    "green 18": lambda: zhang_scene("green", 18, 5),
    "biot 7 tip force": lambda: elastica_scene("biot", 7, 3),
    "penalty joint, point load": _penalty_frame,
    "3D decoupled cable, moment": _cable3d,
}


@pytest.mark.parametrize("name", SCENES)
def test_result_energies_and_gradient_are_the_assemblys(name):
    scene = SCENES[name]()
    r = solve_static(scene)
    assert r.success, r.attempts
    prob = problem_for(scene)
    assert prob.light is not None, "the kernel path (no multiplier rows) is what this checks"
    a = prob.asm
    ref = a.evaluate(r.x, hessian=False)
    fast = prob._evaluation(r.x)
    assert set(fast.energies) == set(ref.energies) == set(r.energies)
    scale = sum(abs(v) for v in ref.energies.values())
    for k, v in ref.energies.items():
        assert abs(fast.energies[k] - v) <= 1e3 * EPS * scale, (k, fast.energies[k], v)
    assert r.residual_floor > 0
    assert np.max(np.abs(fast.gradient - ref.gradient)) <= 10 * r.residual_floor
    assert abs(r.potential - ref.energy) <= 1e3 * EPS * scale


def test_clamp_reaction_balances_the_weight():
    """The clamp's force reaction (from the full gradient) equals the cantilever's weight rho A g L (equilibrium
    of the whole cantilever; the solve's own tolerance 1e-10 bounds the residual far below 1e-9 of it)."""
    from ancf_sym.study.statics_studies import ZA, ZG, ZL, ZRHO
    for strain, n in (("decoupled", 6), ("green", 18)):
        r = solve_static(zhang_scene(strain, n, 5))
        f = np.asarray(r.constraint_forces["clamp beam start"] if "clamp beam start" in r.constraint_forces
                       else next(iter(r.constraint_forces.values())))
        w = ZRHO * ZA * ZG * ZL
        assert abs(abs(f[1]) - w) <= 1e-9 * w and abs(f[0]) <= 1e-9 * w, (strain, f[:2], w)


def test_details_are_worked_out_on_first_access_at_the_results_point(monkeypatch):
    """A solve does not evaluate the energies by effect (a result pays for them where they are read); read later,
    after the problem has evaluated elsewhere and solved again, they are those at the result's own x, once."""
    from ancf_sym.statics.evaluation import ResultEnergies
    calls = []
    energies = ResultEnergies.energies
    monkeypatch.setattr(ResultEnergies, "energies", lambda self, x: calls.append(1) or energies(self, x))
    scene = _penalty_frame()
    r = solve_static(scene)
    assert r.success and not calls
    prob = problem_for(scene)
    prob.light.ev.evaluate(prob.asm.x0)  # the problem's buffers now hold another point
    solve_static(_penalty_frame(), warm_start=r.x + 1e-4)
    ref = prob.asm.evaluate(r.x, hessian=False)
    scale = sum(abs(v) for v in ref.energies.values())
    assert all(abs(r.energies[k] - v) <= 1e3 * EPS * scale for k, v in ref.energies.items())
    assert len(calls) == 1
    assert r.constraint_forces and r.constraint_violation >= 0.0 and r.energies and len(calls) == 1  # once
