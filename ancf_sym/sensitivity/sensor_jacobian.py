"""The exact Jacobians of a sensor's record y(x, v) in the full coordinates and velocities, for every sensor kind:
the linear kinds map as they map x, v; strain, curvature and the body sensors by the chain rule."""
from __future__ import annotations

import numpy as np

from ancf_sym.dynamics.sensors import SensorEval


def _probe_map(ev: SensorEval, w: np.ndarray, n: int) -> np.ndarray:
    """The (dim, n) matrix of x -> x[idx] @ w (r, r_x or r_xx of the sensor's point)."""
    out = np.zeros((ev.probe.dim, n))
    for k in range(ev.probe.dim):
        np.add.at(out[k], ev.probe.idx[k], w)
    return out


def _skew(a: np.ndarray) -> np.ndarray:
    """skew(a) b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _body(ev: SensorEval, x: np.ndarray, v: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    o = ev.offset
    if ev.spatial:  # centre (3), omega = 1/2 sum_k e_k x e_k' (3), axes (9)
        Jx, Jv = np.zeros((15, n)), np.zeros((15, n))
        Jx[np.arange(3), o + np.arange(3)] = 1.0
        Jx[np.arange(6, 15), o + 3 + np.arange(9)] = 1.0
        E, Ed = x[o + 3:o + 12].reshape(3, 3), v[o + 3:o + 12].reshape(3, 3)
        for k in range(3):  # d(e x e') = -skew(e') de + skew(e) de'
            Jx[3:6, o + 3 + 3 * k:o + 6 + 3 * k] = -0.5 * _skew(Ed[k])
            Jv[3:6, o + 3 + 3 * k:o + 6 + 3 * k] = 0.5 * _skew(E[k])
        return Jx, Jv
    Jx, Jv = np.zeros((4, n)), np.zeros((4, n))  # (x, y, atan2(s, c), c s' - s c')
    Jx[0, o], Jx[1, o + 1] = 1.0, 1.0
    c, s = x[o + 2], x[o + 3]
    r2 = c * c + s * s
    Jx[2, o + 2], Jx[2, o + 3] = -s / r2, c / r2
    Jx[3, o + 2], Jx[3, o + 3] = v[o + 3], -v[o + 2]
    Jv[3, o + 3], Jv[3, o + 2] = c, -s
    return Jx, Jv


def sensor_jacobian(ev: SensorEval, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dy/dx, dy/dv), each (k, n), of the sensor's record at the full state (x, v)."""
    n, kind = x.size, ev.sensor.kind
    if kind == "body":
        return _body(ev, x, v, n)
    if kind == "coordinates":
        Jx = np.zeros((len(ev.dofs), n))
        Jx[np.arange(len(ev.dofs)), ev.dofs] = 1.0
        return Jx, np.zeros_like(Jx)
    p = ev.probe
    if kind in ("position", "displacement"):
        R = _probe_map(ev, p.w, n)
        return R, np.zeros_like(R)
    if kind == "velocity":
        R = _probe_map(ev, p.w, n)
        return np.zeros_like(R), R
    Rx = _probe_map(ev, p.wx, n)
    rx = p.rx(x)
    nrm = float(np.linalg.norm(rx))
    if kind == "strain":  # |r_x| - 1
        Jx = (rx / nrm)[None, :] @ Rx
        return Jx, np.zeros_like(Jx)
    if kind != "curvature":
        raise ValueError(f"sensor {ev.sensor.name!r}: unknown kind {kind!r}")
    Rxx = _probe_map(ev, p.wxx, n)
    rxx = p.rxx(x)
    if p.dim == 2:  # c = |r_x0 r_xx1 - r_x1 r_xx0|
        cr = float(rx[0] * rxx[1] - rx[1] * rxx[0])
        c = abs(cr)
        dc = np.sign(cr) * (np.array([rxx[1], -rxx[0]]) @ Rx + np.array([-rx[1], rx[0]]) @ Rxx)
    else:  # c = |w|, w = r_x x r_xx: dc = (dr_x . (r_xx x w) + dr_xx . (w x r_x)) / c
        w = np.cross(rx, rxx)
        c = float(np.linalg.norm(w))
        dc = (np.cross(rxx, w) @ Rx + np.cross(w, rx) @ Rxx) / max(c, 1e-300)
    Jx = (dc / nrm ** 3 - 3.0 * c / nrm ** 5 * (rx @ Rx))[None, :]  # kappa = c / |r_x|^3
    return Jx, np.zeros_like(Jx)
