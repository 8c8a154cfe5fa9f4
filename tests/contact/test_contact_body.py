"""Drums carried by planar rigid bodies (contact between a member and a body, exact derivatives through the body's
coordinates x, y, cos, sin).

References: a held body (revolute + angle drive at 0) carries a drum that must act exactly as the fixed drum at its
centre; a rope over a free pulley with friction well above the stick limit is Atwood's machine with a massive
pulley, a = g (m_h - m_l) / (m_h + m_l + m_rope + J / R^2) (rope masses as in examples/capstan.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate
from ancf_sym.io.scene_toml import scene_from_dict

from helpers import same_motion_tol, step_history

G = 9.81
R, LEG, LM = 0.1, 0.6, 0.05
ROPE = Material(E=1e10, density=300.0)
SEC, MASS_SEC = Section.circle(0.003), Section.circle(0.02)


def _path(s):
    r, t = np.zeros((len(s), 2)), np.zeros((len(s), 2))
    arc = R * math.pi
    for k, sk in enumerate(s):
        if sk <= LEG + LM:
            r[k], t[k] = (-R, -(LEG + LM) + sk), (0.0, 1.0)
        elif sk <= LEG + LM + arc:
            a = math.pi - (sk - LEG - LM) / R
            r[k], t[k] = (R * math.cos(a), R * math.sin(a)), (math.sin(a), -math.cos(a))
        else:
            r[k], t[k] = (R, -(sk - LEG - LM - arc)), (0.0, -1.0)
    return r, t


def rope_over(drum: str, mu: float, m_h: float, m_l: float, pulley_mass: float = 2.0, t_end: float = 0.4,
              newton: dict | None = None):
    """The capstan set-up (rope wrapped over half a drum, end masses as short dense members) with the drum fixed
    ('fixed'), on a body held by an angle drive ('held') or on a body free to turn on a revolute joint ('free').
    Returns (result, rope mass, pulley inertia)."""
    L = 2 * LEG + R * math.pi
    sc = Scene(dim=2, gravity=(0.0, -G))
    for nm, a, b, m in (("mass_l", -LM, 0.0, m_l), ("rope", 0.0, L, None), ("mass_h", L, L + LM, m_h)):
        mat = ROPE if m is None else Material(E=ROPE.E, density=m / (LM * MASS_SEC.area))
        sc.member(nm, [(a, 0.0), (b, 0.0)], 20 if m is None else 2, mat, SEC if m is None else MASS_SEC,
                  bending=m is not None)
    sc.hinge(("mass_l", "end"), ("rope", "start"))
    sc.hinge(("rope", "end"), ("mass_h", "start"))
    law = dict(stiffness=1e6, mu=mu, eps=5e-3, damping=1e3)
    J = 0.5 * pulley_mass * R * R
    if drum == "fixed":
        sc.contact_drum("rope", (0.0, 0.0), R, **law)
    else:
        sc.body("pulley", pulley_mass, J, position=(0.0, 0.0))
        sc.revolute("pulley")
        if drum == "held":
            sc.drive("pulley", angle=0.0)
        sc.contact_drum("rope", radius=R, body="pulley", **law)
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
    return res, ROPE.density * SEC.area * L, J


def _acceleration(res, t0=0.2):
    t, v = np.asarray(res.t), -np.asarray(res.sensors["v"])[:, 1]
    keep = t >= t0
    return float(np.polyfit(t[keep], v[keep], 1)[0]), t[keep], v[keep]


def test_held_body_drum_acts_as_the_fixed_drum():
    """Sliding over a drum (mu = 0.1, ratio 2 > e^(0.1 pi)): a drum on a body held at angle 0 by a drive and the
    fixed drum at the same centre give the same motion: the body's coordinates enter the kernels exactly as the
    fixed centre (its spin is 0). Newton is run to its absolute update tolerance (1e-10 m) every step, so while the
    two differently structured systems (the held one has multipliers) take the same steps they agree to that
    level, 1e-8 m/s over the first 30 steps (the regularised friction's slope mu f_n / eps amplifies differences
    exponentially once the rope slides, so a longer comparison would measure that sensitivity, not the wiring).
    Which steps a run takes can hinge on round-off (helpers.same_motion_tol): then they agree to the time
    discretisation's error. A run is reproducible: the same scene again gives the same numbers, bit for bit."""
    tight = {"single": False, "lte_fraction": 0.0}
    fixed, _, _ = rope_over("fixed", 0.1, 2.0, 1.0, t_end=0.03, newton=tight)
    held, _, _ = rope_over("held", 0.1, 2.0, 1.0, t_end=0.03, newton=tight)
    assert fixed.success and held.success
    v = np.asarray(fixed.sensors["v"])
    assert np.abs(v).max() > 0.1  # the rope does move
    assert np.abs(np.asarray(held.sensors["v"]) - v).max() < same_motion_tol(fixed, held)
    assert np.abs(held.sensors["p"][:, 2]).max() < 1e-9  # the drive holds it
    again, _, _ = rope_over("held", 0.1, 2.0, 1.0, t_end=0.03, newton=tight)
    assert step_history(again) == step_history(held)
    assert np.array_equal(np.asarray(again.sensors["v"]), np.asarray(held.sensors["v"]))


