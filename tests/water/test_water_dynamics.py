"""Lines in water, dynamics: Morison drag and added mass in the step system, against the closed form of a straight
cable sinking through still water.

A straight cable (net weight w per length) sinking broadside (normal) or end-on (tangential) keeps its shape; its
speed obeys m_eff dv/dt = w - k v^2 with m_eff = rho A + rho_w A Ca (Ca the normal or tangential added-mass
coefficient) and k = 1/2 rho_w Cd d (normal) or 1/2 rho_w CdAx pi d (tangential), so
v(t) = v_t tanh(w t / (m_eff v_t)), v_t = sqrt(w / k). The generalized-alpha scheme is second order: the error at
a fixed time falls about 4x per halving of the step (asserted >= 2.5x: the first step's start-up error is first
order in some schemes' variants), and at the finest step it is far below the difference a missing added mass
(24 % of m_eff) or a wrong drag law would make (measured 1.3e-5 m/s of 0.87 m/s)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import DynamicOptions, simulate

RHO_W, D, W, G = 1025.0, 0.02, 10.0, 9.81


def _speed_error(direction: str, dt: float, T: float = 0.3) -> float:
    sec = Section.circle(D)
    rho_a = W / G + RHO_W * sec.area
    if direction == "normal":
        pts, coef, ca_, k = [(0.0, -10.0), (10.0, -10.0)], {"cd": 1.2, "ca": 1.0}, 1.0, 0.5 * RHO_W * 1.2 * D
    else:
        pts, coef, ca_, k = [(0.0, -5.0), (0.0, -15.0)], {"cd_axial": 0.8, "ca_axial": 0.5, "cd": 1.2, "ca": 1.0}, \
            0.5, 0.5 * RHO_W * 0.8 * math.pi * D
    s = Scene(dim=2, gravity=[0.0, -G])
    s.member("c", pts, 4, Material(E=1e10, density=rho_a / sec.area), sec, axial="biot", bending=False)
    s.set_water(density=RHO_W, lines={"c": coef})
    r = simulate(s, DynamicOptions(dt=dt, t_end=T))
    assert r.success, r.message
    m_eff = rho_a + RHO_W * sec.area * ca_
    vt = math.sqrt(W / k)
    v_ref = -vt * math.tanh(W * T / (m_eff * vt))
    return abs(r.v[2 * 4 + 1] - v_ref)  # the middle node's vertical velocity


@pytest.mark.parametrize("direction", ["normal", "tangential"])
def test_sinking_cable_converges_to_the_closed_form(direction):
    e = [_speed_error(direction, dt) for dt in (0.02, 0.01, 0.005)]
    assert e[0] > 2.5 * e[1] > 2.5 * 2.5 * e[2], e
    assert e[2] < 1e-3  # of ~0.87 m/s; a missing added mass is ~0.02 m/s off at t = 0.3 s (normal case)


def test_added_mass_turns_with_the_line():
    """A straight line spun about a pin in water (no gravity, no drag): its material points move on circles, their
    acceleration is along the line, so the normal added mass (Ca) resists no acceleration and the rotation keeps its
    speed; after a quarter turn the tip is at (0, L). An added mass frozen at the start's tangents would hold the
    line's x-direction with the normal coefficient after the turn (measured: 17 % faster, the tip 1.3 m off); the
    exact one keeps the speed to the axial vibration the start excites (measured 2e-4) and the tip within 5 mm."""
    L, om = 10.0, 1.0
    s = Scene(dim=2, gravity=[0.0, 0.0])
    s.member("c", [(0.0, 0.0), (L, 0.0)], 8, Material(E=1e9, density=2000.0), Section.circle(0.05), axial="biot",
             bending=False)
    s.drive_position([0.0, 0.0], member="c", at="start", name="pin")
    s.set_water(density=RHO_W, surface=100.0, lines={"c": {"ca": 1.0, "ca_axial": 0.2}})
    r = simulate(s, DynamicOptions(dt=0.01, t_end=math.pi / 2 / om,
                                   initial=[{"member": "c", "omega": om, "centre": [0.0, 0.0]}]))
    assert r.success, r.message
    tip, v_tip = r.x[8 * 4:8 * 4 + 2], r.v[8 * 4:8 * 4 + 2]
    assert np.linalg.norm(tip - [0.0, L]) < 0.01
    assert abs(np.linalg.norm(v_tip) / (om * L) - 1) < 2e-3


def test_airy_waves():
    """The dispersion relation and the kinematics of linear waves: deep and shallow limits of k, the kinematic
    surface condition w(z = 0) = d eta / dt, continuity du/dx + dw/dz = 0 (central differences of the closed form,
    step 1e-4 m: truncation ~1e-9 of the terms), the acceleration as the velocity's time derivative."""
    from ancf_sym.water import Waves, set_water
    from ancf_sym.model.waves import kinematics, wave_number

    g = 9.81
    assert wave_number(2 * math.pi / 5, 1e4, g) == pytest.approx((2 * math.pi / 5) ** 2 / g, rel=1e-12)
    assert wave_number(0.01, 10.0, g) == pytest.approx(0.01 / math.sqrt(g * 10.0), rel=1e-4)
    om, h = 2 * math.pi / 10, 50.0
    k = wave_number(om, h, g)
    assert om ** 2 == pytest.approx(g * k * math.tanh(k * h), rel=1e-13)
    s = Scene(dim=2, gravity=[0.0, -g])
    s.member("c", [(0.0, -10.0), (10.0, -10.0)], 2, Material(E=1e9, density=2000.0), Section.circle(0.05))
    w = set_water(s, depth=h, waves={"height": 2.0, "period": 10.0, "phase": 0.3, "stretching": "none"})
    assert isinstance(w.waves, Waves)
    t, d = 1.7, 1e-4
    eta0, u0, a0 = kinematics(w, g, [[3.0, 0.0]], t)
    eta_t = (kinematics(w, g, [[3.0, 0.0]], t + d)[0] - kinematics(w, g, [[3.0, 0.0]], t - d)[0]) / (2 * d)
    assert u0[0, 1] == pytest.approx(eta_t[0], rel=1e-6)
    p = np.array([[3.0, -7.0]])
    du_dx = (kinematics(w, g, p + [d, 0], t)[1][0, 0] - kinematics(w, g, p - [d, 0], t)[1][0, 0]) / (2 * d)
    dw_dz = (kinematics(w, g, p + [0, d], t)[1][0, 1] - kinematics(w, g, p - [0, d], t)[1][0, 1]) / (2 * d)
    assert abs(du_dx + dw_dz) < 1e-7 * abs(du_dx)
    du_dt = (kinematics(w, g, p, t + d)[1] - kinematics(w, g, p, t - d)[1]) / (2 * d)
    assert np.allclose(kinematics(w, g, p, t)[2], du_dt, rtol=1e-6, atol=1e-12)
    with pytest.raises(SceneError, match=r"water\.waves"):  # the collocation stages have no time input
        simulate(s, DynamicOptions(dt=0.01, t_end=0.02, integrator="radau"))
