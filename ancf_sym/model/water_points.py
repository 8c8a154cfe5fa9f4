"""The wet members' quadrature points: r, r_x at every point as sparse linear maps of the full coordinates, the
weights w L, and the per-point coefficients of the Morison and water-line terms."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ancf_sym.elements.quadrature import gauss01
from ancf_sym.elements.hermite import weights
from ancf_sym.scene.water import Water, diameter, displaced_area


@dataclass
class WetPoints:
    dim: int
    B: sp.csr_matrix  # (dim P, n): r at the points, component-major (row k P + p)
    Bx: sp.csr_matrix  # (dim P, n): r_x at the points
    wL: np.ndarray  # (P,) quadrature weight times element length [m]
    d: np.ndarray  # (P,) hydrodynamic diameter [m]
    area: np.ndarray  # (P,) displaced area [m^2] (0 where the member has no buoyancy)
    cd: np.ndarray
    cd_axial: np.ndarray
    ca: np.ndarray
    ca_axial: np.ndarray

    @property
    def P(self) -> int:
        return len(self.wL)

    @property
    def buoyant(self) -> bool:
        """Does some member displace water (a water line term)?"""
        return bool(np.any(self.area))

    @property
    def inertia_area(self) -> np.ndarray:
        """The area the added mass is taken on: the displaced area, or pi d^2 / 4 of a member without buoyancy."""
        return np.where(self.area > 0, self.area, np.pi * self.d ** 2 / 4)

    @property
    def drag(self) -> bool:
        return bool(np.any(self.cd) or np.any(self.cd_axial))

    @property
    def added_mass(self) -> bool:
        return bool(np.any(self.ca) or np.any(self.ca_axial))


def wet_points(asm, water: Water) -> WetPoints:
    """The points of every member (water.gauss per element)."""
    dim, n = asm.scene.dim, asm.n
    xi, wq = gauss01(water.gauss)
    rows, cols, vb, vx = [], [], [], []
    wl, dd, aa, cd, cda, cm, cma = [], [], [], [], [], [], []
    p0 = 0
    blocks = []
    for name, mm in asm.mesh.members.items():
        m = mm.member
        c = water.coefficients(name)
        idx = mm.elem_dofs()  # (N, 2 ns): [r0, r0_x, r1, r1_x] (cables: ns = 2 dim)
        L = np.asarray(mm.elem_length, float)
        N = len(L)
        w, wx, _ = weights(xi[None, :], L[:, None])  # (4, N, G)
        blocks.append((idx, w, wx, N, p0))
        p0 += N * len(xi)
        wl.append((wq[None, :] * L[:, None]).ravel())
        k = N * len(xi)
        dd.append(np.full(k, diameter(m, c)))
        aa.append(np.full(k, displaced_area(m, c) if c.buoyancy else 0.0))
        for lst, v in ((cd, c.cd), (cda, c.cd_axial), (cm, c.ca), (cma, c.ca_axial)):
            lst.append(np.full(k, v))
    P = p0
    G = len(xi)
    for idx, w, wx, N, p0 in blocks:
        pts = p0 + np.arange(N * G).reshape(N, G)
        for comp in range(dim):
            # coordinates of node a's r (comp) and r_x (comp) per element: a = 0, 1
            for j, col in enumerate((idx[:, comp], idx[:, dim + comp], idx[:, 2 * dim + comp], idx[:, 3 * dim + comp])):
                rows.append((comp * P + pts).ravel())
                cols.append(np.repeat(col, G))
                vb.append(w[j].ravel())
                vx.append(wx[j].ravel())
    r, cidx = np.concatenate(rows), np.concatenate(cols)
    B = sp.csr_matrix((np.concatenate(vb), (r, cidx)), shape=(dim * P, n))
    Bx = sp.csr_matrix((np.concatenate(vx), (r, cidx)), shape=(dim * P, n))
    cat = np.concatenate
    return WetPoints(dim, B, Bx, cat(wl), cat(dd), cat(aa), cat(cd), cat(cda), cat(cm), cat(cma))
