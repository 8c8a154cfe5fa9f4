"""Angle drives on spatial bodies: a body turned about its revolute joint's axis, relative to the ground or to the
body it is jointed to, at a prescribed angle or angular velocity.

References: the prescribed motion itself (the drive is an exact index-3 row, met to the Newton tolerance at every
step); the exact integral of paper 001's piecewise-polynomial sprocket speed; the torque about a fixed axis, J_o
alpha minus the gravity moment about the axis (the axial component of the angular momentum theorem, whatever the
products of inertia); the energy balance (the drive's work booked through its multiplier).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Scene, SceneError
from ancf_sym.bodies.rows import normals
from ancf_sym.bodies.drives import motion
from ancf_sym.dynamics import run_dynamics
from ancf_sym.io.scene_toml import scene_from_dict

G = 9.81
PAPER_OMEGA = [[0.0, [0.0]], [1.0, [0.0, 0.0, 80 / 3]], [1.25, [5 / 3, 40 / 3]], [1.75, [25 / 3, 40 / 3, -80 / 3]],
               [2.0, [10.0]]]
INERTIA = [[0.30, 0.02, -0.01], [0.02, 0.25, 0.03], [-0.01, 0.03, 0.40]]  # not principal: gyroscopic joint loads


def sensors(*names):
    return [{"name": n, "kind": "body", "member": n} for n in names]


def joint_angle(r, scene, body, other, axis):
    """atan2(u.w2, u.w1) from the body sensors' axes (rows e_k): u = the body's n1 of the axis, w1, w2 = the other
    side's n1, n2 (world n1, n2 on the ground), unwrapped."""
    n1, n2 = normals(np.asarray(axis, float) / np.linalg.norm(axis))

    def fixed(name, d):
        if name is None:
            return np.tile(d, (len(r.t), 1))
        E = r.sensors[name][:, 6:].reshape(-1, 3, 3)
        return np.einsum("tkc,k->tc", E, scene.bodies[name].local_direction(d))

    u, w1, w2 = fixed(body, n1), fixed(other, n1), fixed(other, n2)
    return np.unwrap(np.arctan2((u * w2).sum(1), (u * w1).sum(1)))


@pytest.mark.parametrize("integrator", ["newmark", "hht", "generalized_alpha"])
def test_wheel_on_ground_revolute_tracks_paper_omega(integrator):
    """A wheel with an off-axis centre and a non-principal inertia on a ground revolute joint of a tilted axis,
    driven with paper 001's omega(t) to 2.5 s: the joint angle follows the exact integral to the Newton tolerance
    (the row is enforced each step below ~1e-10; 1e-8 rad leaves room for the output's round-off) in every alpha
    scheme, the angular velocity about the axis follows omega to the scheme's velocity error O(h^2 omega'')
    (h = 1 ms, omega'' <= 1e3 rad/s^3 at the breaks: 2e-3 rad/s), and the drive's work balances the energy
    (algorithmic energy below 1e-3 of the final kinetic energy)."""
    axis = np.array([0.3, 1.0, 0.2])
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("w", 3.0, INERTIA, (0.05, 0.0, 0.02))
    s.revolute("w", point=(0, 0, 0), axis=axis.tolist())
    s.drive("w", omega=PAPER_OMEGA)
    r = run_dynamics(s, {"integrator": integrator, "dt": 1e-3, "t_end": 2.5, "output_every": 10,
                         "sensors": sensors("w")})
    assert r.status == "completed", r.message
    m = motion("omega", PAPER_OMEGA, integral_of=0.0)
    assert np.abs(joint_angle(r, s, "w", None, axis) - [m(t)[0] for t in r.t]).max() < 1e-8
    rate = r.sensors["w"][:, 3:6] @ (axis / np.linalg.norm(axis))
    assert np.abs(rate - [m(t)[1] for t in r.t]).max() < 2e-3
    assert abs(r.energies["algorithmic"][-1]) < 1e-3 * r.energies["kinetic"][-1]
    assert r.constraint_violation.max() < 1e-9


def test_drive_torque_is_j_alpha_minus_gravity_moment():
    """A rod-like body on a ground revolute joint (horizontal axis n through a point off its centre, products of
    inertia about the axis), turned at theta = alpha t^2 / 2 (starting with a non-zero acceleration: the initial
    acceleration solve must honour the drive's second time derivative). About a fixed axis the angular momentum
    theorem's axial part is exact: tau = J_o alpha - n.((r_c - p) x m g), J_o = n.I_c n + m |(r_c - p) x n|^2.
    The drive's reaction matches within 1e-4 N m after 0.5 s (the scheme's O(h^2) acceleration error ~ h^2 omega^4
    J_o ~ 1e-5 at omega <= 3 rad/s; the index-3 multipliers' start-up oscillation is damped by rho_inf = 0.5)."""
    m, alpha = 2.0, 1.5
    n = np.array([0.0, 1.0, 0.0])
    p = np.zeros(3)
    I = np.array(INERTIA)
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("rod", m, I.tolist(), (0.4, 0.1, -0.1))
    s.revolute("rod", point=p.tolist(), axis=n.tolist())
    s.drive("rod", angle=[[0.0, [0.0, 0.0, alpha / 2]]])
    r = run_dynamics(s, {"integrator": "generalized_alpha", "rho_inf": 0.5, "dt": 1e-3, "t_end": 2.0,
                         "output_every": 10, "sensors": sensors("rod")})
    assert r.status == "completed", r.message
    E0 = s.bodies["rod"].axes
    d = s.bodies["rod"].position - p
    Jo = n @ (E0.T @ I @ E0) @ n + m * np.linalg.norm(np.cross(d, n)) ** 2  # invariant under turns about n
    rc = r.sensors["rod"][:, :3]
    moment = np.cross(rc - p, m * np.array([0, 0, -G])) @ n
    tau = Jo * alpha - moment
    got = r.drive_reactions["angle rod"][:, 0]
    late = r.t > 0.5
    assert np.ptp(moment) > 1.0  # gravity's moment does vary along the run
    assert np.abs(got[late] - tau[late]).max() < 1e-4


