"""Ground contact with damping and friction in the dynamics step graphs (every integrator) and in statics.

Rope: 1 m, round section 10 mm (half thickness 5 mm), E = 2 GPa, rho = 1000 kg/m^3: weight W = rho A g L = 0.7705 N.
Linear penalty k = 1e4 N/m^2: static penetration W / (k L) = 7.7e-5 m.

- Dropped from 5 cm with contact damping c delta (n.w) (c = 3e4): at rest after 2 s, the normal force equals the
  weight and the penetration W / (k L) (both to 1e-3: the residual velocity is < 1e-6 m/s, the force balance is then
  exact up to the inertia of that motion); Newton needs < 1.5 iterations per step on average and no step is
  rejected (no chattering); the energy balance closes: E(0) = E(t) + damping work (contact damping counted) up to
  the schemes' algorithmic dissipation at the impacts (< 5 % of E(0) for rho_inf = 0.9 / HHT -0.05;
  trapezoidal Newmark conserves energy only for linear forces: the contact law is not, < 5 % as well).
- Sliding on the ground at 1 m/s with friction mu = 0.3 (regularised with eps = 1e-3 m/s): Coulomb deceleration mu g
  until it stops, so v(0.2 s) = 1 - 0.3 g 0.2 = 0.4114 m/s (1e-2 relative: the penetration oscillation at touch
  changes f_n by a fraction of a percent); the friction work books the lost kinetic energy (algorithmic < 1e-3 E).
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import contact
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.system.step_system import StepSystem
from ancf_sym.scene import Material, Scene, Section

G, K, RHO, D = 9.81, 1e4, 1000.0, 0.01
W = RHO * np.pi * (D / 2) ** 2 * G * 1.0


def _rope(y0: float, **contact_options):
    sc = Scene(dim=2, gravity=[0, -G])
    sc.member("rope", [[0, y0], [1.0, y0]], 20, Material(E=2e9, density=RHO), Section.circle(D))
    sc.contact_ground("rope", stiffness=K, **contact_options)
    return sc


@pytest.mark.parametrize("integrator", ["newmark", "hht", "generalized_alpha", "radau", "gauss"])
def test_dropped_rope_comes_to_rest_on_the_ground(integrator):
    asm = Assembly(_rope(0.05, damping=3e4, mu=0.3, eps=1e-2))
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=2.0, integrator=integrator))
    assert res.success, res.message
    assert np.abs(res.v).max() < 1e-6
    rep = contact.report(asm, res.x)[0]
    assert rep["normal_force"] == pytest.approx(W, rel=1e-3)
    assert -rep["min_gap"] == pytest.approx(W / K, rel=1e-3)
    assert res.counters["newton_iterations"] < 1.5 * res.steps and not res.rejected
    en = res.energies
    E0 = en["total"][0]
    assert en["damping_work"][-1] > 0.5 * E0
    assert abs(en["algorithmic"][-1]) < 0.05 * E0


def test_sliding_rope_decelerates_at_mu_g():
    mu, v0 = 0.3, 1.0
    asm = Assembly(_rope(D / 2 - W / K, mu=mu, eps=1e-3))
    v = np.zeros(asm.n)
    v[0::4] = v0  # x-velocity of every node position (cable2d node: x, y, r_x, r_y)
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=0.2, integrator="generalized_alpha", v0=v))
    assert res.success, res.message
    assert np.mean(res.v[0::4]) == pytest.approx(v0 - mu * G * 0.2, rel=1e-2)
    en = res.energies
    assert abs(en["algorithmic"][-1]) < 1e-3 * en["kinetic"][0]
    assert en["damping_work"][-1] == pytest.approx(en["kinetic"][0] - en["kinetic"][-1], rel=2e-2)


def test_scene_without_contact_has_no_contact_terms():
    """Effects on demand: no contact declared, no contact kernel term and no dissipation call."""
    sc = Scene(dim=2, gravity=[0, -G])
    sc.member("rope", [[0, 0.05], [1.0, 0.05]], 20, Material(E=2e9, density=RHO), Section.circle(D))
    asm = Assembly(sc)
    assert not [t for t in asm.terms if t.label == contact.LABEL]
    assert contact.dissipation_calls(asm.mesh) == []
    S = StepSystem(asm)
    assert S.damp_f is None and S.linsol == "ldl"  # the step graph of a scene without contact is unchanged


def test_friction_coefficient_is_not_shared_between_cached_graphs():
    """Step graphs are cached by structure; the friction parameters are baked into the dissipation graph, so two
    scenes that differ only in mu must not share it: each decelerates at its own mu g (1e-2, as above)."""
    for mu in (0.3, 0.1):
        asm = Assembly(_rope(D / 2 - W / K, mu=mu, eps=1e-3))
        v = np.zeros(asm.n)
        v[0::4] = 1.0
        res = simulate(asm, DynamicOptions(dt=1e-3, t_end=0.2, integrator="generalized_alpha", v0=v))
        assert np.mean(res.v[0::4]) == pytest.approx(1.0 - mu * G * 0.2, rel=1e-2)
