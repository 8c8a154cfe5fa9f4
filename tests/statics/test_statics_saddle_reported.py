"""A saddle the solve cannot leave is not reported as a success (statics/problem.py, stability): with
escape_saddle (the default) the user asked for a minimum of the potential, and an equilibrium with a direction of
negative curvature is not one. The straight column past its Euler load is the saddle; its way out (the elastica) is
found by the real solve, so the test takes that way away."""
from __future__ import annotations

import math

import numpy as np

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.statics.problem import StaticProblem


def column(lam: float) -> Scene:
    s = Scene(dim=2)
    s.member("c", points=[(0, 0), (0, 1.0)], elements=16, material=Material(E=1e7, density=1.0),
             section=Section(area=1e-0, I=1e-7), axial="decoupled", gravity=False)
    s.clamp("c", "start")
    s.force("c", "end", (0.0, -lam * math.pi**2 / 4))
    return s


def test_saddle_without_a_way_out_is_not_a_success(monkeypatch):
    monkeypatch.setattr(StaticProblem, "_leave_saddle",
                        lambda self, x, direction, status, opts, work, attempts: (x, status, False, 0))
    r = solve_static(column(2.0))
    assert not r.success and r.status == "Unstable_Stationary_Point" and r.stable is False
    assert np.all(np.isfinite(r.x)) and abs(r.tip("c")[0]) < 1e-12  # (the saddle itself, for inspection)
    assert "unstable" in r.attempts[-1]["detail"]


def test_saddle_asked_for_is_a_success():
    """escape_saddle=False: the user accepts an unstable equilibrium; it is reported as one."""
    r = solve_static(column(2.0), escape_saddle=False)
    assert r.success and r.stable is False
