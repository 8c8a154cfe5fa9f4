"""Regular Airy (linear) waves in water of finite depth h: the dispersion relation and the water's velocity and
acceleration under them. With amplitude a = H/2, omega = 2 pi / T, k from omega^2 = g k tanh(k h), the phase
theta = k x_d - omega t + phase (x_d the horizontal coordinate along the direction of travel) and z measured up from
the still water line:
    eta = a cos(theta),
    u_d = a omega C(z) cos(theta),   w = a omega S(z) sin(theta),
    a_d = a omega^2 C(z) sin(theta), a_w = -a omega^2 S(z) cos(theta),
C(z) = cosh(k (z + h)) / sinh(k h), S(z) = sinh(k (z + h)) / sinh(k h) (written with exponentials of k z <= 0 and
-k (z + 2 h) < 0: no overflow in deep water).

Stretching (Waves.stretching), how the kinematics reach the moving surface:
- "wheeler" (MoorDyn's convention, its wave grids and spectra): the water column [-h, eta] is mapped onto
  [-h, 0], z_s = h (z + h) / (h + eta) - h, and the formulas above are evaluated at z_s (the acceleration too: the
  local acceleration of the stretched field, as MoorDyn does); at the seabed nothing changes, at the crest the
  still-water surface's kinematics;
- "none": the formulas at the point's own z.
Either way a point above the surface (z_s > 0) takes the surface's kinematics (z_s = 0), as MoorDyn does.

One formula (`kinematics_mx`, any CasADi type): the step graph's water forces take it with exact derivatives with
respect to the position and time, and `kinematics` evaluates it on NumPy arrays."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ancf_sym.scene.water import Water


def wave_number(omega: float, depth: float, g: float) -> float:
    """k [1/m] of omega^2 = g k tanh(k h), by Newton from the deep-water value (the function is increasing and
    concave in k: Newton from above converges monotonically)."""
    k = max(omega * omega / g, omega / math.sqrt(g * depth))
    for _ in range(100):
        th = math.tanh(k * depth)
        f = g * k * th - omega * omega
        df = g * th + g * k * depth * (1 - th * th)
        step = f / df
        k -= step
        if abs(step) <= 1e-15 * k:
            break
    return k


def kinematics_mx(water: Water, g: float, r: list, t, k=None) -> tuple:
    """(eta, u, a) at points r (a list of dim coordinate columns, CasADi SX or MX) and time t (a scalar of the same
    type): the surface elevation above each point, the water's velocity and acceleration (lists of dim columns).
    k: the wave number, if given (an expression of a parameter, ancf_sym.sensitivity.water_derivative), else
    wave_number's."""
    wv = water.waves
    dim = len(r)
    h, amp = water.depth, wv.height / 2
    om = 2 * math.pi / wv.period
    k = wave_number(om, h, g) if k is None else k
    beta = math.radians(wv.direction)
    e = (math.cos(beta), math.sin(beta)) if dim == 3 else (math.cos(beta),)
    xd = sum(ei * ri for ei, ri in zip(e, r[:dim - 1]))
    th = k * xd - om * t + wv.phase
    c, s = ca.cos(th), ca.sin(th)
    eta = amp * c
    z = r[-1] - water.surface
    if wv.stretching == "wheeler":
        z = h * (z + h) / (h + eta) - h
    z = ca.fmin(z, 0.0)
    e1, e2, den = ca.exp(k * z), ca.exp(-k * (z + 2 * h)), 1.0 - (math.exp(-2 * k * h) if isinstance(k, float) else
                                                                  ca.exp(-2 * k * h))
    C, S = (e1 + e2) / den, (e1 - e2) / den  # cosh(k (z + h)) / sinh(k h), sinh(k (z + h)) / sinh(k h)
    ud, w = amp * om * C * c, amp * om * S * s
    ad, aw = amp * om * om * C * s, -amp * om * om * S * c
    u = [ei * ud for ei in e] + [w]
    a = [ei * ad for ei in e] + [aw]
    return eta, u, a


_EVALUATORS: dict = {}  # the mapped CasADi functions of `kinematics` by (waves, depth, surface, g, dim, points)


def kinematics(water: Water, g: float, r: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(eta (P,), u (P, dim), a (P, dim)) at points r (P, dim) and time t: `kinematics_mx` evaluated on arrays (its
    function built once per wave, water and number of points)."""
    r = np.atleast_2d(np.asarray(r, float))
    P, dim = r.shape
    key = (tuple(vars(water.waves).values()), water.depth, water.surface, g, dim, P)
    f = _EVALUATORS.get(key)
    if f is None:
        if len(_EVALUATORS) > 64:
            _EVALUATORS.clear()
        R, T = ca.SX.sym("r", dim), ca.SX.sym("t")
        eta, u, a = kinematics_mx(water, g, [R[i] for i in range(dim)], T)
        f = _EVALUATORS[key] = ca.Function("airy", [R, T], [ca.vertcat(eta, *u, *a)]).map(P)
    out = np.asarray(f(r.T, float(t))).T  # (P, 1 + 2 dim)
    return out[:, 0], out[:, 1:1 + dim], out[:, 1 + dim:]
