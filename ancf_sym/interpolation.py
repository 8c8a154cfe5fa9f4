"""Cubic Hermite interpolation along a member at run time: r, r_x and r_xx at a material point as fixed weights of
one element's nodal coordinates r(0), r_x(0), r(L), r_x(L) (the cable's shape functions; for beam3d the centreline
part of them). The polynomials come from elements.hermite, which is plain arithmetic (no CasADi)."""
from __future__ import annotations

import numpy as np

from typing import TYPE_CHECKING

from .elements import hermite

if TYPE_CHECKING:
    from .mesh import MemberMesh


def weights(xi, L) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(w, wx, wxx), each (4,) + the broadcast shape of xi and L: r = sum_k w_k c_k, r_x = sum_k wx_k c_k,
    r_xx = sum_k wxx_k c_k with c = (r(0), r_x(0), r(L), r_x(L)) of an element of length L at xi = x / L."""
    h, dh, ddh = hermite.h(xi), hermite.dh(xi), hermite.ddh(xi)
    parts = ((h[0], L * h[1], h[2], L * h[3]), (dh[0] / L, dh[1], dh[2] / L, dh[3]),
             (ddh[0] / L**2, ddh[1] / L, ddh[2] / L**2, ddh[3] / L))
    if np.ndim(xi) == 0 and np.ndim(L) == 0:  # one point (probes, output-time interpolation): no broadcasting work
        return tuple(np.array(p, dtype=float) for p in parts)
    return tuple(np.stack(np.broadcast_arrays(*p)) for p in parts)


class Probe:
    """Linear maps from the full coordinates x to r, r_x, r_xx at material coordinate s of a member: idx (dim, 4)
    global coordinates (r(0), r_x(0), r(L), r_x(L) per component) and the weights w, wx, wxx (4,)."""

    def __init__(self, mm: "MemberMesh", s: float, dim: int):
        e, xi = mm.locate(s)
        n0, n1 = mm.elem_nodes[e]
        ns = mm.node_size
        self.dim = dim
        base0, base1 = mm.offset + n0 * ns, mm.offset + n1 * ns
        self.idx = np.array([[base0 + k, base0 + dim + k, base1 + k, base1 + dim + k] for k in range(dim)])
        self.w, self.wx, self.wxx = weights(xi, mm.elem_length[e])

    def r(self, x):
        return x[self.idx] @ self.w

    def rx(self, x):
        return x[self.idx] @ self.wx

    def rxx(self, x):
        return x[self.idx] @ self.wxx
