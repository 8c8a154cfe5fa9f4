"""The mooring stiffness of a free planar body held by its lines (ancf_sym.water.body_mooring_stiffness) against the
closed form of taut straight lines: per line k_axial = EA / L0 (Biot strain, L0 the natural length), k_lateral =
T / l, and for a turn theta about the centre T a + T a^2 / l (the fairlead at arm a moves a theta across the line,
and the line's force turns with the arm). Straight lines are exact for the cubic elements, so what remains is the
solve's round-off: 1e-9 relative (the equilibrium's own tolerance is far below it here)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, solve_static
from ancf_sym.water import body_mooring_stiffness

MAT, SEC = Material(E=1e9, density=1000.0), Section.circle(0.02)
EA = 1e9 * SEC.area
PRE, ARM, SPAN = 0.01, 1.0, 10.0  # prestrain (T = EA PRE), fairlead arm [m], line length between pins [m]


def moored(turn: float = 0.0, elements: int = 4) -> Scene:
    """A body at the origin between two taut lines along the direction `turn` [rad], pinned at their far ends."""
    u = np.array([math.cos(turn), math.sin(turn)])
    s = Scene(dim=2, gravity=[0.0, 0.0])
    s.body("p", 10.0, 1.0, [0.0, 0.0], angle=turn)
    for name, side in (("a", -1.0), ("b", 1.0)):
        s.member(name, [tuple(side * ARM * u), tuple(side * (ARM + SPAN) * u)], elements, MAT, SEC, axial="biot",
                 bending=False, prestrain=PRE)
        s.pin_body("p", name, "start")
        s.pin(name, at="end")
    s.set_water(density=1000.0, surface=10.0)
    return s


def closed_form() -> np.ndarray:
    T, l, L0 = EA * PRE, SPAN, SPAN / (1.0 + PRE)
    return np.diag([2 * EA / L0, 2 * T / l, 2 * (T * ARM + T * ARM**2 / l)])


@pytest.mark.parametrize("elements", [1, 4])
def test_two_taut_lines_match_the_closed_form(elements):
    r = solve_static(moored(elements=elements))
    assert r.success
    K = body_mooring_stiffness(r, "p")
    ref = closed_form()
    assert np.abs(K - ref).max() <= 1e-9 * np.abs(ref).max()


def test_turned_mooring_turns_its_stiffness():
    """The same mooring turned by 30 deg: the translational block turns as R K R^T (now coupling x and y), the
    rotational stiffness stays."""
    turn = math.radians(30.0)
    r = solve_static(moored(turn))
    assert r.success
    K = body_mooring_stiffness(r, "p")
    R = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    ref = closed_form()
    ref[:2, :2] = R @ ref[:2, :2] @ R.T
    assert abs(K[0, 1]) > 1e3  # (the coupling is there: a check that could fail)
    assert np.abs(K - ref).max() <= 1e-9 * np.abs(ref).max()


def test_a_held_body_or_a_dry_result_is_refused():
    s = moored()
    s.revolute("p")
    r = solve_static(s)
    with pytest.raises(SceneError, match="held"):
        body_mooring_stiffness(r, "p")
    with pytest.raises(SceneError, match="does not exist"):
        body_mooring_stiffness(solve_static(moored()), "q")
    dry = moored()
    dry.water = None  # (the same mooring out of the water: its result has no water statics to condense)
    with pytest.raises(SceneError, match="in water"):
        body_mooring_stiffness(solve_static(dry), "p")
