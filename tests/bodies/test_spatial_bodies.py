"""Spatial rigid bodies (natural coordinates r, e1, e2, e3) and their joints against independent references.

References: Euler's equations of a rigid body integrated by scipy's solve_ivp at rtol 1e-11 (torque-free body,
heavy body on a spherical joint, slider on a turning arm); the exact conservation of energy, angular momentum and
(for a cart) horizontal momentum; the linearised cart-pendulum frequency; linear beam theory for a body clamped to
a beam3d tip; the exact compound-pendulum period for a body on a stiff cable3d.
The generalized-alpha scheme (and HHT) is second order: halving dt must divide an error by ~4, which is what the
convergence tests assert (a ratio in [3, 5]), beside an absolute bound at the finer step.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import run_dynamics
from ancf_sym.dynamics.initial import velocities
from ancf_sym.statics import solve_static

G = 9.81
SENSOR = [{"name": "b", "kind": "body", "member": "b"}]


def skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def euler_reference(I: np.ndarray, w0: np.ndarray, t: np.ndarray, torque=lambda R: np.zeros(3)) -> tuple:
    """Rotation matrices R(t) (body -> world, R(0) = 1) and body-frame angular velocities of a body with inertia
    I about its fixed point: I w' = M_body - w x I w, R' = R [w]x (solve_ivp, DOP853, rtol 1e-11)."""
    def f(_, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        wd = np.linalg.solve(I, torque(R) - np.cross(w, I @ w))
        return np.r_[(R @ skew(w)).ravel(), wd]
    sol = solve_ivp(f, (t[0], t[-1]), np.r_[np.eye(3).ravel(), w0], t_eval=t, method="DOP853", rtol=1e-11,
                    atol=1e-12)
    return sol.y[:9].T.reshape(-1, 3, 3), sol.y[9:].T


def free_body(I=(1.0, 2.0, 3.0)) -> Scene:
    s = Scene(dim=3)
    s.body("b", 2.0, I, (0, 0, 0))
    return s


def spin(scene: Scene, w0, dt: float, t_end: float, integrator: str = "generalized_alpha", **opt):
    asm = Assembly(scene)
    v0 = velocities(asm, rotation={"b": (np.asarray(w0, float), scene.bodies["b"].position)})
    return run_dynamics(scene, {"integrator": integrator, "dt": dt, "t_end": t_end, "output_dt": 0.01, "v0": v0,
                                "sensors": SENSOR, **opt})


def invariants(r, I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic energy and world angular momentum E^T I E w at each output (E: rows e_k, world w)."""
    S = r.sensors["b"]
    T, L = [], []
    for k in range(len(r.t)):
        E, w = S[k, 6:].reshape(3, 3), S[k, 3:6]
        Iw = E.T @ I @ E
        T.append(0.5 * w @ Iw @ w)
        L.append(Iw @ w)
    return np.array(T), np.array(L)


@pytest.mark.parametrize("integrator", ["generalized_alpha", "hht"])
def test_torque_free_body_conserves_energy_and_momentum_to_second_order(integrator):
    """Near the unstable intermediate axis (the hardest case: the body flips), over 10 s: the drift of the kinetic
    energy and of the world angular momentum |L| = 6 shrinks by ~4 when dt halves (second-order scheme; the
    orthonormality rows are exact, so no drift of the constraints adds to it) and stays below 1e-4 of the values at
    dt = 1 ms (measured 7e-6 / 5e-6: the bound leaves a factor ~10 for other machines' Newton paths)."""
    I = np.diag([1.0, 2.0, 3.0])
    errs = []
    for dt in (2e-3, 1e-3):
        r = spin(free_body(), (0.01, 3.0, 0.05), dt, 10.0, integrator)
        assert r.status == "completed"
        T, L = invariants(r, I)
        errs.append((np.abs(T - T[0]).max() / T[0], np.abs(L - L[0]).max() / np.linalg.norm(L[0])))
        assert r.constraint_violation.max() < 1e-9
    for k in range(2):
        assert 3.0 < errs[0][k] / errs[1][k] < 5.0
        assert errs[1][k] < 1e-4


