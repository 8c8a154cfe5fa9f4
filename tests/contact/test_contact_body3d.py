"""Drums carried by spatial rigid bodies: cable3d and beam3d centre lines against a cylinder fixed in a body
(kernels <element>_contact_body_drum[_friction], inputs the element's and the body's coordinates r, e1, e2, e3).

References: the fixed drum's kernels (same geometry: a held body's drum must act exactly like it); the rigid motion
of member and body together (no relative velocity: no friction or damping force, whatever the body's spin and
tumbling); Atwood's machine with a massive pulley, a = g (m_h - m_l) / (m_h + m_l + m_rope + J / R^2), for a rope
over a free pulley on a revolute joint with friction well above the stick limit (as the planar body's drum test).
The kernels' derivatives against finite differences are in test_derivatives (catalogue) with the other kernels.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, contact, kernels, registry
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate
from ancf_sym.io.scene_toml import scene_from_dict

from helpers import rotation, same_motion_tol

G = 9.81
K, KH, T, C, MU, EPS = 2.0e4, 5.0e4, 0.01, 3.0, 0.4, 0.05
EL_L = 0.2


def _straight(element: str, z: float) -> np.ndarray:
    """An element from (-L/2, 0, z) to (L/2, 0, z) along x, unit slope (beam: r_y = e_y, r_z = e_z)."""
    ex = np.eye(3)[0]
    if element == "beam3d":
        node = lambda x: np.concatenate([x * ex + [0, 0, z], ex, np.eye(3)[1], np.eye(3)[2]])
    else:
        node = lambda x: np.concatenate([x * ex + [0, 0, z], ex])
    return np.concatenate([node(-EL_L / 2), node(EL_L / 2)])


def _rigid_velocity(element: str, q: np.ndarray, centre: np.ndarray, vc: np.ndarray, omega: np.ndarray):
    """Velocities of the element's coordinates in the rigid motion v = vc + omega x (x - centre)."""
    blocks = q.reshape(-1, 3)
    per_node = 2 if element.startswith("cable") else 4
    v = np.cross(omega, blocks)  # gradients turn
    v[::per_node] = vc + np.cross(omega, blocks[::per_node] - centre)
    return v.ravel()


@pytest.mark.parametrize("element", ["cable3d", "beam3d"])
def test_body_drum_kernels_equal_the_fixed_drum_and_see_rigid_motion(element):
    """A straight element pressed 2 mm into a drum (radius 0.3 m, axis y) carried by a turned body whose centre is
    off the drum axis: the body kernels' energy and member forces equal the fixed drum's at the same world centre and
    axis (same density, different inputs: to round-off, 1e-12 relative), and the body takes the opposite total force
    (action = reaction). Member and body in one rigid motion (translation plus a spin with all three components):
    zero friction and damping force (1e-12 of k L delta); the member at rest on the moving drum is dragged."""
    R = 0.3
    q = _straight(element, 0.0)
    nd = q.size
    centre = np.array([0.0, 0.0, -(R + T - 0.002)])
    E = rotation([0.2, 0.7, -0.4], 1.1)  # rows e1, e2, e3 in world components
    s = np.array([0.05, -0.1, 0.2])  # the drum's axis point in body components
    rb = centre - E.T @ s
    axis = np.array([0.0, 1.0, 0.0])
    a_b = E @ axis
    body = np.r_[rb, E.ravel()]
    fixed = kernels.load(element, "contact_drum")(q, np.r_[EL_L, K, KH, T, R, axis, centre])
    mine = kernels.load(element, "contact_body_drum")(np.r_[q, body], np.r_[EL_L, K, KH, T, R, a_b, s])
    e0, g0 = float(fixed[0]), np.asarray(fixed[1]).ravel()
    e1, g1 = float(mine[0]), np.asarray(mine[1]).ravel()
    assert e0 > 0 and e1 == pytest.approx(e0, rel=1e-12)
    assert np.abs(g1[:nd] - g0).max() < 1e-12 * np.abs(g0).max()
    per_node = 2 if element.startswith("cable") else 4
    f_member = -g1[:nd].reshape(-1, 3)[::per_node].sum(0)
    assert np.allclose(-g1[nd:nd + 3], -f_member, rtol=0, atol=1e-12 * np.abs(f_member).max())

    k = kernels.load(element, "contact_body_drum_friction")
    p = np.r_[EL_L, K, KH, T, R, a_b, C, MU, EPS, s]
    vb, omega = np.array([0.3, -0.2, 0.5]), np.array([0.4, 2.0, -0.7])
    v = _rigid_velocity(element, q, rb, vb, omega)
    Ed = np.cross(omega, E)  # e_k' = omega x e_k
    _, g, _ = k(np.r_[q, body, v, vb, Ed.ravel()], p)
    f = np.asarray(g).ravel()[nd + 12:]
    assert np.abs(f).max() < 1e-12 * K * EL_L * 0.002
    _, g, _ = k(np.r_[q, body, np.zeros(nd), vb, Ed.ravel()], p)  # the member at rest, the drum moving under it
    f = -np.asarray(g).ravel()[nd + 12:nd + 12 + nd].reshape(-1, 3)[::per_node].sum(0)
    x_top = np.zeros(3)
    v_surface = vb + np.cross(omega, x_top - rb)  # the drum's material point under the member's middle
    assert f @ v_surface > 0  # dragged along


