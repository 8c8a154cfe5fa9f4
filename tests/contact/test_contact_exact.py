"""Statics with exact frictionless contact against drums (method="exact" of Scene.contact_drum): the gap kernels
against the geometry, ropes over fixed drums against the closed forms of a frictionless wrap (constant tension, line
pressure T/rho, drum reaction 2 T sin(wrap/2)), drums carried by held rigid bodies, results and bad input."""
from __future__ import annotations

import json
import meshio
import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, kernels, solve_static
from ancf_sym.contact import exact as contact_exact
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.elements.hermite import weights

from helpers import cli, pick, run_example


@pytest.fixture(scope="module")
def drum(tmp_path_factory):
    """examples/rope_over_drum.py --quick: n = 24 in 2D and 3D, and the pulley."""
    return run_example("rope_over_drum", tmp_path_factory)


@pytest.mark.parametrize("element", ["cable2d", "cable3d", "beam3d"])
def test_gap_kernel_is_the_distance_to_the_drum_surface(element):
    """<element>_contact_circle_gap at xi equals |r(xi) - c|_perp - R - t with r(xi) from the Hermite weights and the
    projection normal to the axis computed here: the same arithmetic in another order, so to round-off (1e-12)."""
    rng = np.random.default_rng(5)
    dim = 2 if element == "cable2d" else 3
    nd = {"cable2d": 8, "cable3d": 12, "beam3d": 24}[element]
    q = rng.uniform(-1, 1, nd)
    c = rng.uniform(-1, 1, dim)
    L, xi, t, R = 0.7, 0.3, 0.01, 0.2
    a = np.array([0.3, -0.4, 0.866]) / np.linalg.norm([0.3, -0.4, 0.866])
    p = [L, xi, t, R, *(a if dim == 3 else ())]
    g = float(kernels.load(element, "contact_circle_gap")(np.r_[q, c], p)[0])
    w = weights(xi, L)[0]
    half = nd // 2
    r = sum(wk * q[o:o + dim] for wk, o in zip(w, (0, dim, half, half + dim)))
    d = r - c
    if dim == 3:
        d = d - (d @ a) * a
    assert g == pytest.approx(np.linalg.norm(d) - R - t, rel=1e-12, abs=1e-12)


def test_rope_over_a_fixed_drum_is_a_frictionless_wrap(drum):
    """A prestressed rope (Biot strain 1e-3, no gravity, EI ~ 0) pinned at (+-a, -h) over a fixed drum, 24 elements,
    solved from a start wrapped around a 30 % larger circle. Closed forms of a frictionless wrap: the rope follows
    the tangent-arc-tangent path of the centre-line radius rho = R + t, with the tension T = EA (path / L0 - 1)
    everywhere, so the pins pull with T, the contact forces sum to T / rho per length of wrap, their resultant is
    2 T sin(wrap / 2) and the spans turn by the wrap angle. Discretisation: the rope is held at the Gauss points only
    and cuts the arc between them, which shortens the path by a relative ~1e-6 and changes the 1e-3 strain by
    ~1e-3 relative; it converges as ~h^3 (0.27 %, 0.037 %, 0.009 % at n = 24, 48, 96 for the pin force):
    tolerances 1 % on the forces at n = 24, and on the elements' mean tension on the wrap (measured -0.2..+0.6 %:
    a point force kinks the rope, which the cubic element rounds off), 1e-3 rad on the wrap angle [2e-4]."""
    _, recs = drum
    r = pick(recs, case="wrap2d_n24")
    assert r["success"], r["status"]
    T = r["T_ref_N"]
    assert r["T_wrap_max_N"] == pytest.approx(T, rel=1e-2) and r["T_wrap_min_N"] == pytest.approx(T, rel=1e-2)
    assert r["pin_force_N"] == pytest.approx(T, rel=1e-2)
    assert r["reaction_N"] == pytest.approx(r["reaction_ref_N"], rel=1e-2)
    assert r["pressure_N_m"] == pytest.approx(r["pressure_ref_N_m"], rel=1e-2)
    assert abs(r["wrap_rad"] - r["wrap_ref_rad"]) < 1e-3
    assert r["min_gap_m"] > -1e-9  # no penetration at the contact points (IPOPT's constr_viol_tol 1e-10)