def test_torque_free_stable_and_unstable_axes():
    """Spin about the axes of least and largest inertia is stable: the body-frame spin component stays within 0.1 %
    of its start under a 1 % perturbation (the cone's half-angle is ~ the perturbation). About the intermediate
    axis it is unstable: the spin component reverses (Dzhanibekov flip), at the times the Euler equations give
    (body-frame w within 2e-3 of the reference over 8 s at dt = 1 ms; second-order error (w h)^2 per radian
    accumulates to ~1e-4 here, and the flip's exponential growth amplifies a phase error ~10x)."""
    I = np.diag([1.0, 2.0, 3.0])
    t_end = 8.0
    for axis in (0, 2):
        w0 = np.full(3, 0.03)
        w0[axis] = 3.0
        r = spin(free_body(), w0, 1e-3, t_end)
        E = r.sensors["b"][:, 6:].reshape(-1, 3, 3)
        wb = np.einsum("tij,tj->ti", E, r.sensors["b"][:, 3:6])
        assert np.min(wb[:, axis]) > 0.999 * 3.0 * 0.99
    w0 = np.array([0.01, 3.0, 0.05])
    r = spin(free_body(), w0, 1e-3, t_end)
    E = r.sensors["b"][:, 6:].reshape(-1, 3, 3)
    wb = np.einsum("tij,tj->ti", E, r.sensors["b"][:, 3:6])
    assert wb[:, 1].min() < -2.9  # flipped
    _, wref = euler_reference(I, w0, r.t)
    assert np.abs(wb - wref).max() < 2e-3 * 3.0


def test_heavy_body_on_spherical_joint_matches_euler_equations():
    """A heavy asymmetric body on a ground spherical joint 0.5 m from its centre, launched spinning: its centre
    follows the Euler equations about the pivot (inertia by the parallel-axis theorem, torque s x R^T m g) to 2e-5
    m over 2 s, and the error falls by ~4 per halving of dt (second order; measured 1.8e-5, 4.5e-6, 1.1e-6)."""
    m, Ic, c0 = 1.5, np.diag([0.02, 0.05, 0.06]), np.array([0.3, 0.1, -0.4])
    w0 = np.array([0.5, -1.0, 2.0])
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("b", m, Ic, c0)
    s.spherical("b", point=(0, 0, 0))
    Io = Ic + m * (c0 @ c0 * np.eye(3) - np.outer(c0, c0))
    t = np.linspace(0, 2.0, 101)
    R, _ = euler_reference(Io, w0, t, lambda R: np.cross(c0, R.T @ np.array([0, 0, -m * G])))
    cref = R @ c0
    v0 = velocities(Assembly(s), rotation={"b": (w0, (0, 0, 0))})
    errs = []
    for dt in (2e-3, 1e-3):
        r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": dt, "t_end": 2.0, "output_times": t.tolist(),
                             "v0": v0, "sensors": SENSOR})
        assert r.status == "completed"
        errs.append(np.abs(r.sensors["b"][:, :3] - cref).max())
    assert 3.0 < errs[0] / errs[1] < 5.0 and errs[1] < 1e-5


