"""The mooring stiffness at a fairlead: how the force that holds a line's end changes as the end moves, about an
equilibrium in water, exactly (the condensed Jacobian of the statics' residual; no finite differences)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ancf_sym.util.checks import SceneError


def mooring_stiffness(result, member: str, at="end") -> np.ndarray:
    """(dim, dim) K = dF / du [N/m] at the held node (a pin or a position drive) of `member` at `at`: F the force the
    support applies to the line there (result.constraint_forces), u the node's position, the rest of the line in
    equilibrium (current and water line included). K = J_ff - J_fz KKT^-1 J_zf of the residual's exact Jacobian J
    (f: the node's coordinates, z: the free ones and the multipliers of rows kept exact). K_xx > 0: pulling the fairlead away raises the force holding it."""
    ws = getattr(result, "water", None)
    if ws is None or not result.success:
        raise SceneError("mooring_stiffness: give a successful statics result of a scene in water")
    asm, dim = ws.asm, ws.scene.dim
    mm = asm.mesh.members.get(member)
    if mm is None:
        raise SceneError(f"mooring_stiffness: member {member!r} does not exist; members: {sorted(asm.mesh.members)}")
    f = mm.node_dofs(mm.node(at))[:dim]
    if not np.all(np.isin(f, ws.fixed)):
        raise SceneError(f"mooring_stiffness: {member}@{at} is not held (pin or position drive)")
    _, Jd, _, Gd = ws.full(result.x, 1.0, ws.mu)
    J, G = sp.csc_matrix(Jd.sparse()), sp.csc_matrix(Gd.sparse())
    E = ws.E.tocsc()
    GE = (G @ E).tocsc()
    kkt = sp.bmat([[E.T @ J @ E, GE.T], [GE, None]], format="csc") if ws.m else (E.T @ J @ E).tocsc()
    Jzf = sp.vstack([E.T @ J[:, f], G[:, f]]).toarray() if ws.m else (E.T @ J[:, f]).toarray()
    Jfz = sp.hstack([J[f, :] @ E, G[:, f].T]).toarray() if ws.m else (J[f, :] @ E).toarray()
    return J[f, :][:, f].toarray() - Jfz @ splu(kkt).solve(Jzf)