def test_helix_around_a_cylinder(drum):
    """cable3d around a cylinder of axis z, its pins at z = -+0.2 m: the frictionless rope is a geodesic, a helix of
    slope angle alpha with cos(alpha) = path_xy / path (the cylinder unrolled: a straight line); tension constant,
    pressure T cos^2(alpha) / rho, resultant 2 T cos(alpha) sin(wrap / 2) normal to the axis; tolerances as in 2D
    (measured 0.2 %)."""
    _, recs = drum
    r = pick(recs, case="helix3d_n24")
    assert r["success"], r["status"]
    T = r["T_ref_N"]
    assert r["T_wrap_max_N"] == pytest.approx(T, rel=1e-2) and r["T_wrap_min_N"] == pytest.approx(T, rel=1e-2)
    assert r["pin_force_N"] == pytest.approx(T, rel=1e-2)
    assert r["reaction_N"] == pytest.approx(r["reaction_ref_N"], rel=1e-2)
    assert r["pressure_N_m"] == pytest.approx(r["pressure_ref_N_m"], rel=1e-2)
    assert abs(r["wrap_rad"] - r["wrap_ref_rad"]) < 1e-3


def test_movable_pulley_on_a_prismatic_joint_hangs_on_the_rope(drum):
    """A pulley (a rigid body on a vertical prismatic joint) in the bight of a weightless rope: the contact forces
    carry its weight exactly (their resultant is an equilibrium of the body, to IPOPT's tolerance: 1e-6), the pins
    pull with T = W / (2 cos beta) and the pulley hangs at the depth where the stretched rope fits the path
    (closed form by root finding; discretisation as for the wrap: 1e-3 on T [3e-4], 1e-4 on the depth [1e-5])."""
    _, recs = drum
    r = pick(recs, case="pulley")
    assert r["success"], r["status"]
    assert r["reaction_N"] == pytest.approx(r["weight_N"], rel=1e-6)
    assert r["pin_force_N"] == pytest.approx(r["T_ref_N"], rel=1e-3)
    assert r["depth_m"] == pytest.approx(r["depth_ref_m"], rel=1e-4)


def _pushed(body: str | None = None):
    """A straight rope pinned at both ends whose reference cuts a drum by 2 cm (no gravity): IPOPT starts infeasible."""
    sc = Scene(dim=2, gravity=(0.0, 0.0))
    sc.member("rope", [(0, 0), (1, 0)], 16, Material(E=2e9, density=1000.0), Section.circle(0.004))
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    if body is None:
        sc.contact_drum("rope", (0.5, -0.18), 0.2, method="exact")
    else:
        sc.body("pulley", 1.0, 0.01, position=(0.5, -0.18))
        if body == "revolute":
            sc.revolute("pulley")
        sc.contact_drum("rope", radius=0.2, body="pulley", method="exact")
    return sc


def test_pushed_rope_balances_the_pins():
    """From a reference that cuts the drum: no penetration at the contact points, no pulling force, and the
    contact forces' vertical resultant equals the pins' (an equilibrium of the rope, to IPOPT's tolerance)."""
    r = solve_static(_pushed())
    assert r.success, r.status
    asm = r.assembly
    pts = contact_exact.points(asm, r.x, r.constraint_forces["contact"])
    f = np.array([p["force"] for p in pts])
    assert min(p["gap"] for p in pts) > -1e-9 and np.all(f >= 0) and f.max() > 0
    up = _vertical_resultant(asm, r.x, pts)
    pins = r.constraint_forces["pin rope@start"][1] + r.constraint_forces["pin rope@end"][1]
    assert up == pytest.approx(pins, rel=1e-6)


def _vertical_resultant(asm, x, pts) -> float:
    out = 0.0
    for p in pts:
        r = _point(asm, x, p["element"], p["xi"])
        n = (r - np.array([0.5, -0.18])) / np.linalg.norm(r - np.array([0.5, -0.18]))
        out += p["force"] * n[1]
    return out


def _point(asm, x, element, xi):
    mm = asm.mesh.members["rope"]
    X = asm.member_coordinates(x, "rope")
    a, b = mm.elem_nodes[element]
    w = weights(xi, mm.elem_length[element])[0]
    return w[0] * X[a, :2] + w[1] * X[a, 2:4] + w[2] * X[b, :2] + w[3] * X[b, 2:4]


def test_drum_on_a_held_body_acts_as_the_fixed_drum():
    """The same drum carried by a planar body on a revolute joint at its centre (its angle free: frictionless
    contact does not turn it): the same equilibrium (1e-6 of the push) and contact forces (1e-5 relative)."""
    fixed = solve_static(_pushed())
    held = solve_static(_pushed("revolute"))
    assert held.success, held.status
    n = fixed.x.size  # the member's coordinates come first, the body's after them
    assert np.abs(held.x[:n] - fixed.x).max() < 1e-6 * 0.02
    ff, fh = (np.asarray(r.constraint_forces["contact"]) for r in (fixed, held))
    assert np.abs(fh - ff).max() < 1e-5 * ff.max()


