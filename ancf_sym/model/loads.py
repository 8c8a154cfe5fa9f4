"""Dead point loads (forces at nodes or material points, prescribed tension) as a constant generalized force."""
from __future__ import annotations

import numpy as np

from ancf_sym.model.mesh import Probe
from ancf_sym.model.mesh import Mesh, MemberMesh


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
    g = np.asarray(mesh.scene.gravity, float)
    for pm in getattr(mesh.scene, "point_masses", ()):  # the weight of point masses: dead forces m g
        if np.any(g != 0):
            mm = mesh.members[pm.member]
            idx, val = point_force(mm, mm.coordinate(pm.at), pm.mass * g)
            np.add.at(Q, idx, val)
    return Q


def point_mass_triplets(mesh: Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, cols, values) of the point masses' mass matrix m S(s)^T S(s): per component, m w_a w_b between the
    four coordinates r(0), r_x(0), r(L), r_x(L) that interpolate r at the mass's material coordinate s."""
    rows, cols, vals = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    for pm in getattr(mesh.scene, "point_masses", ()):
        mm = mesh.members[pm.member]
        p = Probe(mm, mm.coordinate(pm.at), mesh.scene.dim)
        for idx in p.idx:  # one component: (4,) coordinates
            rows.append(np.repeat(idx, 4))
            cols.append(np.tile(idx, 4))
            vals.append(pm.mass * np.outer(p.w, p.w).ravel())
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
