"""Turn energies into CasADi Functions (energy, gradient, Hessian) with as few operations as the structure allows.

Three forms:
- quadrature form: U = sum_k w_k L f(u(xi_k), p) where the local fields u (slopes, curvature vectors) are linear
  in q, u = B(xi, p) q. Then grad = sum w L B^T f_u and Hess = sum w L B^T f_uu B: the density's small Hessian is
  differentiated once, not the whole element energy twice. One SX point-function is emitted and called per point,
  so gcc compiles it once whatever the quadrature order.
- direct form: CasADi's own gradient and Hessian of an element energy that is not a sum of local densities
  (decoupled strain, loads).
- stretch form: an energy of a few stretch measures (nodal norms, a quadrature length) plus a quadrature density,
  differentiated in those measures and chained (the decoupled strain fused with bending).
"""
from __future__ import annotations

from typing import Callable

import casadi as ca

from ancf_sym.elements.quadrature import gauss01

KERNEL_IN = ["q", "p"]
KERNEL_OUT = ["energy", "gradient", "hessian"]


def point_terms(q: ca.SX, p: ca.SX, u: ca.SX, density: Callable[[ca.SX, ca.SX], ca.SX], scale):
    """(scale*f, scale*B^T f_u, tril(scale*B^T f_uu B)) for fields u linear in q."""
    v = ca.SX.sym("v", u.shape[0])
    f = scale * density(v, p)  # scaling before differentiating costs one product per unique Hessian entry
    fu, fuu = ca.gradient(f, v), ca.hessian(f, v)[0]
    f_q, fu_q, fuu_q = ca.substitute([f, fu, fuu], [v], [u])
    B = ca.jacobian(u, q)  # constant in q: depends on p and the point only
    return f_q, ca.mtimes(B.T, fu_q), lower_product(B, fuu_q)


def lower_product(B: ca.SX, A: ca.SX) -> ca.SX:
    """Lower triangle of B^T A B for symmetric A (the kernel mirrors it once, after summing the points)."""
    BtA = ca.mtimes(B.T, A)
    n = B.shape[1]
    H = ca.SX.zeros(ca.Sparsity.lower(n))
    for i in range(n):
        for j in range(i + 1):
            hij = ca.dot(BtA[i, :].T, B[:, j])
            H[i, j] = hij
    return H


def point_function(name: str, nq: int, n_p: int, station: Callable) -> ca.Function:
    """SX Function (q, p, xi, w) -> (e, g, H): contribution of one quadrature station.

    station(q, p, xi, w) yields (u, density, scale) triples, one per sub-point (several for a cross-section).
    """
    q, p = ca.SX.sym("q", nq), ca.SX.sym("p", n_p)
    xi, w = ca.SX.sym("xi"), ca.SX.sym("w")
    e, g, H = ca.SX(0), ca.SX.zeros(nq), ca.SX.zeros(ca.Sparsity.lower(nq))
    for u, density, scale in station(q, p, xi, w):
        de, dg, dH = point_terms(q, p, u, density, scale)
        e, g, H = e + de, g + dg, H + dH
    return ca.Function(name, [q, p, xi, w], [e, g, H], ["q", "p", "xi", "w"], KERNEL_OUT)


def quadrature_kernel(name: str, point: ca.Function, gauss: int) -> ca.Function:
    """Sum of the point function over the Gauss points; a 3-output point function's lower-triangular Hessian is
    mirrored once at the end."""
    nq, n_p = point.size1_in(0), point.size1_in(1)
    q, p = ca.MX.sym("q", nq), ca.MX.sym("p", n_p)
    xs, ws = gauss01(gauss)
    outs = [0] * point.n_out()
    for x, w in zip(xs, ws):
        outs = [a + b for a, b in zip(outs, point.call([q, p, float(x), float(w)]))]
    if len(outs) == 3:
        outs[2] = ca.densify(ca.tril2symm(outs[2]))
    return ca.Function(name, [q, p], outs, KERNEL_IN, KERNEL_OUT[:len(outs)])