# -- a rope over a drum: fixed, on a held body, on a free pulley ------------------------------------------------
R, LEG, LM = 0.1, 0.6, 0.05
ROPE = Material(E=1e10, density=300.0)
SEC, MASS_SEC = Section.circle(0.003), Section.circle(0.02)
AXES = rotation([0.0, 1.0, 0.0], 0.4)  # the pulley's axes, turned about the drum axis y: y stays principal
INERTIA = (0.006, 0.01, 0.008)  # body axes: J about the drum axis (body y) = 0.01 kg m^2, J / R^2 = 1 kg


def _path(s):
    """The rope's reference line in the x-z plane: up the left leg (x = -R), over the top, down the right leg."""
    r, t = np.zeros((len(s), 3)), np.zeros((len(s), 3))
    arc = R * math.pi
    for k, sk in enumerate(s):
        if sk <= LEG + LM:
            r[k], t[k] = (-R, 0.0, -(LEG + LM) + sk), (0.0, 0.0, 1.0)
        elif sk <= LEG + LM + arc:
            a = math.pi - (sk - LEG - LM) / R
            r[k], t[k] = (R * math.cos(a), 0.0, R * math.sin(a)), (math.sin(a), 0.0, -math.cos(a))
        else:
            r[k], t[k] = (R, 0.0, -(sk - LEG - LM - arc)), (0.0, 0.0, -1.0)
    return r, t


def rope_over(drum: str, mu: float, m_h: float, m_l: float, t_end: float = 0.4, newton: dict | None = None,
              eps: float = 5e-3):
    """The capstan set-up in 3D (cable3d rope over half a drum of axis y, end masses as short dense members) with
    the drum fixed ('fixed'), carried by a spatial body held by a revolute joint and an angle drive at 0 ('held'),
    or by a body free to turn on the revolute joint ('free'). The body's centre lies on the drum axis but 5 cm off
    the drum's axis point, its axes are turned: the drum's point and axis are stored in body components."""
    L = 2 * LEG + R * math.pi
    sc = Scene(dim=3, gravity=(0.0, 0.0, -G))
    for nm, a, b, m in (("mass_l", -LM, 0.0, m_l), ("rope", 0.0, L, None), ("mass_h", L, L + LM, m_h)):
        mat = ROPE if m is None else Material(E=ROPE.E, density=m / (LM * MASS_SEC.area))
        sc.member(nm, [(a, 0.0, 0.0), (b, 0.0, 0.0)], 20 if m is None else 2, mat, SEC if m is None else MASS_SEC,
                  bending=m is not None)
    sc.hinge(("mass_l", "end"), ("rope", "start"))
    sc.hinge(("rope", "end"), ("mass_h", "start"))
    law = dict(stiffness=1e6, mu=mu, eps=eps, damping=1e3)
    if drum == "fixed":
        sc.contact_drum("rope", (0.0, 0.0, 0.0), R, axis=(0, 1, 0), **law)
    else:
        sc.body("pulley", 2.0, INERTIA, position=(0.0, 0.05, 0.0), axes=AXES.tolist())
        sc.revolute("pulley", point=(0, 0, 0), axis=(0, 1, 0))
        if drum == "held":
            sc.drive("pulley", angle=0.0)
        sc.contact_drum("rope", (0.0, 0.0, 0.0), R, axis=(0, 1, 0), body="pulley", **law)
    sc.strain_rate_damping(axial=ROPE.E * SEC.area * 5e-3, members=["rope"])
    asm = Assembly(sc)
    q0 = asm.x0.copy()
    for nm, s0 in (("mass_l", -LM), ("rope", 0.0), ("mass_h", L)):
        mm = asm.mesh.members[nm]
        n = len(mm.x0)
        r, t = _path(s0 + np.linspace(0.0, LM if nm != "rope" else L, n) + LM)
        for k in range(n):
            q0[mm.node_dofs(k)] = np.r_[r[k], t[k]]
    sensors = [Sensor("v", "velocity", "mass_h", "end")] + ([Sensor("p", "body", "pulley")] if drum != "fixed" else [])
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=t_end, q0=q0, rho_inf=0.6, output_dt=2e-3, sensors=sensors,
                                       newton=newton or {}))
    return res, ROPE.density * SEC.area * L


