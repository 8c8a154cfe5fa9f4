"""The mooring stiffness at a fairlead: how the force that holds a line's end changes as the end moves, about an
equilibrium in water, exactly (the condensed Jacobian of the statics' residual; no finite differences)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ancf_sym.util.checks import SceneError


def mooring_stiffness(result, member: str, at="end") -> np.ndarray:
    """(dim, dim) K = dF / du [N/m] at the held node (a pin or a position drive) of `member` at `at`: F the force the
    support applies to the line there (minus result.constraint_forces, which is the line's force on the support), u the node's position, the rest of the line in
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


def body_mooring_stiffness(result, body: str, point=None) -> np.ndarray:
    """The mooring stiffness of a free rigid body held by its lines, about a statics result in water:
    K = -d(F, M) / d(u, theta), planar (3, 3) [N/m, N/rad; N m/m, N m/rad] or spatial (6, 6): F the force and M the
    moment about the point p the lines put on the body, as the body moves rigidly by the translation u of p and the
    small turn theta about p (world components; planar: theta about the normal of the plane), the lines in
    equilibrium (current and water line included). point: p in world coordinates at the equilibrium (e.g. a
    fairlead), default the body's centre.

    Exact: the residual's exact Jacobian condensed on the body's coordinates (planar (x, y, c, s); spatial the centre
    and the axes e_k), with every kept row but the body's own (its axes' orthonormality, whose curvature at its
    multipliers stays in), mapped to the rigid motion by T: r += u + theta x (r - p), e_k += theta x e_k; plus the
    second-order terms of that map: N . q_ab - Q . dT_a/dtheta_b (N the own rows' force G' mu on the body's
    coordinates, Q the lines', q_ab the rigid motion's symmetric second derivative). At p = the centre with only
    centre loads on the body these cancel; about another point they carry the lines' force turning with the lever
    arm (K is then unsymmetric where the lines' force on the body is not zero)."""
    ws = getattr(result, "water", None)
    if ws is None or not result.success:
        raise SceneError("body_mooring_stiffness: give a successful statics result of a scene in water")
    asm, dim = ws.asm, ws.scene.dim
    if body not in asm.mesh.bodies:
        raise SceneError(f"body_mooring_stiffness: body {body!r} does not exist; bodies: {sorted(asm.mesh.bodies)}")
    size = 4 if dim == 2 else 12  # (x, y, c, s) | (r, e1, e2, e3)
    bc = np.arange(asm.mesh.bodies[body], asm.mesh.bodies[body] + size)
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
    mu = np.asarray(ws.mu, float)
    N = (G[np.flatnonzero(own)].T @ mu[own])[bc]  # the body's own rows' force on its coordinates
    Q = -(G[np.flatnonzero(~own)].T @ mu[~own])[bc]  # the lines' (through their joints' rows)
    q = np.asarray(result.x, float)[bc]
    c = q[:dim]
    p = c if point is None else _point(point, dim)
    T, corr = _rigid_motion(q, c - p, N, Q, dim)
    K = T.T @ Kb @ T
    K[dim:, dim:] += corr
    return K


def _point(point, dim: int) -> np.ndarray:
    p = np.asarray(point, float) if np.ndim(point) == 1 else None
    if p is None or p.shape != (dim,) or not np.all(np.isfinite(p)):
        raise SceneError(f"body_mooring_stiffness: point must be {dim} finite world coordinates [m], got {point!r}")
    return p


def _lift(v: np.ndarray) -> np.ndarray:
    return np.r_[v, np.zeros(3 - len(v))]


def _rigid_motion(q: np.ndarray, d: np.ndarray, N: np.ndarray, Q: np.ndarray, dim: int):
    """(T, corr): T maps (u, theta) to the body's coordinates (r += u + theta x d, d = r - p; e_k += theta x e_k);
    corr[a, b] = sum over the vector blocks v (d, e_k) of N_v . sym(a x (b x v)) - Q_v . a x (b x v)."""
    blocks = [(slice(0, dim), d)] + ([(slice(2, 4), q[2:4])] if dim == 2 else
                                     [(slice(3 + 3 * k, 6 + 3 * k), q[3 + 3 * k:6 + 3 * k]) for k in range(3)])
    axes = np.eye(3) if dim == 3 else np.array([[0.0, 0.0, 1.0]])
    na = len(axes)
    T = np.zeros((len(q), dim + na))
    T[:dim, :dim] = np.eye(dim)
    corr = np.zeros((na, na))
    for sl, v in blocks:
        v3, n3, q3 = _lift(v), _lift(N[sl]), _lift(Q[sl])
        for i, a in enumerate(axes):
            T[sl, dim + i] = np.cross(a, v3)[:dim]
            for j, bb in enumerate(axes):
                abv, bav = np.cross(a, np.cross(bb, v3)), np.cross(bb, np.cross(a, v3))
                corr[i, j] += n3 @ (0.5 * (abv + bav)) - q3 @ abv
    return T, corr
