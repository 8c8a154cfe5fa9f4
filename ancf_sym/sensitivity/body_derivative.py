"""The derivative of the model with respect to a rigid body's numbers: bodies[i].mass, bodies[i].inertia (planar J;
spatial: the principal moments inertia[k] or the tensor's diagonal inertia[k][k]) and bodies[i].force[j].

Both body kinds have a constant mass matrix, linear in the mass and the inertia (ancf_sym.bodies): a planar body's
diag(m, m, J, J) on (x, y, cos, sin), a spatial body's diag(m, m, m) + C (x) I_3 on (r, e1, e2, e3) in natural
coordinates, C = tr(I)/2 - I its second moment in the body axes (so dC/dI_kk = 1/2 I_3 - e_k e_k': the mass matrix
does not depend on the orientation, nor does its derivative). The weight m g and the dead force act at the centre of
mass, the body's first coordinates, with the potential -Q.x: dQ = g (mass), e_j (force[j]), nil (inertia).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp

from ancf_sym.model.assembly import Assembly


def body_derivative(asm: Assembly, doc: dict, keys: tuple, refuse: Callable[[str], None]
                    ) -> tuple[np.ndarray | None, Callable[[], sp.csc_matrix] | None]:
    """(dQ, a builder of dM or None) for the path keys ('bodies', i, name[, index...]); `refuse(why)` raises the
    parameter error naming the path."""
    scene = asm.scene
    body_doc = doc["bodies"][keys[1]]
    name = body_doc["name"]
    o = asm.mesh.bodies[name]
    n, dim = asm.n, scene.dim
    what = keys[2]

    def diagonal(idx: np.ndarray, vals: np.ndarray) -> Callable[[], sp.csc_matrix]:
        return lambda: sp.csc_matrix((vals, (idx, idx)), shape=(n, n))
    if what == "mass" and len(keys) == 3:
        dQ = np.zeros(n)
        dQ[o:o + dim] = np.asarray(scene.gravity, float)
        return dQ, diagonal(o + np.arange(dim), np.ones(dim))
    if what == "force" and len(keys) == 4:
        dQ = np.zeros(n)
        dQ[o + keys[3]] = 1.0
        return dQ, None
    if what == "inertia" and dim == 2 and len(keys) == 3:
        return None, diagonal(o + np.array([2, 3]), np.ones(2))
    if what == "inertia" and dim == 3 and len(keys) in (4, 5):
        k = keys[3]
        if len(keys) == 5 and keys[4] != k:
            refuse("an off-diagonal product of inertia: changing one entry of the symmetric tensor leaves it "
                   "unsymmetric (differentiable: the diagonal inertia[k][k], or the principal moments inertia[k])")
        dC = 0.5 * np.eye(3)
        dC[k, k] -= 1.0
        a, b, c = np.meshgrid(np.arange(3), np.arange(3), np.arange(3), indexing="ij")  # (C (x) I_3: e_a . e_b)
        rows, cols = (o + 3 + 3 * a + c).ravel(), (o + 3 + 3 * b + c).ravel()
        vals = dC[a, b].ravel()
        return None, lambda: sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    refuse("differentiable body numbers: bodies[i].mass, bodies[i].force[j], bodies[i].inertia (planar), "
           "bodies[i].inertia[k] or inertia[k][k] (spatial)")
    return None, None
