"""Drives (prescribed angle / position in time) and applied torques on planar rigid bodies.

References: the prescribed motion itself (a drive is an exact index-3 row: the body follows theta(t) to the Newton
tolerance); scipy's solve_ivp of the one-degree-of-freedom ODE of a pendulum hung from a driven crank or a driven
cart; the torque a drive needs to turn a rod at a prescribed angular acceleration against gravity (closed form).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ancf_sym import Scene, SceneError
from ancf_sym.bodies.drives import motion
from ancf_sym.dynamics import run_dynamics
from ancf_sym.io.scene_toml import scene_from_dict

G = 9.81
# paper 001's sprocket speed relative to the chassis: 0 until 1 s, a smooth ramp to 10 rad/s at 2 s, then constant
PAPER_OMEGA = [[0.0, [0.0]], [1.0, [0.0, 0.0, 80 / 3]], [1.25, [5 / 3, 40 / 3]], [1.75, [25 / 3, 40 / 3, -80 / 3]],
               [2.0, [10.0]]]


def body_sensor(*names):
    return [{"name": n, "kind": "body", "member": n} for n in names]


def test_piecewise_omega_integral_is_exact_and_continuous():
    """The angle of paper 001's omega(t) is the exact integral: at the breaks it equals the closed-form areas
    (ramp pieces: 80/9 (1/4)^3 = 5/36 at 1.25 s; + 1/2 (5/3 + 25/3) / 2 = 5/2 at 1.75 s; ...), and omega is
    continuous (the paper's pieces join)."""
    m = motion("omega", PAPER_OMEGA, integral_of=0.0)
    a125 = 80 / 9 * 0.25**3
    a175 = a125 + 0.5 * (5 / 3 + 25 / 3) * 0.5
    a2 = a175 + 25 / 3 * 0.25 + 20 / 3 * 0.25**2 - 80 / 9 * 0.25**3
    for t, ref in ((1.0, 0.0), (1.25, a125), (1.75, a175), (2.0, a2), (3.0, a2 + 10.0)):
        assert m(t)[0] == pytest.approx(ref, rel=1e-14, abs=1e-14)
    for tb in (1.25, 1.75, 2.0):
        assert m(tb - 1e-12)[1] == pytest.approx(m(tb)[1], abs=1e-9)


def test_relative_drive_on_pitching_chassis_follows_theta():
    """A wheel on a revolute joint to a chassis that swings as a pendulum, driven relative to the chassis with
    paper 001's omega(t): the relative angle follows its integral to the Newton tolerance (the drive is an exact
    row enforced each step below xtol x length ~ 1e-10; 1e-8 rad leaves room for the output's round-off), its
    rate to the scheme's velocity error O(h^2 omega'') (h = 1 ms, omega'' <= 1e3 rad/s^3 at the breaks: 2e-3),
    and the work of the drive balances the energy (algorithmic energy below 1e-3 of the kinetic energy)."""
    s = Scene(dim=2, gravity=(0, -G))
    s.body("chassis", 5.0, 1.0, position=(1.0, 0.0))
    s.revolute("chassis", point=(0, 0))
    s.body("wheel", 1.0, 0.1, position=(2.0, 0.0))
    s.revolute("wheel", other="chassis")
    s.drive("wheel", omega=PAPER_OMEGA, relative_to="chassis")
    r = run_dynamics(s, {"integrator": "hht", "dt": 1e-3, "t_end": 3.0, "output_every": 10,
                         "sensors": body_sensor("chassis", "wheel")})
    assert r.status == "completed"
    m = motion("omega", PAPER_OMEGA, integral_of=0.0)
    rel = np.unwrap(r.sensors["wheel"][:, 2] - r.sensors["chassis"][:, 2])
    assert np.abs(rel - [m(t)[0] for t in r.t]).max() < 1e-8
    rate = r.sensors["wheel"][:, 3] - r.sensors["chassis"][:, 3]
    assert np.abs(rate - [m(t)[1] for t in r.t]).max() < 2e-3
    assert np.ptp(r.sensors["chassis"][:, 2]) > 0.5  # the chassis does pitch
    assert abs(r.energies["algorithmic"][-1]) < 1e-3 * r.energies["kinetic"][-1]
    assert r.constraint_violation.max() < 1e-9


def _pendulum_ode(Jo, m, d, accel):
    """(J + m d^2) phi'' + m d (P'' . (-sin phi, cos phi)) + m g d cos phi = 0 for a rod whose end P(t) moves
    with acceleration accel(t) (phi: the rod's angle from the x axis, centre at P + d (cos phi, sin phi))."""
    def f(t, y):
        ax, ay = accel(t)
        return [y[1], -(m * d * (-ax * math.sin(y[0]) + ay * math.cos(y[0])) + m * G * d * math.cos(y[0])) / Jo]
    return f


def test_pendulum_on_driven_crank_against_ode():
    """A rod hung from the tip of a crank driven at a constant 4 rad/s after a quadratic start (angle drive on the
    crank, body-body revolute): the rod's angle against solve_ivp (rtol 1e-10) of its ODE with the known pivot
    acceleration, within 2e-3 rad over 3 s (generalized-alpha at h = 1 ms: phase error ~ (omega h)^2 t omega ~ 1e-4,
    the start transient's error a little more)."""
    m, length, R, W = 1.0, 0.8, 0.3, 4.0
    J, d = m * length**2 / 12, length / 2
    s = Scene(dim=2, gravity=(0, -G))
    s.body("crank", 2.0, 0.05, position=(0.0, 0.0))
    s.revolute("crank")
    phi0 = -math.pi / 2 + 0.3
    s.body("rod", m, J, position=(R + d * math.cos(phi0), d * math.sin(phi0)), angle=phi0)
    s.revolute("rod", point=(R, 0.0), other="crank")
    s.drive("crank", omega=[[0.0, [0.0, W]], [1.0, [W]]])  # theta = 2 t^2 until 1 s, then 4 rad/s
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 3.0, "output_every": 10,
                         "sensors": body_sensor("rod")})
    assert r.status == "completed"
    th = motion("omega", [[0.0, [0.0, W]], [1.0, [W]]], integral_of=0.0)

    def accel(t):  # P = R (cos theta, sin theta)
        a, w, al = th(t)
        return (-R * (w * w * math.cos(a) + al * math.sin(a)), R * (-w * w * math.sin(a) + al * math.cos(a)))
    ref = solve_ivp(_pendulum_ode(J + m * d * d, m, d, accel), (0, 3.0), [phi0, 0.0], t_eval=r.t, rtol=1e-10,
                    atol=1e-12, max_step=1e-2)
    assert np.abs(np.unwrap(r.sensors["rod"][:, 2]) - ref.y[0]).max() < 2e-3


