"""Statics regressions.

Exact joint constraints handed to IPOPT must be the ones the scene states:

Assembly._casadi_constraint once filled a CasADi sparsity with row-major (CSR) data; CasADi stores non-zeros
column-major, so a hinge's rows r_a - r_b = 0 became r_a + r_b = 0 and a T-frame converged with its crossbar
mirrored through the origin (violation ~2 m, IPOPT reporting success)."""
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static


def _t_scene(kind: str) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    mat, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    s.member("post", [(0, 0), (0, 1)], elements=4, material=mat, section=sec)
    s.member("bar", [(-0.5, 1), (0.5, 1)], elements=4, material=mat, section=sec)
    s.clamp("post", "start")
    getattr(s, kind)(("post", "end"), ("bar", 2))
    s.force("bar", "end", (0, -100))
    return s


def test_joints_hold_exactly():
    for kind in ("hinge", "rigid"):
        r = solve_static(_t_scene(kind))
        assert r.success and r.constraint_violation < 1e-9, (kind, r.status, r.constraint_violation)
        assert np.allclose(r.nodes("post")[-1], r.nodes("bar")[2], atol=1e-9)
        assert r.nodes("bar")[2][1] > 0.9  # the joint stays near the top of the post


def test_full_steps_landing_above_the_start_are_rejected():
    """A beam3d arm hinged to a bending-free cable under a distributed load: IPOPT's full steps (from the singular
    tangent of the straight cable) converged to a stationary point with potential +9.1e5 J, far above the reference
    configuration's 0 J, and it was reported as the solution. A minimiser started at a feasible point cannot rightly
    end higher: such a result is rejected and the line-search attempt finds the minimum (about -6.41 J)."""
    s = Scene(dim=3, gravity=(0, 0, -9.81))
    steel, sq = Material(E=200e9, density=7800), Section.rectangle(0.02, 0.02)
    s.member("arm", [(0, 0, 0), (1, 0, 0)], elements=6, material=steel, section=sq, element="beam3d",
             beam_method="elastic_line", torsion=True, y_axis=(0, 1, 0))
    s.member("rope", [(1, 0, 0), (1, 1, 0)], elements=6, material=steel, section=sq, bending=False)
    s.clamp("arm")
    s.hinge(("arm", "end"), ("rope", "start"))
    s.pin("rope", at=-1)
    s.moment("arm", "end", (0, 0, 5))
    s.distributed("rope", (0, 0, -100))
    r = solve_static(s)
    assert r.success and r.potential < 0, (r.attempts, r.energies)
    assert r.potential == pytest.approx(-6.41, abs=0.01)
    methods = [a["method"] for a in r.attempts]
    full = r.attempts[methods.index("ipopt full steps")]
    assert full.get("rejected") or full["status"] not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"), r.attempts
    assert "ipopt line search" in methods and r.path == "ipopt+newton", r.attempts


def test_joint_penalty_takes_separate_position_and_slope_factors():
    """A rigid joint with penalty = (C1, C2): position rows get C1 EA/1 m, slope rows C2 EI/1 m (paper 002 sets
    them apart: 1e3 EA/L and 0.1..100 EI/L)."""
    from ancf_sym import Material, Scene, Section
    from ancf_sym.model.assembly import Assembly

    s = Scene(dim=2)
    mat, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    s.member("a", [(0, 0), (0.5, 0)], 2, mat, sec)
    s.member("b", [(0.5, 0), (0.5, -0.5)], 2, mat, sec)
    s.pin("a", "start")
    s.rigid(("a", "end"), ("b", "start"), method="penalty", penalty=(1e3, 0.1))
    pen = Assembly(s).penalty
    EA, EI = 200e9 * sec.area, 200e9 * sec.I
    kinds = ["position" if abs(k - 1e3 * EA) < 1e-6 * EA else "slope" if abs(k - 0.1 * EI) < 1e-9 * EI else "?"
             for k in pen.k]
    assert kinds == ["position", "position", "slope"]
