"""The mooring stiffness at a fairlead: how the force that holds a line's end changes as the end moves, about an
equilibrium in water, exactly (the condensed Jacobian of the statics' residual; no finite differences)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..scene import SceneError


def mooring_stiffness(result, member: str, at="end") -> np.ndarray:
    """(dim, dim) K = dF / du [N/m] at the held node (a pin or a position drive) of `member` at `at`: F the force the
    support applies to the line there (result.constraint_forces), u the node's position, the rest of the line in
    equilibrium (current and water line included). K = J_ff - J_fy J_yy^-1 J_yf of the residual's exact Jacobian J
    (f: the node's coordinates, y: the free ones). K_xx > 0: pulling the fairlead away raises the force holding it."""
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
    J = sp.csc_matrix(ws.full(result.x, 1.0)[1].sparse())
    E = ws.E.tocsc()
    Jyy = (E.T @ J @ E).tocsc()
    Jyf = (E.T @ J[:, f]).toarray()
    Jfy = (J[f, :] @ E).toarray()
    return J[f, :][:, f].toarray() - Jfy @ splu(Jyy).solve(Jyf)
