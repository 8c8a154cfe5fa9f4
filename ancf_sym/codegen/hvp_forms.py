"""Hessian-vector companions (<name>_hvp: (q, p, v) -> (H v, d(H v)/dq)) of quadrature kernels in point form.

For a station's fields u = B q, linear in q, the energy sum_k w_k L f(u_k, p) has H v = sum B^T f_uu (B v) and
d(H v)/dq = sum B^T T(u; B v) B with T(u; w) = d2(w . f_u)/du2, the density's third derivative contracted with
w = B v: a derivative of the small density (u: 9 or 12 entries), not of the 24-coordinate element energy. One SX
point function is emitted and called per Gauss point (as the kernels' own, codegen.forms.quadrature_kernel): the
beam3d elastic line's bending companion is ~13x smaller than CasADi's third derivative of the whole expanded kernel
(codegen.forms.hvp_function, which the cables keep).
"""
from __future__ import annotations

from typing import Callable

import casadi as ca

from ancf_sym.codegen.forms import lower_product
from ancf_sym.elements.quadrature import gauss01


def point_hvp_function(name: str, nq: int, n_p: int, station: Callable) -> ca.Function:
    """SX Function (q, p, v, xi, w) -> (H v, tril d(H v)/dq) of one quadrature station (station: as for
    codegen.forms.point_function, yielding (u, density, scale) per sub-point)."""
    q, p, v = ca.SX.sym("q", nq), ca.SX.sym("p", n_p), ca.SX.sym("v", nq)
    xi, w = ca.SX.sym("xi"), ca.SX.sym("w")
    hv, D = ca.SX.zeros(nq), ca.SX.zeros(ca.Sparsity.lower(nq))
    for u, density, scale in station(q, p, xi, w):
        s, d = ca.SX.sym("s", u.shape[0]), ca.SX.sym("d", u.shape[0])
        fu = ca.gradient(scale * density(s, p), s)
        T, fuu_d = ca.hessian(ca.dot(d, fu), s)  # (T = d2(d . f_u)/ds2, fuu_d = f_uu d)
        B = ca.jacobian(u, q)  # (constant in q)
        fuu_d, T = ca.substitute([fuu_d, T], [s, d], [u, ca.mtimes(B, v)])
        hv += ca.mtimes(B.T, fuu_d)
        D += lower_product(B, T)
    return ca.Function(name, [q, p, v, xi, w], [hv, D], ["q", "p", "v", "xi", "w"], ["hv", "dhv"])


def quadrature_hvp(name: str, point: ca.Function, gauss: int) -> ca.Function:
    """(q, p, v) -> (H v, d(H v)/dq) summed over the Gauss points, the lower triangle mirrored once at the end."""
    nq, n_p = point.size1_in(0), point.size1_in(1)
    q, p, v = ca.MX.sym("q", nq), ca.MX.sym("p", n_p), ca.MX.sym("v", nq)
    xs, ws = gauss01(gauss)
    hv, D = 0, 0
    for x, w in zip(xs, ws):
        a, b = point.call([q, p, v, float(x), float(w)])
        hv, D = hv + a, D + b
    return ca.Function(name, [q, p, v], [hv, ca.densify(ca.tril2symm(D))], ["q", "p", "v"], ["hv", "dhv"])