def test_cart_pendulum_prismatic_and_body_body_revolute():
    """A cart on a ground prismatic joint (x axis) carrying a pendulum on a body-body revolute joint (y axis):
    horizontal momentum is exactly conserved (the combined centre of mass stays put to 1e-9 m: the prismatic
    reaction has no x component, the revolute's forces are internal), and the small-amplitude period is
    2 pi / w, w^2 = m g d / (J_o - m^2 d^2 / (M + m)), within 1e-3 (amplitude 0.05 rad: nonlinear correction
    ~ theta0^2 / 16 = 1.6e-4 times mass-ratio factors of order 1; phase error (w h)^2 / 12 = 2e-5)."""
    M, mp, d, Jc, th0 = 3.0, 1.0, 0.5, 0.02, 0.05
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("cart", M, (0.1, 0.2, 0.2), (0, 0, 0))
    s.prismatic("cart", axis=(1, 0, 0))
    s.body("bob", mp, (Jc, Jc, 0.01), (d * math.sin(th0), 0, -d * math.cos(th0)))
    s.revolute("bob", point=(0, 0, 0), axis=(0, 1, 0), other="cart")
    Jo = Jc + mp * d * d
    T = 2 * math.pi / math.sqrt(mp * G * d / (Jo - mp**2 * d**2 / (M + mp)))
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": T / 400, "t_end": 3 * T, "output_every": 1,
                         "sensors": [{"name": "c", "kind": "body", "member": "cart"},
                                     {"name": "b", "kind": "body", "member": "bob"}]})
    assert r.status == "completed"
    c, b = r.sensors["c"], r.sensors["b"]
    assert np.abs(M * c[:, 0] + mp * b[:, 0] - mp * d * math.sin(th0)).max() < 1e-9
    assert np.abs(c[:, 1:3]).max() < 1e-9 and np.abs(c[:, 3:6]).max() < 1e-9  # the cart slides, never turns
    wy, t = b[:, 4], r.t
    i = np.flatnonzero(np.sign(wy[:-1]) * np.sign(wy[1:]) < 0)
    tz = t[i] - wy[i] * (t[i + 1] - t[i]) / (wy[i + 1] - wy[i])
    assert abs(2 * np.mean(np.diff(tz)) / T - 1) < 1e-3


def test_slider_on_turning_arm_body_body_prismatic():
    """A slider on a body-body prismatic joint along an arm that turns freely about a vertical revolute axis: the
    radius follows the two-degree-of-freedom Lagrange equations r'' = r th'^2, th'' = -2 m r r' th' / (J + m r^2)
    (solve_ivp) to 2e-6 m at dt = 1 ms over 1 s (the slider flies out from 0.2 m to 0.65 m; second order,
    error ratio ~4 on halving dt; measured 8e-7)."""
    JA, mB, JB, r0, W = 0.2, 0.5, 0.01, 0.2, 2.0
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("arm", 1.0, (0.1, 0.1, JA), (0, 0, 0))
    s.revolute("arm", point=(0, 0, 0), axis=(0, 0, 1))
    s.body("b", mB, (JB, JB, JB), (r0, 0, 0))
    s.prismatic("b", axis=(1, 0, 0), other="arm")
    v0 = velocities(Assembly(s), rotation={"arm": ((0, 0, W), (0, 0, 0)), "b": ((0, 0, W), (0, 0, 0))})
    t = np.linspace(0, 1.0, 51)
    J = JA + JB
    ref = solve_ivp(lambda _, y: [y[1], y[0] * y[3]**2, y[3], -2 * mB * y[0] * y[1] * y[3] / (J + mB * y[0]**2)],
                    (0, 1.0), [r0, 0, 0, W], t_eval=t, rtol=1e-11, atol=1e-12).y[0]
    errs = []
    for dt in (2e-3, 1e-3):
        r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": dt, "t_end": 1.0, "output_times": t.tolist(),
                             "v0": v0, "sensors": SENSOR})
        assert r.status == "completed"
        errs.append(np.abs(np.hypot(r.sensors["b"][:, 0], r.sensors["b"][:, 1]) - ref).max())
        assert np.abs(r.sensors["b"][:, 2]).max() < 1e-9  # stays in its plane
    assert 3.0 < errs[0] / errs[1] < 5.0 and errs[1] < 2e-6