def test_exact_drum_contact_is_refused_in_dynamics_and_with_a_law():
    sc = _pushed()
    with pytest.raises(SceneError, match=r"contact_drum\(member='rope'\): method='exact'.*statics"):
        simulate(sc, DynamicOptions(dt=1e-3, t_end=0.01))
    with pytest.raises(SceneError, match=r"method='exact'"):
        sc.contact_drum("rope", (0.5, -0.18), 0.2, method="exact", stiffness=1e6)


TOML = """
[scene]
dim = 2
gravity = [0, 0]
[materials.rope]
E = 2e9
density = 1000
[sections.d4]
shape = "circle"
diameter = 0.004
[[members]]
name = "rope"
points = [[0, 0], [1, 0]]
elements = 16
material = "rope"
section = "d4"
[[supports]]
member = "rope"
at = "start"
type = "pin"
[[supports]]
member = "rope"
at = "end"
type = "pin"
[[contacts]]
type = "circle"
member = "rope"
centre = [0.5, -0.18]
radius = 0.2
method = "exact"
"""


def test_toml_exact_drum_and_result_json(tmp_path):
    """TOML type = "circle" with method = "exact"; result.json reports per contact the points' gaps and forces
    (the multipliers), their sum and the smallest gap."""
    f = tmp_path / "pushed.toml"
    f.write_text(TOML)
    out = tmp_path / "out"
    run = cli("run", f, "--out", out, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    doc = json.loads((out / "result.json").read_text())
    (c,) = doc["contacts"]
    assert c["type"] == "circle" and c["method"] == "exact" and len(c["gaps"]) == 16 * 5
    assert c["normal_force"] == pytest.approx(sum(c["forces"])) and c["normal_force"] > 0
    assert c["min_gap"] > -1e-9
    (vtu,) = list(out.glob("*.vtu"))
    pd = meshio.read(vtu).point_data  # the forces shared by the nodes, interpolated between them: the same sum
    assert pd["contact_force"].max() > 0 and pd["contact_force"].min() >= 0
    assert pd["contact_gap"].min() == pytest.approx(c["min_gap"], abs=1e-12)


def _pushed3d(element: str, body: bool):
    """3D: a straight member pinned at both ends pushed 2 cm sideways by a cylinder of axis z (no gravity); fixed,
    or carried by a spatial body on a revolute joint about that axis."""
    sc = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
    if element == "beam3d":
        sc.member("strip", [(0, 0, 0), (1, 0, 0)], 8, Material(E=2e9, density=1000.0), Section.rectangle(0.01, 0.004),
                  element="beam3d")
    else:
        sc.member("strip", [(0, 0, 0), (1, 0, 0)], 8, Material(E=2e9, density=1000.0), Section.circle(0.004))
    sc.pin("strip", "start")
    sc.pin("strip", "end")
    centre = (0.5, -0.18, 0.0)
    if body:
        sc.body("wheel", 1.0, (0.01, 0.01, 0.02), position=centre)
        sc.revolute("wheel", axis=(0, 0, 1))
        sc.contact_drum("strip", centre, 0.2, axis=(0, 0, 1), body="wheel", method="exact")
    else:
        sc.contact_drum("strip", centre, 0.2, axis=(0, 0, 1), method="exact")
    return sc


@pytest.mark.parametrize("element", ["cable3d", "beam3d"])
def test_drum_on_a_held_spatial_body_acts_as_the_fixed_cylinder(element):
    """The kernel <element>_contact_body_drum_gap on a spatial body held by a revolute joint about the drum axis gives
    the fixed cylinder's equilibrium (1e-6 of the push) and contact forces (1e-5 relative: IPOPT's tolerance); no
    point penetrates and the forces push (>= 0).

    The beam3d strip, pushed about its stiff axis, twists onto its weak axis (a lateral-torsional saddle left by the
    statics): it may turn either way (two mirror states of equal potential; which one the escape takes rests on
    round-off in the negative-curvature direction, which differs between LAPACK builds), so there the centre line,
    the potential and the forces are compared, not the section vectors' sign."""
    fixed = solve_static(_pushed3d(element, False))
    held = solve_static(_pushed3d(element, True))
    assert fixed.success and held.success, (fixed.status, held.status)
    n = fixed.x.size
    if element == "beam3d":
        assert np.abs(held.nodes("strip") - fixed.nodes("strip")).max() < 1e-6 * 0.02
        assert held.potential == pytest.approx(fixed.potential, rel=1e-6)
    else:
        assert np.abs(held.x[:n] - fixed.x).max() < 1e-6 * 0.02
    ff, fh = (np.asarray(r.constraint_forces["contact"]) for r in (fixed, held))
    assert ff.max() > 0 and np.all(fh >= 0) and np.abs(fh - ff).max() < 1e-5 * ff.max()
    assert min(contact_exact.gaps(held.assembly, held.x)) > -1e-9