def test_pendulum_on_driven_cart_against_ode():
    """A position drive: a cart's centre moves as x = A (1 - cos Omega t) (starting at rest), a rod hangs from it
    on a revolute joint; the rod's angle against solve_ivp of its ODE within 2e-3 rad (as the crank test). The
    drive's force on the cart at the outputs equals m_cart x'' + the rod's pull, checked through the horizontal
    momentum balance to 2 % (the reaction is the multiplier of an exact row)."""
    m, length, A, Om, mc = 1.0, 0.6, 0.2, 5.0, 3.0
    J, d = m * length**2 / 12, length / 2
    s = Scene(dim=2, gravity=(0, -G))
    s.body("cart", mc, 0.1, position=(0.0, 0.0))
    s.body("rod", m, J, position=(0.0, -d), angle=-math.pi / 2)
    s.revolute("rod", point=(0.0, 0.0), other="cart")
    x_cart = (lambda t: A * (1 - math.cos(Om * t)), lambda t: A * Om * math.sin(Om * t),
              lambda t: A * Om * Om * math.cos(Om * t))
    s.drive_position(body="cart", position=[x_cart, 0.0])
    s.drive("cart", angle=0.0)
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 2.0, "output_every": 10,
                         "sensors": body_sensor("rod", "cart")})
    assert r.status == "completed"
    ref = solve_ivp(_pendulum_ode(J + m * d * d, m, d, lambda t: (A * Om * Om * math.cos(Om * t), 0.0)),
                    (0, 2.0), [-math.pi / 2, 0.0], t_eval=r.t, rtol=1e-10, atol=1e-12, max_step=1e-2)
    assert np.abs(np.unwrap(r.sensors["rod"][:, 2]) - ref.y[0]).max() < 2e-3
    # horizontal momentum: F_drive = mc x_cart'' + m x_rod'' (x_rod = x_cart + d cos phi)
    t, phi = r.t, ref.y[0]
    dphi = ref.y[1]
    ddphi = np.array([_pendulum_ode(J + m * d * d, m, d, lambda t: (A * Om * Om * math.cos(Om * t), 0.0))(
        ti, [p, w])[1] for ti, p, w in zip(t, phi, dphi)])
    xdd = A * Om * Om * np.cos(Om * t)
    F = (mc + m) * xdd + m * d * (-np.sin(phi) * ddphi - np.cos(phi) * dphi**2)
    Fx = r.drive_reactions["position cart"][:, 0]
    assert np.abs(Fx - F).max() < 0.02 * np.abs(F).max()


