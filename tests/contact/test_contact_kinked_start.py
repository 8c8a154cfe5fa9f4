"""A rope over a drum with a linear penalty law: statics must not settle on a higher-potential state.

The scene: a light rope (no bending stiffness) of the capstan set-up (legs of 0.6 m, a drum of R = 0.1 m) with a
1 kg mass member hinged at each end, pinned at its middle node, starting straight and level 0.1 m above the drum,
linear law k = 1e6 N/m^2. Before the contact step limit (ancf_sym.contact.steps) IPOPT's full steps pulled the
left leg through the drum: statics reported a stable success with both legs on the right of the drum, kinked round
it, at -10.127 J (measured), where the Hertz law (or any path that stays outside the drum) gives -10.634 J with
one leg on each side.
"""
from __future__ import annotations

import math

import numpy as np

from ancf_sym import Material, Scene, Section, contact
from ancf_sym.statics import problem as statics
from ancf_sym.statics import solve_static

G, R, LEG, LM = 9.81, 0.1, 0.6, 0.05
ROPE, SEC, MASS_SEC = Material(E=1e10, density=300.0), Section.circle(0.003), Section.circle(0.02)


def rope_over_drum(law: dict, n: int = 20, y: float = 2 * R) -> Scene:
    """The rope level at height y, its middle node pinned (at x = 0)."""
    L = 2 * LEG + math.pi * R
    x0 = -L / 2
    sc = Scene(dim=2, gravity=(0.0, -G))
    for nm, a, b, m in (("mass_l", x0 - LM, x0, 1.0), ("rope", x0, x0 + L, None), ("mass_h", x0 + L, x0 + L + LM, 1.0)):
        mat = ROPE if m is None else Material(E=ROPE.E, density=m / (LM * MASS_SEC.area))
        sc.member(nm, [(a, y), (b, y)], n if m is None else 2, mat, SEC if m is None else MASS_SEC,
                  bending=m is not None)
    sc.hinge(("mass_l", "end"), ("rope", "start"))
    sc.hinge(("rope", "end"), ("mass_h", "start"))
    sc.pin("rope", n // 2)
    sc.contact_drum("rope", (0.0, 0.0), R, **law)
    return sc


def test_linear_law_reaches_the_state_of_the_hertz_law():
    """Linear law k = 1e6: success, stable, one leg on each side of the drum (the masses' x on either side, beyond
    the drum's radius), and the potential of the Hertz-law solution: the two laws differ only in how far the rope
    sinks into the drum (line pressure ~ T / R ~ 100 N/m: 1e-4 m linear, 2e-5 m Hertz), which moves the 2 kg of
    masses by less than that: |dPi| < 20 N x 1e-4 m x 2.5 = 5e-3 J (measured 1.1e-3 J), far below the 0.5 J by which
    the kinked state lies higher. The drum carries the rope (a positive normal force)."""
    statics._CACHE.clear()
    lin = solve_static(rope_over_drum({"stiffness": 1e6}))
    hertz = solve_static(rope_over_drum({"hertz": 1e9}))
    assert lin.success and lin.stable, (lin.status, lin.attempts)
    assert hertz.success and hertz.stable
    assert lin.tip("mass_l")[0] < -R < R < lin.tip("mass_h")[0]
    assert abs(lin.potential - hertz.potential) < 5e-3
    assert lin.potential < -10.6  # (the kinked state: -10.127 J)
    (rep,) = contact.report(lin.assembly, lin.x)
    assert rep["normal_force"] > 0


def test_start_through_the_drum_is_refused_with_the_reason():
    """The same rope starting level through the drum's centre (8 contact points within half a radius of the axis,
    where the law's normal is arbitrary): before the step limit statics reported a stable success at +328 J with
    the rope inside the drum (measured); now no solve path may carry points across the axis, and the failure names
    the member and the drum."""
    r = solve_static(rope_over_drum({"stiffness": 1e6}, y=0.0))
    assert not r.success and r.status == statics.TUNNELLED
    assert "member 'rope'" in r.attempts[-1]["detail"] and "radius 0.1" in r.attempts[-1]["detail"]
    assert np.all(np.isfinite(r.x))
