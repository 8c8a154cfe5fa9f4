"""Dead point loads (forces at nodes or material points, prescribed tension) as a constant generalized force."""
from __future__ import annotations

import numpy as np

from .interpolation import Probe
from .mesh import Mesh, MemberMesh


def point_force(mm: MemberMesh, s: float, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices, values) of Q = S(x)^T F for a force F at material coordinate s."""
    p = Probe(mm, s, len(F))  # r(s) = idx @ w: r(0), r_x(0), r(L), r_x(L) per component
    return p.idx.T.ravel(), np.outer(p.w, F).ravel()


def load_vector(mesh: Mesh) -> np.ndarray:
    """Q_ext (n,): the potential of these loads is -Q_ext . x."""
    Q = np.zeros(mesh.n)
    for load in mesh.scene.loads:
        mm = mesh.members[load.member]
        if load.kind == "force":
            s = mm.coordinate(load.at)
            idx, val = point_force(mm, s, np.asarray(load.value, float))
            np.add.at(Q, idx, val)
        elif load.kind == "tension":
            node = mm.node(load.at)
            t = mm.x0[node][mm.node_size // (4 if mm.member.element == "beam3d" else 2):][:mesh.scene.dim]
            t = t / np.linalg.norm(t)  # reference slopes carry the prestretch
            outward = t if node == mm.n_nodes - 1 else -t
            idx, val = point_force(mm, float(mm.s_node[node]), float(load.value) * outward)
            np.add.at(Q, idx, val)
    return Q
