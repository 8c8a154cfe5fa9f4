"""Planar rigid bodies (natural coordinates x, y, cos, sin) and their joints against independent references.

References: the compound pendulum's exact period T = 4 sqrt(J_o / (m g d)) K(sin(theta0 / 2)) (complete elliptic
integral of the first kind, any amplitude); a cantilever's linear tip deflection under a rigidly attached tip body
(tip load m g and moment m g e); a body pinned to the end of a short stiff clamped cable swings like a pendulum on
a fixed pivot.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import run_dynamics
from ancf_sym.statics import solve_static

G = 9.81


def compound_pendulum(theta0: float, m: float = 2.0, length: float = 1.0) -> tuple[Scene, float]:
    """A uniform rod on a revolute joint at one end, released at rest theta0 from the downward vertical; returns
    the scene and the exact period."""
    J, d = m * length**2 / 12, length / 2
    s = Scene(dim=2, gravity=(0, -G))
    s.body("rod", m, J, position=(d * math.sin(theta0), -d * math.cos(theta0)), angle=theta0 - math.pi / 2)
    s.revolute("rod", point=(0, 0))
    Jo = J + m * d * d
    return s, 4 * math.sqrt(Jo / (m * G * d)) * ellipk(math.sin(theta0 / 2) ** 2)


def period(t: np.ndarray, w: np.ndarray) -> float:
    """Twice the mean spacing of the angular velocity's zeros (linear interpolation between outputs)."""
    i = np.flatnonzero(np.sign(w[:-1]) * np.sign(w[1:]) < 0)
    tz = t[i] - w[i] * (t[i + 1] - t[i]) / (w[i + 1] - w[i])
    return 2 * float(np.mean(np.diff(tz)))


BODY = [{"name": "b", "kind": "body", "member": "rod"}]


@pytest.mark.parametrize("integrator", ["hht", "generalized_alpha", "radau"])
def test_compound_pendulum_large_amplitude_period(integrator):
    """Released at 2 rad (the period is 1.37 x the small-amplitude one): the period matches the elliptic-integral
    value within 2e-4. Every integrator here is at least second order: with omega h = 0.02 the phase error per
    period is ~ (omega h)^2 / 12 = 3e-5; the zero-crossing interpolation adds O(h^2 w'') ~ 1e-5. (The unit-vector
    row keeps a multiplier, an index-3 constraint: the non-dissipative schemes drift on it, see the next test.)"""
    s, T = compound_pendulum(2.0)
    r = run_dynamics(s, {"integrator": integrator, "dt": 4e-3, "t_end": 2.2 * T, "output_every": 1,
                         "sensors": BODY})
    assert r.status == "completed"
    assert abs(period(r.t, r.sensors["b"][:, 3]) / T - 1) < 2e-4
    assert r.constraint_violation.max() < 1e-9  # revolute and unit-vector rows are exact (index-3, Newton tol)


def test_compound_pendulum_newmark_small_amplitude():
    """Trapezoidal Newmark at 0.5 rad over 4 periods: the period within 1e-4 (phase error (omega h)^2/12), the energy
    error |dE| / (m g d) < 1e-4, the amplitude kept within 1e-3 rad. (At 2 rad its index-3 multiplier on the
    unit-vector row grows an energy error until the run stops with energy_blowup: use a dissipative scheme.)"""
    s, T = compound_pendulum(0.5)
    r = run_dynamics(s, {"integrator": "newmark", "dt": 4e-3, "t_end": 4 * T, "output_every": 1, "sensors": BODY})
    assert r.status == "completed"
    assert abs(period(r.t, r.sensors["b"][:, 3]) / T - 1) < 1e-4
    assert np.max(np.abs(r.energies["algorithmic"])) / (2.0 * G * 0.5) < 1e-4
    theta = r.sensors["b"][:, 2] + math.pi / 2
    assert abs(np.max(np.abs(theta)) - 0.5) < 1e-3


def test_body_on_stiff_cable_swings_like_pinned_pendulum():
    """A rod pinned (free rotation) to the end of a 0.1 m clamped steel cable of 20 mm diameter: the cable's tip
    stiffness 3EI/L^3 ~ 5e6 N/m deflects < 1e-5 m under the rod's ~10 N, so the rod swings about an almost fixed
    pivot: period within 1e-3 of the exact rigid-pivot value at 0.5 rad (cable compliance and the damped
    integrator's small phase error)."""
    m, Lr = 2.0, 1.0
    J, d, th = m * Lr**2 / 12, Lr / 2, 0.5
    s = Scene(dim=2, gravity=(0, -G))
    s.member("cable", [(0, 0.1), (0, 0)], 2, Material(E=2e11, density=7800), Section.circle(0.02), gravity=False)
    s.clamp("cable", "start")
    s.body("rod", m, J, position=(d * math.sin(th), -d * math.cos(th)), angle=th - math.pi / 2)
    s.pin_body("rod", "cable", "end")
    T = 4 * math.sqrt((J + m * d * d) / (m * G * d)) * ellipk(math.sin(th / 2) ** 2)
    r = run_dynamics(s, {"integrator": "generalized_alpha", "rho_inf": 0.8, "dt": 2e-3, "t_end": 2.2 * T,
                         "output_every": 1, "sensors": BODY})
    assert r.status == "completed"
    assert abs(period(r.t, r.sensors["b"][:, 3]) / T - 1) < 1e-3


