"""Gradient-deficient ANCF cable (planar 8 DOF, spatial 12 DOF): kinematics and one energy per effect.

q = [r(0), r_x(0), r(L), r_x(L)], each a dim-vector. Energies are written in squared forms wherever a norm
would put a non-differentiable point inside a physical state (zero curvature).
"""
from __future__ import annotations

import casadi as ca

from ancf_sym.elements import hermite
from ancf_sym.elements.quadrature import gauss01


def nodal(q: ca.SX, dim: int) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """Split q into r(0), r_x(0), r(L), r_x(L)."""
    return tuple(q[i * dim:(i + 1) * dim] for i in range(4))


def position(q, L, xi, dim: int):
    r0, t0, r1, t1 = nodal(q, dim)
    h = hermite.h(xi)
    return h[0] * r0 + L * h[1] * t0 + h[2] * r1 + L * h[3] * t1


def slope(q, L, xi, dim: int):
    """r_x at xi [-]."""
    r0, t0, r1, t1 = nodal(q, dim)
    d = hermite.dh(xi)
    return (d[0] * r0 + d[2] * r1) / L + d[1] * t0 + d[3] * t1


def curvature_vector(q, L, xi, dim: int):
    """r_xx at xi [1/m]."""
    r0, t0, r1, t1 = nodal(q, dim)
    d = hermite.ddh(xi)
    return (d[0] * r0 + d[2] * r1) / L**2 + (d[1] * t0 + d[3] * t1) / L


def cross2(a, b):
    """z-component of a x b for planar vectors, or the 3-vector for spatial ones."""
    if a.shape[0] == 2:
        return a[0] * b[1] - a[1] * b[0]
    return ca.cross(a, b)


# Energy densities per unit reference length, as functions of the local fields (linear in q) ------------------

def green_density(rx, EA):
    eps = (ca.dot(rx, rx) - 1) / 2
    return EA / 2 * eps**2


def biot_density(rx, EA):
    eps = ca.sqrt(ca.dot(rx, rx)) - 1
    return EA / 2 * eps**2


def bending_density(rx, rxx, EI):
    c = cross2(rx, rxx)
    g = ca.dot(rx, rx)
    return bending_of_invariants(g, c, EI)


def bending_invariants(rx, rxx):
    """(r_x.r_x, r_x x r_xx): the quadratic forms of the fields bending depends on (a scalar cross product in 2D)."""
    return ca.vertcat(ca.dot(rx, rx), cross2(rx, rxx))


def bending_of_invariants(g, c, EI):
    return EI / 2 * ca.sumsqr(c) / g**3  # kappa^2 = |r_x x r_xx|^2/|r_x|^6: smooth at zero curvature


# Whole-element energies (direct form; the decoupled strain needs the whole element at once) ------------------

def decoupled_stretches(q, L, dim: int, gauss: int):
    """(a, L_D, c) = (|r_x(0)|, int |r_x| dx by `gauss` points, |r_x(L)|): all the decoupled axial energy sees of q."""
    _, t0, _, t1 = nodal(q, dim)
    xs, ws = gauss01(gauss)
    LD = L * sum(w * ca.sqrt(ca.sumsqr(slope(q, L, x, dim))) for x, w in zip(xs, ws))
    return ca.sqrt(ca.sumsqr(t0)), LD, ca.sqrt(ca.sumsqr(t1))


def rod_energy(a, LD, c, L, EA, gauss: int, strain: str = "green"):
    """Axial energy of the equivalent rod q_D = [0, a, L_D, c] (scalar Hermite functions of x in [0, L]), with
    its Green strain ((r_D,x)^2 - 1)/2 or Biot strain r_D,x - 1, integrated by `gauss` points."""
    xs, ws = gauss01(gauss)
    U = 0
    for x, w in zip(xs, ws):
        d = hermite.dh(x)
        rDx = d[1] * a + d[2] * LD / L + d[3] * c  # d r_D / dx with r_D(0) = 0
        eps = (rDx**2 - 1) / 2 if strain == "green" else rDx - 1
        U += w * L * EA / 2 * eps**2
    return U


