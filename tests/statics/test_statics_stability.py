"""Regression: the saddle test of solve_static must see a straight column past its Euler load as unstable even when
the axial stiffness dwarfs the bending stiffness (EA L^2/EI = 1e7: a 1.3 mm steel wire 1 m long has 1.6e7).

Before the fix, StaticProblem.stability called an eigenvalue negative only below -1e-10 ||H_reduced||. For a clamped-
free column with EA L^2/EI = 1e7 and 32 elements ||H_reduced|| = 1.5e9 while the straight state's negative eigenvalue
at 2 P_cr is -0.063: solve_static returned the straight column with stable=True after 2 iterations, never trying to
leave the saddle. The eigenvalues' round-off floor is eps ||H_reduced|| (a true zero mode measures within 0.2 of it).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.statics import StaticProblem

EI, L = 1.0, 1.0
P_CR = math.pi**2 * EI / (4 * L**2)


def column(lam: float, EA: float = 1e7, n: int = 32) -> Scene:
    s = Scene(dim=2)
    s.member("c", points=[(0, 0), (0, L)], elements=n, material=Material(E=1e7, density=1.0),
             section=Section(area=EA / 1e7, I=EI / 1e7), axial="decoupled", gravity=False)
    s.clamp("c", "start")
    s.force("c", "end", (0.0, -lam * P_CR))
    return s


@pytest.mark.parametrize("EA", [1e5, 1e7])
def test_straight_column_past_euler_load_is_a_saddle(EA):
    r = solve_static(column(2.0, EA), escape_saddle=False)
    assert r.success and abs(r.tip("c")[0]) < 1e-12
    assert r.stable is False


def test_column_leaves_the_saddle_to_the_elastica():
    r = solve_static(column(2.0))
    assert r.success and r.stable is True
    assert any(a["method"].startswith("leave saddle") for a in r.attempts), r.attempts
    k = brentq(lambda k: (2 * ellipk(k * k) / math.pi) ** 2 - 2.0, 1e-12, 1 - 1e-15)
    # elastica tip deflection 2kL/K(k) = 0.79696 m; 32 elements and EA L^2/EI = 1e7 reach it within 1e-5 m
    assert abs(r.tip("c")[0]) == pytest.approx(2 * k * L / ellipk(k * k), abs=1e-4)


def test_no_false_alarm_below_the_euler_load_or_on_a_zero_mode():
    r = solve_static(column(0.99), escape_saddle=False)
    assert r.stable is True
    # a bar held by one pin only, no load: its free rotation is an exactly zero mode, neither stable nor unstable in
    # exact arithmetic; round-off must not make it look like negative curvature
    for EA in (1e5, 1e10):
        s = Scene(dim=2)
        s.member("b", points=[(0, 0), (np.cos(0.7), np.sin(0.7))], elements=64, material=Material(E=1e7, density=1.0),
                 section=Section(area=EA / 1e7, I=1e-7), axial="decoupled", gravity=False)
        s.pin("b", "start")
        p = StaticProblem(s)
        assert p.stability(p.asm.x0)[0] is True
