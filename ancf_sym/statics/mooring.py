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
    return _condensed(J[f, :][:, f], J[f, :] @ E, E.T @ J[:, f], E.T @ J @ E, G[:, f], G @ E)


def _condensed(Jff, Jfz, Jzf, Jzz, Gf, Gz) -> np.ndarray:
    """J_ff - [J_fz G_f^T] KKT^-1 [J_zf; G_f], KKT = [[J_zz, G_z^T], [G_z, 0]]: the residual's Jacobian condensed on
    the coordinates f, the coordinates z and the multipliers of the rows G in equilibrium (no rows: J_zz alone)."""
    if Gz.shape[0]:
        kkt = sp.bmat([[Jzz, Gz.T], [Gz, None]], format="csc")
        Jzf, Jfz = sp.vstack([Jzf, Gf]), sp.hstack([Jfz, Gf.T])
    else:
        kkt = sp.csc_matrix(Jzz)
    return sp.csr_matrix(Jff).toarray() - sp.csr_matrix(Jfz).toarray() @ splu(kkt).solve(sp.csr_matrix(Jzf).toarray())


def body_mooring_stiffness(result, body: str) -> np.ndarray:
    """(3, 3) K = d(-F, -M) / d(u_x, u_y, theta) [N/m, N/rad, N m/rad] of a free planar body held by its lines: the
    force and moment the lines put on it as it moves rigidly (u about its centre, turned by theta), the lines in
    equilibrium (current and water line included), about a statics result in water. The condensation of the
    residual's exact Jacobian on the body's coordinates (x, y, c, s), with every kept row but the body's own
    (c^2 + s^2 = 1, whose curvature at its multiplier stays in), mapped to the rigid motion by T: (x, y) += u,
    (c, s) += (-s, c) theta. Exact at an equilibrium of the body (no net force or moment on it)."""
    ws = getattr(result, "water", None)
    if ws is None or not result.success:
        raise SceneError("body_mooring_stiffness: give a successful statics result of a scene in water")
    asm = ws.asm
    if ws.scene.dim != 2:
        raise SceneError("body_mooring_stiffness: planar bodies (2D scenes) only in this version")
    if body not in asm.mesh.bodies:
        raise SceneError(f"body_mooring_stiffness: body {body!r} does not exist; bodies: {sorted(asm.mesh.bodies)}")
    bc = np.arange(asm.mesh.bodies[body], asm.mesh.bodies[body] + 4)
    E = ws.E.tocsr()
    b = []
    for k in bc:  # each body coordinate an unknown of its own: a body held by a joint or a drive is refused
        row = E[k]
        if row.nnz != 1 or row.data[0] != 1.0 or np.asarray(abs(E[:, row.indices[0]]).sum()).item() != 1.0:
            raise SceneError(f"body_mooring_stiffness: body {body!r} is held (a revolute joint, a drive or a "
                             "support fixes or shares its coordinates): its lines alone must hold it")
        b.append(int(row.indices[0]))
    b = np.array(b)
    _, Jd, _, Gd = ws.full(result.x, 1.0, ws.mu)
    J, G = sp.csc_matrix(Jd.sparse()), sp.csr_matrix(Gd.sparse())
    Ec = E.tocsc()
    Jr = (Ec.T @ J @ Ec).tocsc()
    own = np.array([set(G[r].indices) <= set(bc) for r in range(G.shape[0])], bool)
    Gr = (G[np.flatnonzero(~own)] @ Ec).tocsc()
    other = np.setdiff1d(np.arange(Jr.shape[0]), b)
    Kb = _condensed(Jr[b][:, b], Jr[b][:, other], Jr[other][:, b], Jr[other][:, other], Gr[:, b], Gr[:, other])
    c, s = result.x[bc[2]], result.x[bc[3]]
    T = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -s], [0.0, 0.0, c]])
    return T.T @ Kb @ T