def test_cantilever_with_rigid_tip_body_statics():
    """A clamped steel beam with a body rigidly attached at its tip (centre e = 0.3 m beyond it): linear beam
    theory gives the tip deflection P L^3/(3EI) + M L^2/(2EI) and rotation P L^2/(2EI) + M L/EI (P = m g,
    M = P e), here ~1 % of L, so the geometric nonlinearity is ~(1e-2)^2 relative: tolerance 1e-3. The body's
    angle equals the beam's tip rotation (the rigid joint) and its centre sits e along the tip tangent."""
    E, L, m, e = 2e11, 1.0, 5.0, 0.3
    sec = Section.rectangle(0.02, 0.02)
    EI = E * sec.Iz
    s = Scene(dim=2, gravity=(0, -G))
    s.member("beam", [(0, 0), (L, 0)], 8, Material(E=E, density=7800), sec, gravity=False)
    s.clamp("beam", "start")
    s.body("tip", m, 0.1, position=(L + e, 0))
    s.rigid_body("tip", "beam", "end")
    r = solve_static(s)
    assert r.success
    P, M = m * G, m * G * e
    w, phi = P * L**3 / (3 * EI) + M * L**2 / (2 * EI), P * L**2 / (2 * EI) + M * L / EI
    assert abs(-r.tip("beam")[1] / w - 1) < 1e-3
    x, y, angle = r.body("tip")
    assert abs(-angle / phi - 1) < 1e-3
    tip = r.tip("beam")
    assert np.allclose([x, y], tip + e * np.array([math.cos(angle), math.sin(angle)]), atol=1e-9 * L)


def test_body_hung_from_cable_statics():
    """A 50 kg body pinned (free rotation) at a point 0.224 m from its centre to the end of a pinned steel cable:
    at equilibrium its centre hangs straight below the cable end (x = 0 within 1e-9 L) at that distance, and the
    cable stretches by m g L / EA (tolerance 1e-3: Green strain differs from the engineering one by ~eps/2 = 1e-4).
    The body's rotation has no stiffness at the start (it comes from the multipliers): Newton's first KKT matrix is
    singular, and the solve must still end at the true equilibrium (IPOPT), never stop at the start."""
    m, L = 50.0, 2.0
    sec = Section.circle(0.004)
    s = Scene(dim=2, gravity=(0, -G))
    s.member("cable", [(0, 0), (0, -L)], 4, Material(E=2e11, density=7800), sec, gravity=False)
    s.pin("cable", "start")
    s.body("weight", m, 0.3, position=(0.1, -L - 0.2), angle=0.3)
    s.pin_body("weight", "cable", "end")
    r = solve_static(s)
    assert r.success and r.stable
    x, y, _ = r.body("weight")
    tip = r.tip("cable")
    assert abs(x) < 1e-9 * L and abs(tip[0]) < 1e-9 * L
    assert abs(math.hypot(x - tip[0], y - tip[1]) - math.hypot(0.1, 0.2)) < 1e-9 * L
    stretch = -tip[1] - L
    assert abs(stretch / (m * G * L / (2e11 * sec.area)) - 1) < 1e-3


def test_scene_without_bodies_keeps_its_unknowns():
    """Bodies cost nothing when absent: same coordinates, same constraint rows, same mass matrix."""
    s, _ = compound_pendulum(0.1)
    s2 = Scene(dim=2, gravity=(0, -G))
    s2.member("c", [(0, 0), (1, 0)], 3, Material(E=1e9, density=1000), Section.circle(0.01))
    s2.pin("c", "start")
    a = Assembly(s2)
    assert a.n == a.mesh.members["c"].x0.size and not a.mesh.bodies
    assert a.constraints.m == 2
    a1 = Assembly(s)
    assert a1.n == 4 and a1.constraints.m == 3  # (x, y, c, s); unit row + 2 revolute rows
    assert np.allclose(a1.mass_matrix().diagonal(), [2.0, 2.0, 2 / 12, 2 / 12])


