"""Fields along a member from its nodal coordinates: positions, axial strain and curvature at sample points."""
from __future__ import annotations

import numpy as np

from .elements import hermite
from .mesh import MemberMesh


def sample(mm: MemberMesh, xn: np.ndarray, per_element: int = 8) -> dict:
    """Positions r, slopes r_x and r_xx along the member; xn: (n_nodes, node_size) nodal coordinates.

    Returns s [m] (material coordinate), r (k, dim), strain = |r_x| - 1 [-], curvature |r_x x r_xx|/|r_x|^3 [1/m].
    """
    dim = mm.member.points.shape[1]
    xi = np.linspace(0.0, 1.0, per_element + 1)
    h, dh, ddh = (np.array(f(xi)) for f in (hermite.h, hermite.dh, hermite.ddh))  # (4, k)
    s_all, r_all, rx_all, rxx_all = [], [], [], []
    for e, (a, b) in enumerate(mm.elem_nodes):
        L = mm.elem_length[e]
        ra, ta, rb, tb = xn[a][:dim], xn[a][dim:2 * dim], xn[b][:dim], xn[b][dim:2 * dim]
        r = np.outer(h[0], ra) + L * np.outer(h[1], ta) + np.outer(h[2], rb) + L * np.outer(h[3], tb)
        rx = (np.outer(dh[0], ra) + np.outer(dh[2], rb)) / L + np.outer(dh[1], ta) + np.outer(dh[3], tb)
        rxx = (np.outer(ddh[0], ra) + np.outer(ddh[2], rb)) / L**2 + (np.outer(ddh[1], ta) + np.outer(ddh[3], tb)) / L
        keep = slice(0 if e == 0 else 1, None)
        s_all.append(mm.s_node[a] + xi[keep] * L)
        r_all.append(r[keep]); rx_all.append(rx[keep]); rxx_all.append(rxx[keep])
    r, rx, rxx = np.vstack(r_all), np.vstack(rx_all), np.vstack(rxx_all)
    norm = np.linalg.norm(rx, axis=1)
    if dim == 2:  # np.cross of 2-vectors is deprecated (NumPy 2)
        cr = np.abs(rx[:, 0] * rxx[:, 1] - rx[:, 1] * rxx[:, 0])
    else:
        cr = np.linalg.norm(np.cross(rx, rxx), axis=1)
    return {"s": np.concatenate(s_all), "r": r, "strain": norm - 1.0, "curvature": cr / norm**3}
