"""Fields along a member from its nodal coordinates: positions, axial strain and curvature at sample points."""
from __future__ import annotations

import numpy as np

from .interpolation import weights
from .mesh import MemberMesh


def sample(mm: MemberMesh, xn: np.ndarray, per_element: int = 8) -> dict:
    """Positions r, slopes r_x and r_xx along the member; xn: (n_nodes, node_size) nodal coordinates.

    Returns s [m] (material coordinate), r (k, dim), strain = |r_x| - 1 [-], curvature |r_x x r_xx|/|r_x|^3 [1/m].
    """
    dim = mm.member.points.shape[1]
    xi = np.linspace(0.0, 1.0, per_element + 1)
    s_all, r_all, rx_all, rxx_all = [], [], [], []
    for e, (a, b) in enumerate(mm.elem_nodes):
        L = mm.elem_length[e]
        c = np.stack([xn[a][:dim], xn[a][dim:2 * dim], xn[b][:dim], xn[b][dim:2 * dim]])  # (4, dim)
        w, wx, wxx = weights(xi, L)  # (4, k)
        r, rx, rxx = w.T @ c, wx.T @ c, wxx.T @ c
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