def test_drive_reaction_torque_against_closed_form():
    """A rod on a ground revolute at its end, turned at the prescribed angle theta = -pi/2 + alpha t^2 / 2 under
    gravity: the drive's torque is J_o alpha + m g d cos(theta) (rod centre at d (cos, sin) theta). The drive's
    reaction (multiplier of the exact row) matches to 1e-4 N m after the start (1e-5 of the torque): the scheme's
    acceleration of the unit vector (c, s) carries an O(h^2) error ~ h^2 |d^4 u / dt^4| ~ h^2 omega^4 = 8e-5 at
    omega = 3 rad/s, times J_o = 0.67 kg m^2; the index-3 multipliers' O(h) start-up oscillation is damped by the
    scheme (rho_inf = 0.5) before t = 0.5 s."""
    m, length, alpha = 2.0, 1.0, 1.5
    J, d = m * length**2 / 12, length / 2
    s = Scene(dim=2, gravity=(0, -G))
    s.body("rod", m, J, position=(0.0, -d), angle=-math.pi / 2)
    s.revolute("rod", point=(0, 0))
    s.drive("rod", angle=[[0.0, [-math.pi / 2, 0.0, alpha / 2]]])
    r = run_dynamics(s, {"integrator": "generalized_alpha", "rho_inf": 0.5, "dt": 1e-3, "t_end": 2.0,
                         "output_every": 10})
    assert r.status == "completed"
    th = -math.pi / 2 + alpha * r.t**2 / 2
    tau = (J + m * d * d) * alpha + m * G * d * np.cos(th)
    got = r.drive_reactions["angle rod"][:, 0]
    late = r.t > 0.5
    assert np.abs(got[late] - tau[late]).max() < 1e-4


def test_applied_torque_spins_disc():
    """A disc on a revolute joint under the torque tau = 2 t (a motion of time): angle = tau t^3 / (6 J), within
    Newmark's O(h^2) error (h = 1 ms: ~1e-6 rad here); the torque's work is booked (energy balance to 1e-5)."""
    s = Scene(dim=2, gravity=(0, 0))
    s.body("disc", 1.0, 0.5, position=(0, 0))
    s.revolute("disc")
    s.torque("disc", [[0.0, [0.0, 2.0]]])
    r = run_dynamics(s, {"integrator": "newmark", "dt": 1e-3, "t_end": 1.0, "output_every": 10,
                         "sensors": body_sensor("disc")})
    assert r.status == "completed"
    assert np.abs(np.unwrap(r.sensors["disc"][:, 2]) - r.t**3 / 1.5).max() < 1e-5
    assert abs(r.energies["algorithmic"][-1]) < 1e-5


