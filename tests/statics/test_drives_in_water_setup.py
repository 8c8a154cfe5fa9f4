"""Member-node position drives in the statics of a 3-D scene in water (held at their t = 0 values, as pins).

A spatial body's scene needs the Newton graph with multiplier rows; its drive rows were built with no time input
and the set-up raised NotImplementedError (casadi vertcat of None). Lines whose only holds are drives were refused
as free although the statics in water holds them. A drive at a node's reference position holds it where a pin
does: the answers must agree to the solver's tolerance."""
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static

MAT, SEC = Material(E=1e9, density=1000.0), Section.circle(0.02)
TOL = 1e-10  # the statics' default relative tolerance


def moored(body: bool, driven: set) -> Scene:
    """Three slack lines (2 % longer than their chords) from fairleads around (0, 0, -5) to anchors 20 m deeper,
    on a spatial body (pinned to it) or on fairleads of their own; `driven`: which ends ("fairlead", "anchor") are
    position drives at their reference positions, the others pins."""
    s = Scene(dim=3, gravity=[0.0, 0.0, -9.81])
    if body:
        s.body("p", 10.0, [1.0, 2.0, 2.5], [0.0, 0.0, -5.0])
    for k, ang in enumerate((0.0, 120.0, 240.0)):
        u = np.array([np.cos(np.radians(ang)), np.sin(np.radians(ang)), 0.0])
        a = np.array([0.0, 0.0, -5.0]) + u
        b = a + 10.0 * u + [0.0, 0.0, -20.0]
        s.member(f"l{k}", [tuple(a), tuple(b)], 4, MAT, SEC, axial="biot", bending=False, prestrain=-0.02)
        for end, at, point in (("fairlead", "start", a), ("anchor", "end", b)):
            if end == "fairlead" and body:
                s.pin_body("p", f"l{k}", "start")
            elif end in driven and (end == "fairlead" or k == 0):
                s.drive_position(list(point), member=f"l{k}", at=at, name=f"{end}{k}")
            else:
                s.pin(f"l{k}", at=at)
    s.set_water(density=1025.0, surface=0.0)
    return s


def _nodes(r, n=3):
    return np.vstack([r.nodes(f"l{k}") for k in range(n)])


@pytest.mark.parametrize("body,driven", [(True, {"anchor"}), (False, {"fairlead"}), (False, {"fairlead", "anchor"})],
                         ids=["body-anchor-driven", "fairleads-driven", "both-ends-driven"])
def test_position_drives_in_water_hold_as_pins(body, driven):
    r = solve_static(moored(body, driven))
    ref = solve_static(moored(body, set()))
    assert r.success and ref.success, (r.status, ref.status)
    L = 22.4  # the lines' chord: each answer within tol L of the discrete equilibrium (Newton's increment bound)
    assert np.max(np.abs(_nodes(r) - _nodes(ref))) <= 2 * TOL * L
    if body:
        assert np.max(np.abs(r.body("p")[0] - ref.body("p")[0])) <= 2 * TOL * L