def test_body_rigid_on_beam3d_tip_statics():
    """A body clamped into a beam3d cantilever's tip (centre e = 0.3 m beyond it), gravity -z: linear theory gives
    the tip deflection P L^3/(3EI) + M L^2/(2EI) and rotation P L^2/(2EI) + M L/EI (P = m g, M = P e), ~1 % of L,
    so geometric nonlinearity is ~1e-4 relative, and 16 elastic-line elements are within 3e-4 of the linear value
    under a plain tip force and moment (measured; 8 elements: 2e-3): tolerance 1e-3. The body's x axis turns with
    the tip (its z component is sin(phi))."""
    E, L, m, e = 2e11, 1.0, 5.0, 0.3
    sec = Section.rectangle(0.02, 0.02)
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.member("beam", [(0, 0, 0), (L, 0, 0)], 16, Material(E=E, density=7800), sec, element="beam3d",
             beam_method="elastic_line", gravity=False)
    s.clamp("beam", "start")
    s.body("b", m, (0.1, 0.1, 0.1), (L + e, 0, 0))
    s.rigid_body("b", "beam", "end")
    r = solve_static(s)
    assert r.success
    EI = E * sec.Iy
    P, Mo = m * G, m * G * e
    w, phi = P * L**3 / (3 * EI) + Mo * L**2 / (2 * EI), P * L**2 / (2 * EI) + Mo * L / EI
    tip = r.tip("beam")
    assert abs(-tip[2] / w - 1) < 1e-3
    c, axes = r.body("b")
    assert abs(-axes[0, 2] / math.sin(phi) - 1) < 1e-3
    assert np.allclose(c, tip + e * axes[0], atol=1e-9 * L)


def test_body_on_stiff_cable3d_swings_like_pendulum():
    """A rod pinned (spherical) to the end of a 0.1 m clamped steel cable3d of 20 mm diameter swings in a vertical
    plane like a compound pendulum on a fixed pivot (tip stiffness 3EI/L^3 ~ 5e6 N/m against ~10 N): period
    within 1e-3 of the exact value at 0.5 rad (elliptic integral), and no motion out of its plane (< 1e-9 m)."""
    m, Lr, th = 2.0, 1.0, 0.5
    J, d = m * Lr**2 / 12, Lr / 2
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.member("cable", [(0, 0, 0.1), (0, 0, 0)], 2, Material(E=2e11, density=7800), Section.circle(0.02),
             gravity=False)
    s.clamp("cable", "start")
    s.body("b", m, (J, J, 1e-3), (d * math.sin(th), 0, -d * math.cos(th)),
           axes=[[math.cos(th), 0, math.sin(th)], [0, 1, 0], [-math.sin(th), 0, math.cos(th)]])
    s.pin_body("b", "cable", "end")
    T = 4 * math.sqrt((J + m * d * d) / (m * G * d)) * ellipk(math.sin(th / 2) ** 2)
    r = run_dynamics(s, {"integrator": "generalized_alpha", "rho_inf": 0.8, "dt": 2e-3, "t_end": 2.2 * T,
                         "output_every": 1, "sensors": SENSOR})
    assert r.status == "completed"
    wy, t = r.sensors["b"][:, 4], r.t
    i = np.flatnonzero(np.sign(wy[:-1]) * np.sign(wy[1:]) < 0)
    tz = t[i] - wy[i] * (t[i + 1] - t[i]) / (wy[i + 1] - wy[i])
    assert abs(2 * np.mean(np.diff(tz)) / T - 1) < 1e-3
    assert np.abs(r.sensors["b"][:, 1]).max() < 1e-9


def test_mass_matrix_and_unknowns():
    """12 unknowns and 6 orthonormality rows per body; the mass matrix is diag(m, m, m) + C (x) I_3 with
    C = tr(I)/2 - I, so its kinetic energy for a rotation w equals 1/2 w . I w exactly."""
    I = np.array([[2.0, 0.3, 0.0], [0.3, 3.0, 0.1], [0.0, 0.1, 4.0]])
    s = Scene(dim=3)
    s.body("b", 2.0, I, (1, 2, 3))
    a = Assembly(s)
    assert a.n == 12 and a.constraints.m == 6
    w = np.array([0.3, -0.7, 1.1])
    v = velocities(a, rotation={"b": (w, (1, 2, 3))})
    assert math.isclose(0.5 * v @ a.mass_matrix() @ v, 0.5 * w @ I @ w, rel_tol=1e-13)