def test_drives_from_toml_match_api():
    """[[drives]] tables build the same drives as the Python API (angle with omega pieces, torque)."""
    doc = {"scene": {"dim": 2, "gravity": [0, 0]},
           "materials": {"m": {"E": 1e9, "density": 1000}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
           "members": [{"name": "c", "points": [[0, 1], [1, 1]], "elements": 2, "material": "m", "section": "s"}],
           "supports": [{"type": "pin", "member": "c", "at": "start"}],
           "bodies": [{"name": "a", "mass": 1, "inertia": 0.1, "position": [0, 0], "revolute": [0, 0]},
                      {"name": "b", "mass": 1, "inertia": 0.1, "position": [1, 0], "revolute_body": "a"}],
           "drives": [{"type": "angle", "body": "b", "relative_to": "a", "omega": PAPER_OMEGA},
                      {"type": "torque", "body": "a", "torque": 2.0},
                      {"type": "position", "member": "c", "at": "end", "position": [1.0, [[0, [1.0, 0.1]]]]}],
           "analysis": {"type": "dynamics", "dt": 0.01, "t_end": 0.1}}
    scene, _ = scene_from_dict(doc)
    kinds = [type(d).__name__ for d in scene.drives]
    assert kinds == ["AngleDrive", "Torque", "PositionDrive"]
    assert scene.drives[0].relative_to == "a"
    assert scene.drives[0].angle(3.0)[1] == 10.0


@pytest.mark.parametrize("kw, needle", [
    (dict(body="nope", omega=1.0), "body='nope'"),
    (dict(body="a", omega=1.0, angle=0.0), "exactly one of angle"),
    (dict(body="a", omega=[[1.0, [1]], [0.5, [2]]]), "increasing"),
    (dict(body="a", omega=lambda t: t), "callable"),
    (dict(body="a", omega=float("nan")), "finite"),
    (dict(body="a", angle=1.0, relative_to="a"), "another body"),
])
def test_bad_drives_refused(kw, needle):
    s = Scene(dim=2)
    s.body("a", 1.0, 1.0, position=(0, 0))
    with pytest.raises(SceneError, match=needle):
        s.drive(**kw)


def test_drive_conflicts_refused_before_work():
    """A position drive on a pinned body, collocation with drives, statics with drives, and a start state off the
    drive: each refused with the drive's name before any step."""
    s = Scene(dim=2)
    s.body("a", 1.0, 1.0, position=(0, 0))
    s.revolute("a")
    s.drive_position(body="a", position=[0.0, 0.0])
    with pytest.raises(SceneError, match="already fixes"):
        run_dynamics(s, {"dt": 0.01, "t_end": 0.1})
    s = Scene(dim=2)
    s.body("a", 1.0, 1.0, position=(0, 0))
    s.revolute("a")
    s.drive("a", angle=0.5)
    with pytest.raises(SceneError, match="violates drive 'angle a'"):
        run_dynamics(s, {"dt": 0.01, "t_end": 0.1})
    with pytest.raises(SceneError, match="collocation"):
        run_dynamics(s, {"integrator": "radau", "dt": 0.01, "t_end": 0.1})
    with pytest.raises(SceneError, match="drives"):
        s.validate_for_statics()
    s2 = Scene(dim=2)
    s2.body("a", 1.0, 1.0, position=(0, 0))
    s2.revolute("a")
    s2.drive("a", omega=2.0)  # starts at 2 rad/s while the body is at rest
    with pytest.raises(SceneError, match="v0 .*violates drive"):
        run_dynamics(s2, {"dt": 0.01, "t_end": 0.1})