def test_free_pulley_is_atwoods_machine():
    """mu = 0.5 (stick limit e^(pi/2) = 4.8 against a mass ratio of 1.5): the rope turns a free pulley (J = 0.01 kg
    m^2, J / R^2 = 1 kg) without slipping, so a = g (m_h' - m_l') / (m_h' + m_l' + m_rope + J / R^2) (m' = m + the
    leg's rope mass). Within 4 % as the capstan example (wrap resolved by cubic elements over 0.8 rad each, the
    residual axial oscillation in the fit); the pulley's rim speed omega R follows the masses' speed within 2 % on
    average over the window (creep of the regularised friction below eps = 5 mm/s against speeds of ~0.4 m/s; the
    rope legs' damped axial oscillation, ~1e-2 m/s, shows in the mass's speed and averages out)."""
    m_h, m_l = 1.5, 1.0
    res, m_rope, J = rope_over("free", 0.5, m_h, m_l)
    assert res.success, res.message
    a, t, v = _acceleration(res)
    leg = ROPE.density * SEC.area * LEG
    ref = G * ((m_h + leg) - (m_l + leg)) / (m_h + m_l + m_rope + J / R**2)
    assert a == pytest.approx(ref, rel=4e-2)
    rim = -R * np.asarray(res.sensors["p"])[np.asarray(res.t) >= 0.2, 3]  # (clockwise: the heavy side is right)
    assert abs(np.mean(rim - v)) < 0.02 * np.mean(v)  # (mean: the legs' axial oscillation shows in v, not in rim)


def test_body_drum_refusals_and_toml():
    s = Scene(dim=2)
    s.member("rope", [(0, 0.2), (1, 0.2)], 4, ROPE, SEC, bending=False)
    s.body("p", 1.0, 0.01, position=(0.5, 0.0))
    with pytest.raises(SceneError, match="leave centre out"):
        s.contact_drum("rope", (0.5, 0.0), 0.1, body="p", stiffness=1e5)
    with pytest.raises(SceneError, match="body 'q' does not exist"):
        s.contact_drum("rope", radius=0.1, body="q", stiffness=1e5)
    with pytest.raises(SceneError, match="centre: missing"):
        s.contact_drum("rope", radius=0.1, stiffness=1e5)
    doc = {"scene": {"dim": 2}, "materials": {"m": {"E": 1e9, "density": 1000}},
           "sections": {"s": {"area": 1e-4, "I": 1e-9}},
           "members": [{"name": "c", "points": [[0, 0.2], [1, 0.2]], "elements": 2, "material": "m", "section": "s"}],
           "bodies": [{"name": "p", "mass": 1, "inertia": 0.01, "position": [0.5, 0], "revolute": [0.5, 0]}],
           "contacts": [{"type": "circle", "member": "c", "body": "p", "radius": 0.1, "stiffness": 1e5, "mu": 0.3}],
           "analysis": {"type": "dynamics", "dt": 0.01, "t_end": 0.1}}
    scene, _ = scene_from_dict(doc)
    assert scene.contacts[0].body == "p"