def test_held_spatial_body_drum_acts_as_the_fixed_drum():
    """Sliding over a drum (mu = 0.1, mass ratio 2 > e^(0.1 pi)): a drum on a spatial body held by a revolute joint
    and an angle drive at 0, and the fixed drum at the same axis, give the same motion: the body's coordinates
    enter the kernels exactly as the fixed geometry (its velocity is 0). Newton is run to its absolute update
    tolerance every step, so while the two differently structured systems (the held one has the body's
    multipliers) take the same steps they agree to that level: 1e-8 m/s over the first 20 ms. The wrapped start
    makes Newton reject and halve steps in both, and whether a step that converges at the iteration limit is
    accepted can hinge on round-off: then the step sequences part and the runs agree to the time discretisation's
    error (helpers.same_motion_tol)."""
    tight = {"single": False, "lte_fraction": 0.0}
    fixed, _ = rope_over("fixed", 0.1, 2.0, 1.0, t_end=0.02, newton=tight)
    held, _ = rope_over("held", 0.1, 2.0, 1.0, t_end=0.02, newton=tight)
    assert fixed.success and held.success
    v = np.asarray(fixed.sensors["v"])
    assert np.abs(v).max() > 0.1  # the rope does move
    assert np.abs(np.asarray(held.sensors["v"]) - v).max() < same_motion_tol(fixed, held)
    assert np.abs(held.sensors["p"][:, 3:6]).max() < 1e-8  # the drive holds it (angular velocity)


EPS_FREE = 0.05


def test_rope_over_free_spatial_pulley_is_atwoods_machine():
    """mu = 0.5 (stick limit e^(pi/2) = 4.8 against a mass ratio of 1.5): the rope turns a free spatial pulley
    (revolute joint about y, J = 0.01 kg m^2 about it, J / R^2 = 1 kg) without slipping, so a = g (m_h' - m_l') /
    (m_h' + m_l' + m_rope + J / R^2) (m' = m + the leg's rope mass). Within 4 % as the planar pulley test (wrap
    resolved by cubic elements over 0.8 rad each, the residual axial oscillation in the fit). The regularised
    friction creeps: the rim (omega_y R) lags the rope by w = eps rho / sqrt(1 - rho^2), rho the fraction of the
    friction capacity in use (tension ratio ~1.1 of the 4.8 allowed: rho well below 1/2, so 0 < lag < eps / 2).
    eps = 5 cm/s here: with 5 mm/s Newton stalls at the start on the friction's viscous slope mu f_n / eps, which
    outweighs the light rope's inertia at every step size (the fixed and held drums start, with rejections)."""
    m_h, m_l = 1.5, 1.0
    res, m_rope = rope_over("free", 0.5, m_h, m_l, eps=EPS_FREE)
    assert res.success, res.message
    t, v = np.asarray(res.t), -np.asarray(res.sensors["v"])[:, 2]
    keep = t >= 0.2
    a = float(np.polyfit(t[keep], v[keep], 1)[0])
    leg = ROPE.density * SEC.area * LEG
    J = INERTIA[1]
    ref = G * ((m_h + leg) - (m_l + leg)) / (m_h + m_l + m_rope + J / R**2)
    assert a == pytest.approx(ref, rel=4e-2)
    rim = R * np.asarray(res.sensors["p"])[keep, 4]  # omega_y R: the top of the drum moves +x, the right leg down
    assert 0 < np.mean(v[keep] - rim) < EPS_FREE / 2
    (rep,) = contact.report(res.assembly, res.x)  # the drum's pose follows the body: the rope lies on it
    assert -2e-3 < rep["min_gap"] < 1e-3


