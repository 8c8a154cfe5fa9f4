"""Cubic Hermite functions of xi = x/L in [0, 1] and their xi-derivatives (without the L factors), and the weights
of an element's nodal coordinates r(0), r_x(0), r(L), r_x(L) at a material point (the cable's shape functions; for
beam3d the centre-line part of them). Plain arithmetic: the symbolic elements and the run-time interpolation share it."""
from __future__ import annotations

import numpy as np


def h(xi):
    """[h1, h2, h3, h4]: r(x) = h1 r(0) + L h2 r_x(0) + h3 r(L) + L h4 r_x(L)."""
    return [1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -(xi**2) + xi**3]


def dh(xi):
    return [-6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2, 6 * xi - 6 * xi**2, -2 * xi + 3 * xi**2]


def ddh(xi):
    return [-6 + 12 * xi, -4 + 6 * xi, 6 - 12 * xi, -2 + 6 * xi]


def weights(xi, L) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(w, wx, wxx), each (4,) + the broadcast shape of xi and L: r = sum_k w_k c_k, r_x = sum_k wx_k c_k,
    r_xx = sum_k wxx_k c_k with c = (r(0), r_x(0), r(L), r_x(L)) of an element of length L at xi = x / L."""
    h0, h1, h2 = h(xi), dh(xi), ddh(xi)
    parts = ((h0[0], L * h0[1], h0[2], L * h0[3]), (h1[0] / L, h1[1], h1[2] / L, h1[3]),
             (h2[0] / L**2, h2[1] / L, h2[2] / L**2, h2[3] / L))
    if np.ndim(xi) == 0 and np.ndim(L) == 0:  # one point (probes, output-time interpolation): no broadcasting work
        return tuple(np.array(p, dtype=float) for p in parts)
    return tuple(np.stack(np.broadcast_arrays(*p)) for p in parts)