@pytest.mark.parametrize("call, match", [
    (lambda s: s.body("x", 0.0, (1, 1, 1), (0, 0, 0)), "body.mass"),
    (lambda s: s.body("x", 1.0, (1, -1, 1), (0, 0, 0)), "body.inertia"),
    (lambda s: s.body("x", 1.0, (1, 1, 3), (0, 0, 0)), "triangle"),
    (lambda s: s.body("x", 1.0, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]], (0, 0, 0)), "symmetric"),
    (lambda s: s.body("x", 1.0, (1, 1, 1), (0, 0, 0), axes=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]), "right-handed"),
    (lambda s: s.body("x", 1.0, (1, 1, 1), (0, 0, 0), angle=0.3), "body.angle"),
    (lambda s: s.revolute("b", point=(0, 0, 0)), "revolute.axis"),
    (lambda s: s.revolute("b", axis=(0, 0, 0)), "non-zero"),
    (lambda s: s.spherical("nobody"), "names no body"),
    (lambda s: s.spherical("b", other="b"), "another body"),
    (lambda s: s.pin_body("b", "nomember", "end"), "names no member"),
    (lambda s: s.prismatic("b", axis=(1, 0, 0), other="ghost"), "another body"),
])
def test_bad_spatial_input_refused(call, match):
    """Refused when given, naming the field: non-positive mass, inertia not SPD or not a mass distribution's
    (triangle inequality), non-rotation axes, planar fields, missing axis, unknown body or member."""
    s = Scene(dim=3)
    s.body("b", 1.0, (1, 1, 1), (0, 0, 0))
    with pytest.raises(SceneError, match=match):
        call(s)


def test_statics_refuses_a_free_spatial_body():
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("b", 1.0, (1, 1, 1), (0, 0, 0))
    with pytest.raises(SceneError, match="free rigid-body motion"):
        solve_static(s)


def test_world_torque_changes_angular_momentum_linearly():
    """A constant world torque tau on a spinning asymmetric body held at its centre by a spherical joint, without
    gravity: the angular momentum theorem gives L(t) = L0 + tau t exactly for any body. The torque enters as the
    configuration-dependent force 1/2 tau x e_k on each axis vector (no potential exists in 3D); L's error shrinks
    by ~4 per dt halving (second order) and is below 1e-4 |L(t_end)| at dt = 1 ms; the energy balance (torque work
    booked as external work) closes within 1e-3 of the kinetic energy (second-order error, ~1e-5 expected)."""
    I = np.diag([1.0, 2.0, 3.0])
    tau = np.array([0.5, -1.0, 2.0])
    w0 = np.array([0.3, 1.0, -0.5])
    errs = []
    for dt in (2e-3, 1e-3):
        s = Scene(dim=3)
        s.body("b", 2.0, np.diag(I), (0, 0, 0))
        s.spherical("b")
        s.torque("b", tau.tolist())
        r = spin(s, w0, dt, 2.0)
        assert r.status == "completed"
        T, L = invariants(r, I)
        errs.append(np.abs(L - (I @ w0 + np.outer(r.t, tau))).max())
        assert np.max(np.abs(r.energies["algorithmic"])) < 1e-3 * T[-1]
    assert 3.0 < errs[0] / errs[1] < 5.0
    assert errs[1] < 1e-4 * np.linalg.norm(I @ w0 + 2.0 * tau)


def test_position_drive_moves_a_spatial_body_centre():
    """A body's centre driven along z = t^2 / 2 (piecewise polynomial) while it may turn freely: every component
    follows the prescribed motion exactly at the steps (< 1e-9 m), z included."""
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("b", 1.0, (0.1, 0.2, 0.3), (0, 0, 0))
    s.drive_position([0.0, 0.0, [[0.0, [0.0, 0.0, 0.5]]]], body="b")
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 1e-2, "t_end": 1.0, "output_every": 5,
                         "sensors": SENSOR})
    assert r.status == "completed"
    assert np.abs(r.sensors["b"][:, :3] - np.c_[0 * r.t, 0 * r.t, 0.5 * r.t**2]).max() < 1e-9


def test_spatial_drive_and_torque_input_refused():
    s = Scene(dim=3)
    s.body("b", 1.0, (1, 1, 1), (0, 0, 0))
    with pytest.raises(SceneError, match="3 motions"):
        s.torque("b", 5.0)
    with pytest.raises(SceneError, match="needs exactly one revolute joint"):
        s.drive("b", angle=0.3)