def test_beam3d_strip_on_held_body_drum_matches_fixed_drum():
    """A beam3d strip (elastic-line forces) released 2 mm above a drum of axis y carried by a held spatial body,
    with friction, against the same strip over the fixed drum: the same motion to Newton's tolerance (1e-9 m over
    40 steps of 1 ms while it lands: the body's coordinates enter the beam3d kernels as the fixed geometry)."""
    out = []
    for drum in ("fixed", "held"):
        sc = Scene(dim=3, gravity=(0.0, 0.0, -G))
        sc.member("strip", [(-0.3, 0.0, 0.0), (0.3, 0.0, 0.0)], 6, Material(E=2e9, density=1000.0),
                  Section.rectangle(0.02, 0.004), element="beam3d", beam_method="elastic_line")
        law = dict(stiffness=1e5, damping=1e2, mu=0.3, eps=1e-2)
        centre = (0.05, 0.0, -0.2 - 0.002 - 0.002)
        if drum == "fixed":
            sc.contact_drum("strip", centre, 0.2, axis=(0, 1, 0), **law)
        else:
            sc.body("wheel", 3.0, (0.05, 0.06, 0.05), position=(0.05, 0.1, -0.204), axes=AXES.tolist())
            sc.revolute("wheel", point=centre, axis=(0, 1, 0))
            sc.drive("wheel", angle=0.0)
            sc.contact_drum("strip", centre, 0.2, axis=(0, 1, 0), body="wheel", **law)
        res = simulate(sc, DynamicOptions(dt=1e-3, t_end=0.04, output_dt=2e-3,
                                          newton={"single": False, "lte_fraction": 0.0},
                                          sensors=[Sensor("tip", "position", "strip", "end")]))
        assert res.success, res.message
        out.append(np.asarray(res.sensors["tip"]))
    assert out[0][-1, 2] < -2e-3  # it fell onto the drum (free fall over 40 ms: 7.8 mm)
    assert np.abs(out[1] - out[0]).max() < 1e-9


def test_spatial_body_drum_input_and_toml():
    """Scene.contact_drum(body=...) in 3D: centre and axis default to the body's centre and z axis; a missing body
    is refused; [[contacts]] type = "circle" with body and a centre builds the same contact."""
    s = Scene(dim=3)
    s.member("rope", [(0, 0, 0.2), (1, 0, 0.2)], 4, ROPE, SEC, bending=False)
    s.body("p", 1.0, (0.01, 0.01, 0.01), position=(0.5, 0.0, 0.0), axes=AXES.tolist())
    c = s.contact_drum("rope", radius=0.1, body="p", stiffness=1e5)
    assert np.allclose(c.centre, (0.5, 0, 0)) and np.allclose(c.axis, AXES[2])
    with pytest.raises(SceneError, match="body 'q' does not exist"):
        s.contact_drum("rope", radius=0.1, body="q", stiffness=1e5)
    with pytest.raises(SceneError, match="axis must be a non-zero vector"):
        s.contact_drum("rope", radius=0.1, body="p", axis=(0, 0, 0), stiffness=1e5)
    doc = {"scene": {"dim": 3}, "materials": {"m": {"E": 1e9, "density": 1000}},
           "sections": {"s": {"area": 1e-4, "I": 1e-9}},
           "members": [{"name": "c", "points": [[0, 0, 0.2], [1, 0, 0.2]], "elements": 2, "material": "m",
                        "section": "s"}],
           "bodies": [{"name": "p", "mass": 1, "inertia": [0.01, 0.01, 0.01], "position": [0.5, 0, 0],
                       "revolute": {"point": [0.5, 0, 0], "axis": [0, 1, 0]}}],
           "contacts": [{"type": "circle", "member": "c", "body": "p", "centre": [0.5, 0.1, 0], "axis": [0, 1, 0],
                         "radius": 0.1, "stiffness": 1e5, "mu": 0.3}],
           "analysis": {"type": "dynamics", "dt": 0.01, "t_end": 0.1}}
    scene, _ = scene_from_dict(doc)
    (c,) = scene.contacts
    assert c.body == "p" and np.allclose(c.centre, (0.5, 0.1, 0)) and np.allclose(c.axis, (0, 1, 0))
    assert ("cable3d", "contact_body_drum_friction") in registry.EFFECTS