def test_wheel_on_moving_carrier_follows_relative_omega():
    """A carrier swinging on a spherical joint (its centre translates and it pitches and rolls) carries an
    eccentric wheel on a body-body revolute joint, driven relative to the carrier with paper 001's omega(t)
    (1 ms, to 2.5 s, HHT): the relative joint angle follows the exact integral to the Newton tolerance (1e-8 rad),
    the relative rate about the carrier's axis to O(h^2 omega'') (2e-3 rad/s), the carrier does move (it is pushed
    by the wheel's reaction), and the energy balance closes (1e-3 of the kinetic energy)."""
    axis = [0.0, 1.0, 0.0]
    s = Scene(dim=3, gravity=(0, 0, -G))
    s.body("carrier", 5.0, (0.5, 0.4, 0.3), (1.0, 0.0, 0.0))
    s.spherical("carrier", point=(0, 0, 0))
    s.body("wheel", 1.0, INERTIA, (1.5, 0.1, 0.05))
    s.revolute("wheel", point=(1.5, 0.1, 0.0), axis=axis, other="carrier")
    s.drive("wheel", omega=PAPER_OMEGA, relative_to="carrier")
    r = run_dynamics(s, {"integrator": "hht", "dt": 1e-3, "t_end": 2.5, "output_every": 10,
                         "sensors": sensors("carrier", "wheel")})
    assert r.status == "completed", r.message
    mo = motion("omega", PAPER_OMEGA, integral_of=0.0)
    assert np.abs(joint_angle(r, s, "wheel", "carrier", axis) - [mo(t)[0] for t in r.t]).max() < 1e-8
    Ec = r.sensors["carrier"][:, 6:].reshape(-1, 3, 3)
    t_world = np.einsum("tkc,k->tc", Ec, s.bodies["carrier"].local_direction(axis))
    rel = ((r.sensors["wheel"][:, 3:6] - r.sensors["carrier"][:, 3:6]) * t_world).sum(1)
    assert np.abs(rel - [mo(t)[1] for t in r.t]).max() < 2e-3
    assert np.ptp(r.sensors["carrier"][:, 2]) > 0.1 and np.ptp(r.sensors["carrier"][:, 1]) > 1e-3
    assert abs(r.energies["algorithmic"][-1]) < 1e-3 * r.energies["kinetic"][-1]
    assert r.constraint_violation.max() < 1e-9


def test_spatial_angle_drive_from_toml_and_refusals():
    """[[drives]] of type angle on 3D bodies (the revolute joint from the [[bodies]] table); a drive without a
    revolute joint between the two sides is refused, naming the body."""
    doc = {"scene": {"dim": 3, "gravity": [0, 0, -G]},
           "bodies": [{"name": "c", "mass": 5, "inertia": [1, 1, 1], "position": [0, 0, 1],
                       "revolute": {"point": [0, 0, 1], "axis": [1, 0, 0]}},
                      {"name": "w", "mass": 1, "inertia": [0.1, 0.1, 0.1], "position": [0.5, 0, 1],
                       "revolute": {"point": [0.5, 0, 1], "axis": [0, 1, 0], "other": "c"}}],
           "drives": [{"type": "angle", "body": "w", "relative_to": "c", "omega": PAPER_OMEGA},
                      {"type": "angle", "body": "c", "angle": [[0, [0, 0, 0.5]]]}],
           "analysis": {"type": "dynamics", "dt": 0.01, "t_end": 0.05}}
    scene, _ = scene_from_dict(doc)
    assert [d.relative_to for d in scene.drives] == ["c", None]
    assert scene.drives[0].angle(3.0)[1] == 10.0
    r = run_dynamics(scene, {"dt": 1e-2, "t_end": 1.0, "output_every": 10, "sensors": sensors("c")})
    assert r.status == "completed"
    assert np.abs(joint_angle(r, scene, "c", None, [1, 0, 0]) - 0.5 * r.t**2).max() < 1e-8
    s = Scene(dim=3)
    s.body("a", 1.0, (1, 1, 1), (0, 0, 0))
    s.body("b", 1.0, (1, 1, 1), (1, 0, 0))
    with pytest.raises(SceneError, match="revolute joint between 'a' and the ground"):
        s.drive("a", angle=0.3)
    s.spherical("b", other="a")
    with pytest.raises(SceneError, match="revolute joint between 'b' and 'a'"):
        s.drive("b", omega=1.0, relative_to="a")
    s.revolute("a", axis=(0, 0, 1))
    with pytest.raises(SceneError, match="angle0"):
        s.drive("a", angle=0.3, angle0=1.0)
    assert math.isclose(s.drive("a", omega=2.0, angle0=0.0, name="spin").angle(0.5)[0], 1.0)