@pytest.mark.parametrize("kw, field", [
    (dict(mass=0.0, inertia=1.0), "mass"), (dict(mass=None, inertia=1.0), "mass"),
    (dict(mass=1.0, inertia=0.0), "inertia"), (dict(mass=1.0, inertia=-2.0), "inertia"),
    (dict(mass=1.0, inertia=1.0, position=(0, float("nan"))), "position"),
])
def test_bad_body_refused(kw, field):
    s = Scene(dim=2)
    kw = {"position": (0, 0), **kw}
    with pytest.raises(SceneError, match=field):
        s.body("b", **kw)


def test_bad_body_joints_refused():
    s = Scene(dim=2)
    s.member("c", [(0, 0), (1, 0)], 2, Material(E=1e9, density=1000), Section.circle(0.01))
    s.body("b", 1.0, 1.0, (1, 0))
    with pytest.raises(SceneError, match="names no body"):
        s.revolute("nobody")
    with pytest.raises(SceneError, match="pin.at"):
        s.pin_body("b", "c", at=7)
    with pytest.raises(SceneError, match="new non-empty"):
        s.body("c", 1.0, 1.0, (0, 0))
    with pytest.raises(SceneError, match="body.inertia"):  # a 3D scene's body is spatial: an inertia tensor
        Scene(dim=3).body("b", 1.0, 1.0, (0, 0, 0))
    with pytest.raises(SceneError, match="free rigid-body motion"):
        s.pin("c", "start")
        s.validate_for_statics()  # the body is tied to nothing


CABLE_BODY_TOML = """
[scene]
dim = 2
gravity = [0, -9.81]
[materials.steel]
E = 2e11
density = 7800
[sections.rod]
shape = "rectangle"
b = 0.02
h = 0.02
[[members]]
name = "beam"
points = [[0, 0], [1, 0]]
elements = 8
material = "steel"
section = "rod"
gravity = false
[[supports]]
type = "clamp"
member = "beam"
at = "start"
[[bodies]]
name = "tip"
mass = 5.0
inertia = 0.1
position = [1.3, 0]
rigid = [["beam", "end"]]
"""


def test_toml_bodies_match_python_api(tmp_path):
    """The TOML [[bodies]] table builds the same scene as the Python API: same coordinates, constraint rows and
    dead-load vector (exact equality: the same numbers go through the same code)."""
    from ancf_sym.io.scene_toml import load_scene

    f = tmp_path / "s.toml"
    f.write_text(CABLE_BODY_TOML)
    scene, _ = load_scene(f)
    s = Scene(dim=2, gravity=(0, -G))
    s.member("beam", [(0, 0), (1, 0)], 8, Material(E=2e11, density=7800), Section.rectangle(0.02, 0.02),
             gravity=False)
    s.clamp("beam", "start")
    s.body("tip", 5.0, 0.1, position=(1.3, 0))
    s.rigid_body("tip", "beam", "end")
    a, b = Assembly(scene), Assembly(s)
    assert a.n == b.n and a.constraints.labels == b.constraints.labels
    assert np.array_equal(a.Q, b.Q) and np.array_equal(a.x0, b.x0)


@pytest.mark.parametrize("edit, message", [
    (("mass = 5.0", "mass = -1.0"), "bodies\\[0\\].*mass"),
    (("inertia = 0.1", "inertia = 0"), "bodies\\[0\\].*inertia"),
    (('rigid = [["beam", "end"]]', 'rigid = [["nobeam", "end"]]'), "bodies\\[0\\].rigid\\[0\\]"),
    (('rigid = [["beam", "end"]]', 'spin = 3'), "bodies\\[0\\]"),
])
def test_toml_bad_body_refused(tmp_path, edit, message):
    from ancf_sym.io.scene_toml import load_scene

    f = tmp_path / "s.toml"
    f.write_text(CABLE_BODY_TOML.replace(*edit))
    with pytest.raises(SceneError, match=message):
        load_scene(f)


def test_body_initial_rotation_reaches_energy_amplitude():
    """A compound pendulum hanging at rest, started by initial.velocities(rotation={rod: (omega0, pivot)}): it
    swings up to theta_max with 1/2 J_o omega0^2 = m g d (1 - cos theta_max) (energy conservation). The
    generalized-alpha scheme (rho_inf 0.9, omega h ~ 0.02) dissipates ~1e-5 of the energy per period: tolerance
    1e-3 rad on theta_max over the first half period; the recorded start rate equals omega0."""
    from ancf_sym.dynamics import initial

    s, T = compound_pendulum(0.0)
    a = Assembly(s)
    w0 = 3.0
    v0 = initial.velocities(a, rotation={"rod": (w0, (0.0, 0.0))})
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 4e-3, "t_end": 0.6 * T, "output_every": 1,
                         "sensors": BODY, "v0": v0})
    assert r.status == "completed"
    m, d = 2.0, 0.5
    Jo = m / 12 + m * d * d
    th_max = math.acos(1 - 0.5 * Jo * w0**2 / (m * G * d))
    theta = r.sensors["b"][:, 2] + math.pi / 2
    assert abs(theta.max() - th_max) < 1e-3
    assert abs(r.sensors["b"][0, 3] - w0) < 1e-12 * w0


