"""Lines in water under regular Airy waves, in the dynamics: the Morison force against the formula evaluated by hand,
its exact tangents, the Wheeler stretching, the convergence of a wave-loaded line's response in dt, and the energy
balance with the waves' work booked."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.model.assembly import Assembly
from ancf_sym.system.step_system import StepSystem

RHO_W, G, DEPTH = 1025.0, 9.81, 40.0
WAVES = {"height": 3.0, "period": 7.0, "direction": 30.0, "phase": 0.4}
COEF = {"cd": 1.2, "cd_axial": 0.3, "ca": 1.0, "ca_axial": 0.4}
D = 0.3


def _airy(p: np.ndarray, t: float, stretching: str) -> tuple[np.ndarray, np.ndarray]:
    """The textbook Airy velocity and acceleration at points p (P, 3) (z up from the still water line 0), with
    Wheeler's stretching z' = h (z + h) / (h + eta) - h or none, and the surface's values above it (cosh / sinh
    written out: a code path of its own)."""
    H, T, beta, ph = WAVES["height"] / 2, WAVES["period"], math.radians(WAVES["direction"]), WAVES["phase"]
    om, h = 2 * math.pi / T, DEPTH
    k = om * om / G
    for _ in range(60):  # fixed point of k tanh(k h) = om^2 / g (contracts: the map's slope is below 1 here)
        k = om * om / (G * math.tanh(k * h))
    e = np.array([math.cos(beta), math.sin(beta), 0.0])
    th = k * (p[:, 0] * e[0] + p[:, 1] * e[1]) - om * t + ph
    eta = H * np.cos(th)
    z = p[:, 2]
    if stretching == "wheeler":
        z = h * (z + h) / (h + eta) - h
    z = np.minimum(z, 0.0)
    C, S = np.cosh(k * (z + h)) / math.sinh(k * h), np.sinh(k * (z + h)) / math.sinh(k * h)
    u = np.outer(H * om * C * np.cos(th), e) + np.outer(H * om * S * np.sin(th), [0, 0, 1])
    a = np.outer(H * om * om * C * np.sin(th), e) + np.outer(-H * om * om * S * np.cos(th), [0, 0, 1])
    return u, a


def _morison(p, tang, v, t, current, stretching, buoyancy=True) -> np.ndarray:
    """Force per unit length [N/m] at points p with unit tangents tang, the line moving at v (rigidly); a member
    without buoyancy displaces no water: no Froude-Krylov part, the added mass alone."""
    u, acc = _airy(p, t, stretching)
    ur = u + current - v
    area = math.pi * D * D / 4
    out = []
    for i in range(len(p)):
        tt = tang[i]
        ut = (ur[i] @ tt) * tt
        un = ur[i] - ut
        at = (acc[i] @ tt) * tt
        an = acc[i] - at
        sn = math.sqrt(un @ un + 1e-8)  # the package's |u| = sqrt(u.u + eps^2), eps = 1e-4 m/s (docs/water.md)
        st = math.sqrt((ur[i] @ tt) ** 2 + 1e-8)
        out.append(0.5 * RHO_W * COEF["cd"] * D * sn * un + 0.5 * RHO_W * COEF["cd_axial"] * math.pi * D * st * ut
                   + RHO_W * area * ((buoyancy + COEF["ca"]) * an + (buoyancy + COEF["ca_axial"]) * at))
    return np.array(out)


def _system(a, b, n: int, stretching: str, current=None, buoyancy=True):
    s = Scene(dim=3, gravity=[0.0, 0.0, -G])
    s.member("c", [a, b], n, Material(E=2e11, density=7800.0), Section.circle(D), axial="biot", bending=False)
    s.set_water(density=RHO_W, depth=DEPTH, current=current, waves=dict(WAVES, stretching=stretching),
                lines={"c": dict(COEF, buoyancy=buoyancy)})
    asm = Assembly(s)
    asm.added_mass_state = asm.x0
    return StepSystem.for_scene(asm), asm


@pytest.mark.parametrize("case", ["vertical", "inclined", "no_buoyancy"])
@pytest.mark.parametrize("stretching", ["wheeler", "none"])
def test_force_matches_morison_by_hand(case, stretching):
    """A straight cylinder line in waves (and a current), moving rigidly at v: the step system's water force on
    the coordinates against Q = integral of S(s)' f(s) ds of the Morison force per unit length evaluated by hand
    from the Airy formulas (drag on u_wave + u_current - v split along the tangent, (1 + Ca) rho A a_n +
    (1 + CaAx) rho A a_t). The package integrates with 5 Gauss points per element (exact to degree 9), the hand
    side with 12: elements of 1.4 - 2.6 m against a wave length of ~76 m (k L < 0.25) and the smooth drag leave ~(k L)^10 / 10! of
    quadrature difference, so the two agree to round-off; asserted at 1e-9 of the largest entry."""
    from ancf_sym.elements.hermite import weights
    from ancf_sym.elements.quadrature import gauss01

    if case == "vertical":
        a, b, current = np.array([3.0, -2.0, -12.0]), np.array([3.0, -2.0, -0.5]), None
    else:
        a, b, current = np.array([-4.0, 1.0, -20.0]), np.array([6.0, 5.0, -2.0]), [0.6, -0.3, 0.0]
    n, buoyancy = 8, case != "no_buoyancy"
    S, asm = _system(a, b, n, stretching, current, buoyancy)
    v = np.array([0.3, -0.5, 0.2])
    V = np.zeros(asm.n)
    for k in range(n + 1):  # a rigid translation: every node's r moves at v, the slopes stay
        V[6 * k:6 * k + 3] = v
    t = 2.3
    f = S.damping_force(asm.x0, V, t)  # = -Q_water (the water line is 0 under water): no supports, E = I
    assert S.nf == asm.n
    Lt = np.linalg.norm(b - a)
    tang = (b - a) / Lt
    Le = Lt / n
    xi, wq = gauss01(12)
    Q = np.zeros(asm.n)
    cur = np.zeros(3) if current is None else np.asarray(current, float)
    for e in range(n):
        s_ = (e + xi) * Le
        p = a[None, :] + np.outer(s_, tang)
        fl = _morison(p, np.repeat(tang[None, :], len(xi), 0), v, t, cur, stretching, buoyancy)
        w, _, _ = weights(xi, Le)  # (4, G): r = w0 r_a + w1 r_a' + w2 r_b + w3 r_b'
        for j, off in enumerate((0, 3, 6, 9)):
            Q[6 * e + off:6 * e + off + 3] += (w[j] * wq * Le) @ fl
    assert np.max(np.abs(-f - Q)) <= 1e-9 * np.max(np.abs(Q)), np.max(np.abs(-f - Q)) / np.max(np.abs(Q))
    # the resultant: the shape functions of the positions sum to 1, so the position rows sum to the integral of f
    total = sum(Q[6 * k:6 * k + 3] for k in range(n + 1))
    assert np.linalg.norm(total) > 1e3  # (a load that matters: kN on a 12-20 m line)


def test_tangents_are_exact():
    """df/dq and df/dv of the water forces under waves (the step matrix's water part) against central differences
    of the force (step 1e-6 m, 1e-6 m/s: truncation ~1e-12 relative, round-off ~1e-10): to 1e-6 of the largest
    entry. A tangent that missed the waves' dependence on the position (d u_wave / d r, d a_wave / d r: the
    kinematics change by k ~ 0.08 of themselves per metre) would be off by far more."""
    S, asm = _system(np.array([-4.0, 1.0, -20.0]), np.array([6.0, 5.0, -2.0]), 4, "wheeler", [0.6, -0.3, 0.0])
    rng = np.random.default_rng(3)
    x = asm.x0 + 0.05 * rng.standard_normal(asm.n)
    v = 0.4 * rng.standard_normal(asm.n)
    t = 1.1
    f, dfx, dfv = (np.asarray(o.full() if hasattr(o, "full") else o) for o in S.damp_f(x, v, t))
    for J, which in ((dfx, 0), (dfv, 1)):
        num = np.zeros_like(J)
        for j in range(asm.n):
            d = np.zeros(asm.n)
            d[j] = 1e-6
            args_p, args_m = [x, v], [x, v]
            args_p[which], args_m[which] = args_p[which] + d, args_m[which] - d
            num[:, j] = (S.damping_force(*args_p, t) - S.damping_force(*args_m, t)) / 2e-6
        assert np.max(np.abs(J - num)) <= 1e-6 * np.max(np.abs(J)), np.max(np.abs(J - num)) / np.max(np.abs(J))


def test_wheeler_stretching():
    """Wheeler's stretching maps [-h, eta] onto [-h, 0]: at the crest's surface the still-water surface's
    kinematics, at the seabed no change, above the surface the surface's; without stretching the still water
    line's kinematics hold above z = 0."""
    from ancf_sym.model.waves import kinematics

    s = Scene(dim=3, gravity=[0.0, 0.0, -G])
    s.member("c", [(0, 0, -10), (1, 0, -10)], 1, Material(E=1e9, density=2000.0), Section.circle(0.05))
    w = s.set_water(depth=DEPTH, waves=WAVES)
    t, p = 0.7, np.array([[2.0, 1.0, 0.0]])
    eta = kinematics(w, G, p, t)[0][0]
    at_eta = kinematics(w, G, p + [0, 0, eta], t)
    above = kinematics(w, G, p + [0, 0, eta + 0.5], t)
    u_n, a_n = _airy(p, t, "none")
    assert np.allclose(at_eta[1], u_n, rtol=1e-12) and np.allclose(at_eta[2], a_n, rtol=1e-12)
    assert np.allclose(above[1], at_eta[1], rtol=1e-12)
    bottom = p + [0, 0, -DEPTH]
    assert np.allclose(kinematics(w, G, bottom, t)[1], _airy(bottom, t, "none")[0], atol=1e-14)
    with pytest.raises(SceneError, match=r"water\.waves\.stretching"):
        Scene(dim=2, gravity=[0, -G]).set_water(depth=10.0, waves={"height": 1, "period": 5, "stretching": "x"})