def decoupled_energy(q, p, dim: int, gauss: int, strain: str = "green"):
    """Paper 000 sec. 2: axial energy of the equivalent rod q_D = [0, |r_x(0)|, L_D, |r_x(L)|], with the rod's Green
    strain (the paper's) or its Biot strain r_D,x - 1 (the statics' start for it, as Biot is for coupled Green)."""
    L, EA = p[0], p[1]
    a, LD, c = decoupled_stretches(q, L, dim, gauss)
    return rod_energy(a, LD, c, L, EA, gauss, strain)


def gravity_energy(q, p, dim: int):
    """-int rhoA g.r dx; the cubic times a constant is integrated exactly by 2 Gauss points, 4 used."""
    L, rhoA, g = p[0], p[1], p[2:2 + dim]
    xs, ws = gauss01(4)
    return -sum(w * L * rhoA * ca.dot(g, position(q, L, x, dim)) for x, w in zip(xs, ws))


def planar_angle(ref_a, ref_b, a, b):
    """Signed angle turning the planar vector (ref_a, ref_b) to (a, b); its gradient is smooth except at 0."""
    return ca.atan2(ref_a * b - ref_b * a, ref_a * a + ref_b * b)


def _angle_over_sine(c):
    """acos(c) / sqrt(1 - c^2), analytic at c = 1 (series there: both branches stay finite for the derivatives)."""
    x = 1 - c
    series = 1 + x / 3 + 2 * x**2 / 15 + 2 * x**3 / 35 + 8 * x**4 / 315  # error < 1e-14 for x < 1e-3
    cc = ca.fmax(ca.fmin(c, 1 - 1e-3), -1 + 1e-12)
    return ca.if_else(x < 1e-3, series, ca.acos(cc) / ca.sqrt(1 - cc * cc))


def moment_energy(q, p, dim: int):
    """Potential -M*phi of a moment turning the tangent at xi; phi measured from the reference t0.

    2D: phi the signed planar angle; the energy has a branch cut at phi = +-pi (2*pi*M jump), its gradient and
    Hessian are smooth through it. 3D: phi = n . theta, theta = alpha u the rotation vector of the shortest rotation
    turning t0 into t (alpha the angle between them): the planar angle for tangents in the plane normal to n, and
    less for an arc turned about t0 out of that plane (phi = alpha cos(beta)), so planar arcs stay stable up to 180
    degrees (the angle of the tangent's projection on that plane grew with such a turn past 90 degrees: every planar
    arc past 90 degrees was a saddle). Singular at alpha = 180 degrees, where the rotation axis is undefined.
    """
    L, xi, M = p[0], p[1], p[2]
    t = slope(q, L, xi, dim)
    if dim == 2:
        t0 = p[3:5]
        phi = planar_angle(t0[0], t0[1], t[0], t[1])
    else:
        n, t0 = p[3:6], p[6:9]
        n = n / ca.norm_2(n)
        scale = ca.norm_2(t0) * ca.norm_2(t)
        c = ca.dot(t0, t) / scale  # cos(alpha)
        phi = ca.dot(n, ca.cross(t0, t)) / scale * _angle_over_sine(c)  # sin(alpha) (n . u) * alpha / sin(alpha)
    return -M * phi


def mass_matrix(p, dim: int):
    """M = rhoA int S^T S dx; the products of cubics are integrated exactly by 4 Gauss points."""
    L, rhoA = p[0], p[1]
    xs, ws = gauss01(4)
    M = ca.SX.zeros(4 * dim, 4 * dim)
    eye = ca.SX.eye(dim)
    for x, w in zip(xs, ws):
        h = hermite.h(x)
        S = ca.horzcat(*[hk * (L if k in (1, 3) else 1) * eye for k, hk in enumerate(h)])
        M += w * L * rhoA * ca.mtimes(S.T, S)
    return M
