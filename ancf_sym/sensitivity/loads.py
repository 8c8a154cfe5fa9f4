"""Exact static sensitivity to a point force at a member node, by the implicit function theorem.

The force enters the residual linearly: R(x, f) = grad Pi(x) - P f, so dR/df = -P and the reduced equilibrium
gives [K_L G'; G 0] [dy; dmu] = [B e; 0] with the exact Hessian of the Lagrangian K_L (ancf_sym.modal.linearize)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..modal.linearize import Linearization


def node_force_sensitivity(lin: Linearization, member: str, node: int, component: int) -> np.ndarray:
    """d x*/d f: full coordinates of the equilibrium per unit force at `member`'s public node `node` (index from 0,
    -1 the last), world component `component`."""
    nodes = [k for (name, k, _) in lin.inputs if name == member]
    if not nodes:
        raise KeyError(f"member {member!r}: no such member; members: {sorted({n for n, _, _ in lin.inputs})}")
    node = range(max(nodes) + 1)[node]
    col = lin.inputs.index((member, node, "xyz"[component]))
    rhs = lin.B[:, col].toarray().ravel()
    m = lin.G.shape[0]
    if m:
        A = sp.bmat([[lin.K, lin.G.T], [lin.G, None]]).tocsc()
        dy = spla.spsolve(A, np.r_[rhs, np.zeros(m)])[:lin.size]
    else:
        dy = spla.spsolve(lin.K.tocsc(), rhs)
    return lin.E @ dy