def test_pendulum_under_side_force_statics():
    """A rod on a revolute joint with a horizontal dead force F at its centre: equilibrium angle from the vertical
    tan(theta) = F / (m g) (moment balance about the pivot, exact for a rigid body). Tolerance 1e-8 rad: only the
    solver's tolerance separates them. The revolute rows' multipliers are (F, -m g): the joint pushes the body with
-lambda = (-F, m g), the reaction that balances the loads (relative 1e-8 likewise)."""
    m, F, d = 2.0, 7.0, 0.5
    s = Scene(dim=2, gravity=(0, -G))
    s.body("rod", m, m / 12, position=(0, -d), angle=-math.pi / 2, force=(F, 0))
    s.revolute("rod", point=(0, 0))
    r = solve_static(s)
    assert r.success and r.stable
    x, y, angle = r.body("rod")
    theta = angle + math.pi / 2
    assert abs(theta - math.atan2(F, m * G)) < 1e-8
    assert abs(math.hypot(x, y) - d) < 1e-12
    assert np.allclose(r.constraint_forces["revolute rod"], [F, -m * G], rtol=1e-8)


def test_planar_slider_on_incline_prismatic_closed_form():
    """A body on a ground prismatic joint along a 30 degree incline, released at rest in gravity: it slides with
    the constant acceleration g sin(alpha), s = g sin(alpha) t^2 / 2, and never turns or leaves the line. The
    Newmark family integrates a constant acceleration exactly, so the error is Newton's tolerance level (< 1e-9 m);
    the joint's reaction carries the normal component m g cos(alpha) exactly."""
    a = math.radians(30)
    axis = np.array([math.cos(a), -math.sin(a)])
    s = Scene(dim=2, gravity=(0, -G))
    s.body("rod", 2.0, 0.1, position=(0.3, 0.2), angle=0.4)
    s.prismatic("rod", axis=axis)
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 1e-2, "t_end": 1.0, "output_every": 1,
                         "sensors": BODY})
    assert r.status == "completed"
    x = r.sensors["b"]
    d = x[:, :2] - np.array([0.3, 0.2])
    assert np.abs(d @ axis - 0.5 * G * math.sin(a) * r.t**2).max() < 1e-9
    assert np.abs(d @ np.array([math.sin(a), math.cos(a)])).max() < 1e-9
    assert np.abs(x[:, 2] - 0.4).max() < 1e-12


def test_planar_cart_pendulum_prismatic_and_body_body_revolute():
    """A planar cart on a horizontal ground prismatic joint with a pendulum on a body-body revolute joint: the
    combined centre of mass stays put horizontally (< 1e-9 m: no horizontal external force) and the small-amplitude
    period is 2 pi / w, w^2 = m g d / (J_o - m^2 d^2 / (M + m)), within 1e-3 (amplitude 0.05 rad: nonlinear
    correction ~ theta0^2 / 16 = 1.6e-4 times factors of order 1; phase error (w h)^2 / 12 = 2e-5)."""
    M, mp, d, Jc, th0 = 3.0, 1.0, 0.5, 0.02, 0.05
    s = Scene(dim=2, gravity=(0, -G))
    s.body("cart", M, 0.2, (0, 0))
    s.prismatic("cart", axis=(1, 0))
    s.body("bob", mp, Jc, (d * math.sin(th0), -d * math.cos(th0)), angle=th0)
    s.revolute("bob", point=(0, 0), other="cart")
    Jo = Jc + mp * d * d
    T = 2 * math.pi / math.sqrt(mp * G * d / (Jo - mp**2 * d**2 / (M + mp)))
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": T / 400, "t_end": 3 * T, "output_every": 1,
                         "sensors": [{"name": "c", "kind": "body", "member": "cart"},
                                     {"name": "b", "kind": "body", "member": "bob"}]})
    assert r.status == "completed"
    c, b = r.sensors["c"], r.sensors["b"]
    assert np.abs(M * c[:, 0] + mp * b[:, 0] - mp * d * math.sin(th0)).max() < 1e-9
    assert np.abs(c[:, 1]).max() < 1e-9 and np.abs(c[:, 2]).max() < 1e-12
    assert abs(period(r.t, b[:, 3]) / T - 1) < 1e-3
