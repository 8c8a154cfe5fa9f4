"""Curved open members (Scene.arc, TOML [[members]] arc = {...}): a circular arc meshed with its nodes on the arc and
the arc's tangents as slopes, stress-free in its reference state; a quarter-circle cantilever under a tip load
deflects as Castigliano's curved beam says, converging under refinement."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.statics import solve_static
from ancf_sym.io.scene_toml import scene_from_dict

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

STEEL = Material(E=2e11, density=7800.0)
ROD = Section.circle(0.02)
R = 1.0
EI, EA = STEEL.E * ROD.I, STEEL.E * ROD.area


def quarter(n: int, load: float, **arc) -> np.ndarray:
    """Tip displacement of a quarter circle (from (R, 0) counter-clockwise to (0, R)), clamped at its start, under
    a downward tip force `load` [N]."""
    s = Scene(dim=2)
    s.arc("a", n, STEEL, ROD, axial="decoupled", **(arc or dict(centre=(0, 0), radius=R, angle0=0.0,
                                                                sweep=math.pi / 2)))
    s.clamp("a")
    if load:
        s.force("a", "end", (0.0, -load))
    r = solve_static(s)
    assert r.success, r.status
    return r.tip("a") - np.array([0.0, R])


def test_the_arc_is_its_own_unloaded_equilibrium_converging_as_h4():
    """Unloaded, the clamped arc stays where it is drawn: what moves it is the Hermite cubic's departure from the
    circle (position error O(h^4)), so the tip's drift falls ~16x per halving of the elements (asserted: >= 8x) and
    is below 1e-6 R at 16 elements."""
    drift = [np.linalg.norm(quarter(n, 0.0)) for n in (4, 8, 16)]
    assert drift[0] / drift[1] > 8 and drift[1] / drift[2] > 8, drift
    assert drift[2] < 1e-6 * R


def test_quarter_circle_cantilever_matches_castigliano_under_refinement():
    """Tip load P down at the free end of a quarter circle clamped at the other: Castigliano (bending M = P R cos
    phi, axial N = -P cos phi) gives the tip displacement (-P R^3/(2 EI) + P R/(2 EA), -pi P R^3/(4 EI) - pi P R/
    (4 EA)). The linear response (u(P) - u(-P)) / 2 (which cancels the quadratic geometric nonlinearity of a
    deflection of 1e-3 R) converges to it; what is left at fine meshes is the extensible model's departure from the
    closed form's curved-beam assumptions, of order EI / (EA R^2) = 2.5e-5 (measured 8e-5): asserted 5e-4. The
    full nonlinear tip at 16 elements agrees to 1e-3 (the nonlinearity, ~ deflection / R)."""
    P = 1e-3 * EI / R**3
    exact = np.array([-P * R**3 / (2 * EI) + P * R / (2 * EA), -math.pi * P * R**3 / (4 * EI)
                      - math.pi * P * R / (4 * EA)])
    scale = np.abs(exact).max()
    errors = []
    for n in (2, 4, 8, 16):
        lin = (quarter(n, P) - quarter(n, -P)) / 2
        errors.append(np.abs(lin - exact).max() / scale)
    assert errors[0] > errors[1] > errors[2] and errors[1] < errors[0] / 8, errors
    assert errors[-1] < 5e-4, errors
    assert np.abs(quarter(16, P) - exact).max() / scale < 1e-3


def test_arc_through_three_points_is_the_same_arc():
    """The arc through (R, 0), (R/sqrt 2, R/sqrt 2), (0, R) is the quarter circle given by centre and angles:
    the same nodes to round-off (the circumcentre is computed to ~1e-16 R), so the same tip."""
    a = quarter(6, 100.0)
    b = quarter(6, 100.0, through=[(R, 0.0), (R / math.sqrt(2), R / math.sqrt(2)), (0.0, R)])
    assert np.allclose(a, b, rtol=1e-9, atol=1e-12)
    clockwise = Scene(dim=2).arc("c", 4, STEEL, ROD, through=[(0.0, R), (R / math.sqrt(2), R / math.sqrt(2)),
                                                              (R, 0.0)], axial="decoupled")
    assert clockwise.arc_curvature == pytest.approx(-1 / R) and clockwise.length == pytest.approx(
        math.pi * R / 2, rel=1e-4)  # (length: the arc's, less the model's stretch EI/(EA R^2) ~ 2.5e-5)


TOML = """
[scene]
dim = 2
[materials.steel]
E = 2e11
density = 7800.0
[sections.rod]
shape = "circle"
diameter = 0.02
[[members]]
name = "hook"
arc = {centre = [0.0, 0.0], radius = 1.0, angle0 = 0.0, sweep = 1.5707963267948966}
elements = 6
material = "steel"
section = "rod"
axial = "decoupled"
[[supports]]
type = "clamp"
member = "hook"
[[loads]]
type = "force"
member = "hook"
at = "end"
value = [0.0, -100.0]
"""


def test_toml_arc_is_the_python_arc():
    scene, _ = scene_from_dict(tomllib.loads(TOML))
    r = solve_static(scene)
    assert r.success
    assert np.allclose(r.tip("hook") - [0.0, R], quarter(6, 100.0), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("old, new, path", [
    ("arc = {centre", "points = [[0.0, 0.0], [1.0, 0.0]]\narc = {centre", "members[0]"),
    ("radius = 1.0", "radius = -1.0", "members[0].arc.radius"),
    ("sweep = 1.5707963267948966", "sweep = 7.0", "members[0].arc.sweep"),
    ("angle0 = 0.0, ", "", "members[0].arc.angle0"),
    ("{centre = [0.0, 0.0], radius = 1.0, angle0 = 0.0, sweep = 1.5707963267948966}",
     "{through = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]}", "members[0].arc.through"),
    ("{centre = [0.0, 0.0], radius = 1.0, angle0 = 0.0, sweep = 1.5707963267948966}",
     "{through = [[0.0, 0.0], [1.0, 1.0]], radius = 2.0}", "members[0].arc"),
    ("sweep = 1.5707963267948966}", "sweep = 1.5707963267948966, spin = 1}", "members[0].arc.spin"),
    ('axial = "decoupled"', 'axial = "decoupled"\nprestrain = 0.01', "members[0].prestrain"),
])
def test_bad_arcs_refused_naming_the_toml_field(old, new, path):
    assert old in TOML
    with pytest.raises(SceneError) as exc:
        scene_from_dict(tomllib.loads(TOML.replace(old, new)))
    assert str(exc.value).startswith(path), str(exc.value)


def test_arcs_are_planar():
    with pytest.raises(SceneError, match=r"^members\['a'\]\.arc: curved members \(arcs\) are planar"):
        Scene(dim=3).arc("a", 4, STEEL, ROD, centre=(0, 0), radius=1.0, angle0=0.0, sweep=1.0)


def test_docs_show_the_declared_arc_keys():
    from pathlib import Path

    from ancf_sym.scene.schema import ARC, fields_table

    page = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()
    assert fields_table(ARC) in page
