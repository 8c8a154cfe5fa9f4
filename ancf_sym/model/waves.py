"""Regular Airy (linear) waves in water of finite depth h: the dispersion relation and the water's velocity and
acceleration under them (NumPy). With amplitude a = H/2, omega = 2 pi / T, k from omega^2 = g k tanh(k h), the
phase theta = k x_d - omega t + phase (x_d the horizontal coordinate along the direction of travel) and z measured
up from the still water line:
    eta = a cos(theta),
    u_d = a omega cosh(k (z + h)) / sinh(k h) cos(theta),   w = a omega sinh(k (z + h)) / sinh(k h) sin(theta),
and the accelerations their time derivatives at a fixed point. Above the still water line the kinematics of z = 0
hold (constant stretching)."""
from __future__ import annotations

import math

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


def kinematics(water: Water, g: float, r: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(eta (P,), u (P, dim), a (P, dim)) at points r (P, dim) and time t: the surface elevation above each point,
    the water's velocity and acceleration."""
    wv = water.waves
    r = np.atleast_2d(np.asarray(r, float))
    dim = r.shape[1]
    h, a = water.depth, wv.height / 2
    om = 2 * math.pi / wv.period
    k = wave_number(om, h, g)
    beta = math.radians(wv.direction)
    e = np.array([math.cos(beta), math.sin(beta)]) if dim == 3 else np.array([math.cos(beta)])
    xd = r[:, :dim - 1] @ e
    z = np.minimum(r[:, -1] - water.surface, 0.0)
    th = k * xd - om * t + wv.phase
    ch, sh = np.cosh(k * (z + h)) / math.sinh(k * h), np.sinh(k * (z + h)) / math.sinh(k * h)
    ud, w = a * om * ch * np.cos(th), a * om * sh * np.sin(th)
    ad, aw = a * om * om * ch * np.sin(th), -a * om * om * sh * np.cos(th)
    u = np.zeros_like(r)
    acc = np.zeros_like(r)
    u[:, :dim - 1], acc[:, :dim - 1] = np.outer(ud, e), np.outer(ad, e)
    u[:, -1], acc[:, -1] = w, aw
    return a * np.cos(th), u, acc