def pruned(f: ca.Function, n_out: int, name: str) -> ca.Function:
    """An SX function restricted to its first n_out outputs: the operations only the others need are dropped."""
    args = [ca.SX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    outs = f.call(args)[:n_out]
    return ca.Function(name, args, outs, f.name_in(), f.name_out()[:n_out])


def rates_rows(kernel: ca.Function, name: str) -> ca.Function:
    """(z, p) -> (f, J) of a dissipation kernel D(z), z = [q; v] (n each): the force f = dD/dv and its Jacobian
    J = [df/dq, df/dv] (n x 2n), the rows of the Hessian the step uses; the q-q block's operations are dropped
    (the kernel's own SX graph restricted to these outputs: the same arithmetic, entry for entry)."""
    args = [ca.SX.sym(kernel.name_in(i), kernel.sparsity_in(i)) for i in range(kernel.n_in())]
    _, g, H = kernel.call(args)
    n = g.shape[0] // 2
    return ca.Function(name, args, [g[n:], ca.densify(H[n:, :])], kernel.name_in(), ["force", "jacobian"])


def direct_kernel(name: str, nq: int, n_p: int, energy: Callable[[ca.SX, ca.SX], ca.SX]) -> ca.Function:
    q, p = ca.SX.sym("q", nq), ca.SX.sym("p", n_p)
    U = energy(q, p)
    H, g = ca.hessian(U, q)
    return ca.Function(name, [q, p], [U, g, ca.densify(H)], KERNEL_IN, KERNEL_OUT)


def lower_orders(kernel: ca.Function, points: tuple[ca.Function, ca.Function] | None,
                 gauss: int | None) -> tuple[ca.Function, ca.Function]:
    """(<name>_energy: (q, p) -> energy, <name>_grad: (q, p) -> (energy, gradient)) without the Hessian's work.

    The energy is what IPOPT differentiates through (with its reverse companion); energy + gradient is the
    residual of modified Newton iterations, which reuse a factorised tangent."""
    name = kernel.name()
    if kernel.is_a("SXFunction"):
        return pruned(kernel, 1, name + "_energy"), pruned(kernel, 2, name + "_grad")
    point_e, point_eg = points  # the point function pruned to (e) and (e, g): shared by every quadrature order
    return (quadrature_kernel(name + "_energy", point_e, gauss), quadrature_kernel(name + "_grad", point_eg, gauss))


def hvp_function(kernel: ca.Function) -> ca.Function:
    """(q, p, v) -> (H v, d(H v)/dq): the Hessian-vector product and its Jacobian (the Hessian of v . grad U).

    Optimal control puts grad U inside the dynamics constraints; the exact Hessian of IPOPT's Lagrangian then needs
    these third derivatives of the energy contracted with the multipliers v.
    """
    nq, n_p = kernel.size1_in(0), kernel.size1_in(1)
    q, p, v = ca.SX.sym("q", nq), ca.SX.sym("p", n_p), ca.SX.sym("v", nq)
    sx = kernel.expand() if not kernel.is_a("SXFunction") else kernel
    g = sx(q, p)[1]
    d2, hv = ca.hessian(ca.dot(v, g), q)
    return ca.Function(kernel.name() + "_hvp", [q, p, v], [hv, ca.densify(d2)], ["q", "p", "v"], ["hv", "dhv"])


def stretch_kernel(name: str, nq: int, n_p: int, gauss: int, coordinates: Callable, basis: Callable,
                   invariants: Callable, ends: Callable, stretch_energy: Callable, density: Callable) -> ca.Function:
    """(q, p) -> (e, g, H) of U = f(s, p) + sum_k w_k L phi(z_k, p): an energy f of three stretch measures
    s = (a, l, c) = (|t0|, sum_k w_k L |r_x(xi_k)|, |t1|) plus a quadrature density phi of the fields' invariants.

    The energy sees q through fewer coordinates y = coordinates(q, p) = R q (linear, one entry of R per column:
    a rigid translation drops out, lengths are scaled); at a point the fields are u = B y with a numeric
    B = basis(xi) (r_x first), phi depends on them through the quadratic forms z = invariants(u) (z_0 = |r_x|^2),
    and ends(y) = (t0, t1). Chain rule, exact (CasADi AD of the small functions f(s) and
    psi(z) = w L (mu sqrt(z_0) + phi(z)), mu = f_l: the length's share of each point joins its density):
      grad_y = sum_k G_k^T psi_z + f_a grad a + f_c grad c,   G_k = dz_k/dy,
      Hess_y = sum_k (G_k^T psi_zz G_k + sum_i psi_z,i B_k^T Hess(z_i) B_k) + J^T f_ss J + f_a Hess a + f_c Hess c,
    J = ds/dy; the B_k^T Hess(z_i) B_k are numbers, so their weighted sums cost one product per distinct entry.
    Then grad = R^T grad_y, Hess = R^T Hess_y R. Common subexpressions (the invariants' repeated entries, the
    norms of both passes, mirrored entries) are merged once at the end."""
    q, p = ca.SX.sym("q", nq), ca.SX.sym("p", n_p)
    L = p[0]
    yq = coordinates(q, p)
    R = ca.jacobian(yq, q)
    y = ca.SX.sym("y", yq.shape[0])
    ny = y.shape[0]
    v = ca.SX.sym("v", basis(0.5).shape[0])
    zv = invariants(v)
    nz = zv.shape[0]
    hz = [ca.evalf(ca.hessian(zv[i], v)[0]) for i in range(nz)]  # constant: z quadratic in v
    zs, mu, wl = ca.SX.sym("z", nz), ca.SX.sym("mu"), ca.SX.sym("wl")
    phi = density(zs, p)
    psi_zz, psi_z = ca.hessian(wl * (mu * ca.sqrt(zs[0]) + phi), zs)
    xs, ws = gauss01(gauss)
    Bs = [ca.DM(basis(float(x))) for x in xs]
    zk = [ca.substitute(zv, v, ca.mtimes(B, y)) for B in Bs]
    ls = L * sum(float(w) * ca.sqrt(z[0]) for z, w in zip(zk, ws))
    t0, t1 = ends(y)
    a, c = ca.sqrt(ca.sumsqr(t0)), ca.sqrt(ca.sumsqr(t1))
    s = ca.SX.sym("s", 3)
    f = stretch_energy(s, p)
    fss, fs = ca.hessian(f, s)
    f, fs, fss = ca.substitute([f, fs, fss], [s], [ca.vertcat(a, ls, c)])
    e, g, H = f, ca.SX.zeros(ny), ca.SX.zeros(ca.Sparsity.lower(ny))
    const = [ca.SX.zeros(ca.Sparsity.lower(ny)) for _ in range(nz)]
    for B, z, w in zip(Bs, zk, ws):
        ph, pz, pzz = ca.substitute([phi, psi_z, psi_zz], [zs, mu, wl], [z, fs[1], float(w) * L])
        G = ca.jacobian(z, y)
        e += float(w) * L * ph
        g += ca.mtimes(G.T, pz)
        H += lower_product(G, pzz)
        for i in range(nz):
            const[i] += pz[i] * ca.SX(ca.tril(ca.mtimes([B.T, hz[i], B])))
    ga, gc = ca.jacobian(a, y), ca.jacobian(c, y)
    g += fs[0] * ga.T + fs[2] * gc.T
    J = ca.vertcat(ga, ca.jacobian(ls, y), gc)
    H += sum(const) + lower_product(J, fss) + ca.tril(fs[0] * ca.hessian(a, y)[0] + fs[2] * ca.hessian(c, y)[0])
    e, g, H = ca.substitute([e, ca.mtimes(R.T, g), ca.tril(ca.mtimes([R.T, ca.tril2symm(H), R]))], [y], [yq])
    e, g, H = ca.cse([e, g, ca.densify(ca.tril2symm(H))])
    return ca.Function(name, [q, p], [e, g, H], KERNEL_IN, KERNEL_OUT)


def direction_function(kernel: ca.Function, name: str) -> ca.Function:
    """(q, p, dq, dp) -> (de, dg, dH): the forward derivative of the kernel's (energy, gradient, Hessian) along
    (dq, dp), exact (CasADi AD of the same symbolic graph, expanded to SX).

    The sensitivities need d/dP of a kernel's outputs where a scene number enters its parameters nonlinearly (a
    beam's Poisson ratio, a drum's radius: dq = 0, dp = dP/dp) and, along dq with dp = 0, the Hessian's change with
    the state (the third derivatives of a curved kernel without an _hvp companion)."""
    sx = kernel if kernel.is_a("SXFunction") else kernel.expand()
    nq, n_p = sx.size1_in(0), sx.size1_in(1)
    q, p, dq, dp = ca.SX.sym("q", nq), ca.SX.sym("p", n_p), ca.SX.sym("dq", nq), ca.SX.sym("dp", n_p)
    z, dz = ca.vertcat(q, p), ca.vertcat(dq, dp)
    de, dg, dH = (ca.jtimes(ca.vec(o), z, dz) for o in sx(q, p))
    return ca.Function(name, [q, p, dq, dp], [de, dg, ca.densify(ca.reshape(dH, nq, nq))],
                       ["q", "p", "dq", "dp"], KERNEL_OUT)


def mass_direction(mass: ca.Function, name: str) -> ca.Function:
    """(p, dp) -> dM: the mass matrix's derivative along dp (the beam's mass is not linear in its b x h)."""
    p, dp = ca.SX.sym("p", mass.size1_in(0)), ca.SX.sym("dp", mass.size1_in(0))
    M = mass(p)
    return ca.Function(name, [p, dp], [ca.densify(ca.reshape(ca.jtimes(ca.vec(M), p, dp), M.shape))], ["p", "dp"],
                       ["mass"])
