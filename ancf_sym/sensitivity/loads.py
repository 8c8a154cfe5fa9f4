"""Exact static sensitivity to a point force at a member node, by the implicit function theorem.

The force enters the residual linearly: R(x, f) = grad Pi(x) - P f, so dR/df = -P and the reduced equilibrium
gives [K_L G'; G 0] [dy; dmu] = [B e; 0] with the exact Hessian of the Lagrangian K_L (ancf_sym.modal.linearize)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.modal.linearize import Linearization


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


def load_value_sensitivity(doc: dict, lin: Linearization, path: str) -> np.ndarray:
    """d x*/d p for p = ``loads[i].value[j]`` of a scene document: a force at a node (``at`` an integer, "start"
    or "end"). Other loads (distributed, moments, tensions, forces between nodes) are refused by name: not
    handled yet."""
    from ancf_sym.sensitivity.paths import get_parameter, parse_path

    p = parse_path(path)
    get_parameter(doc, p)  # names a number, or a clear error
    if len(p.keys) != 4 or p.keys[0] != "loads" or p.keys[2] != "value":
        raise ValueError(f"parameter path {path!r}: expected loads[i].value[j]")
    load = doc["loads"][p.keys[1]]
    at = load.get("at")
    if load.get("type") != "force" or not (at in ("start", "end") or (isinstance(at, int) and not isinstance(at, bool))):
        raise ValueError(f"parameter path {path!r}: a {load.get('type')!r} load at {at!r}; only forces at a node "
                         "are handled")
    node = {"start": 0, "end": -1}.get(at, at)
    return node_force_sensitivity(lin, load["member"], node, p.keys[3])