def _riser(n: int, coef: dict = COEF) -> Scene:
    """A slack steel riser in 40 m of water, 60 m long, from the seabed (pinned) to a pinned top 5 m under the
    still water line, 30 m away: a catenary the waves push about (D 0.3 m)."""
    s = Scene(dim=2, gravity=[0.0, -G])
    s.member("r", [(0.0, -DEPTH + 1), (60.0, -DEPTH + 1)], n, Material(E=2e8, density=1500.0), Section.circle(D),
             axial="biot", bending=False)
    s.pin("r", "start")
    s.drive_position([30.0, -5.0], member="r", at="end", name="top")
    s.set_water(density=RHO_W, depth=DEPTH, waves={"height": 4.0, "period": 8.0}, lines={"r": coef})
    return s


def _static_riser(n: int):
    from ancf_sym import solve_static

    r = solve_static(_riser(n))  # (the statics take no waves: the riser at rest in still water)
    assert r.success, r.summary()
    return r


def _wave_run(n, dt, q0, T, coef: dict = COEF, **kw):
    r = simulate(_riser(n, coef), DynamicOptions(dt=dt, t_end=T, q0=q0, output_dt=T / 4, **kw))
    assert r.success, r.message
    return r


def test_wave_response_converges_in_dt():
    """The riser's response over the first wave period from its static state: the nodes' positions at the end
    against a run at dt / 8 of the finest. Generalized-alpha is second order: the error falls ~4x per halving of dt
    (asserted >= 3x; measured 4.5x and 4.1x). rho_inf = 0.5 damps the axial vibration the waves' sudden onset
    excites (periods ~0.05 s, far below the steps), whose phase at coarse steps otherwise scatters the ratios
    (measured 2-6x at rho_inf = 0.9). The waves move the riser by ~1 m: far above the errors (< 1 mm)."""
    n, T = 8, 8.0
    st = _static_riser(n)
    pos = np.r_[np.arange(0, st.x.size, 4), np.arange(1, st.x.size, 4)]  # the nodes' x and z (not the slopes)
    ref = _wave_run(n, 0.003125, st.x, T, rho_inf=0.5)
    errs = [float(np.max(np.abs(_wave_run(n, dt, st.x, T, rho_inf=0.5).x - ref.x)[pos])) for dt in (0.1, 0.05, 0.025)]
    moved = float(np.max(np.abs(ref.x - st.x)[pos]))
    assert errs[0] > 3 * errs[1] > 3 * 3 * errs[2], errs
    assert moved > 0.5 and errs[-1] < 1e-3 * moved, (moved, errs)


def test_energy_balance_books_the_waves_work():
    """Trapezoidal Newmark conserves E + damping_work - external_work to O(dt^2) (the energy identity is exact
    for a quadratic potential): the waves feed the riser (damping_work < 0 by ~600 J in 3 s), and what the balance
    leaves (`algorithmic`) is a small fraction of it that falls ~4x per halving of dt (asserted >= 2.8x; measured
    0.060 J and 0.011 J). A run that did not book the waves' work would leave all of it. Isotropic added mass
    (ca = ca_axial): the part of the added mass that turns with the line has no kinetic energy of its own in the
    balance (with ca_axial 0.4 the balance keeps a 0.2 J floor here)."""
    n, T = 10, 3.0
    st = _static_riser(n)
    coef = dict(COEF, ca_axial=COEF["ca"])
    alg, work = [], []
    for dt in (0.05, 0.025):
        E = _wave_run(n, dt, st.x, T, coef, integrator="newmark").energies
        alg.append(float(np.max(np.abs(E["algorithmic"]))))
        work.append(float(np.max(np.abs(E["damping_work"]))))
    assert work[-1] > 100.0, work
    assert alg[-1] < 1e-3 * work[-1], (alg, work)
    assert alg[0] > 2.8 * alg[1], alg
