"""Contact of a member's centre line with the ground (half-space) and with circles / cylinders: one normal energy
and one dissipation function per obstacle, as densities per unit reference length of fields linear in the inputs.

Gap of a centre-line point r with a section of half thickness t:
- ground {n.r >= d} (unit normal n):            g = n.r - d - t
- circle (2D) / cylinder of axis a (3D), centre c: g = |r - c|_perp - R - t  (perp: normal to a; the member is
  outside the drum. A point on the drum's axis is not a contact state: |r - c|_perp = 0 only after a failed run.)
Penetration delta = max(0, -g). Normal energy (both laws in one density; a scene sets the other stiffness to 0):

    e = k/2 delta^2 + 2/5 k_h delta^(5/2),    normal force f_n = k delta + k_h delta^(3/2)

(k: linear penalty per unit length [N/m^2]; k_h: Hertz-type [N/m^2.5 per m]). delta^(5/2) is C2 at delta = 0: its
Hessian 3/2 k_h delta^(1/2) is continuous, so Newton sees no jump when a point touches down; the linear law's Hessian
jumps by k (C1 energy).

Damping and friction depend on the velocity: they are written as a dissipation function D(q, v) whose v-gradient is
the generalized force (f = dD/dv) and whose Hessian blocks d2D/dv dq, d2D/dv2 are the force's exact tangents:

    D = 1/2 c delta (n.w)^2 + mu f_n (sqrt(|w_t|^2 + eps^2) - eps)

w: the point's velocity relative to the obstacle's material point at the same place (ground: v; drum: v - c' -
omega a x (r - c)), w_t its part tangent to the surface. The damping force c delta (n.w) grows from zero with the
penetration (no jump at touch-down, the chatter of on/off damping), and the friction force mu f_n w_t /
sqrt(|w_t|^2 + eps^2) is Coulomb's law regularised by the velocity eps: viscous (slope mu f_n / eps) while
|w_t| << eps, mu f_n while sliding. D >= 0 and the dissipated power f.v >= 0.
"""
from __future__ import annotations

import casadi as ca


def penetration(gap):
    return ca.fmax(0, -gap)


def normal_energy(delta, k, kh):
    """Energy density of the normal law: k/2 delta^2 + 2/5 kh delta^2.5 (constant power: its derivative is
    5/2 delta^1.5 and its second 15/4 delta^0.5, finite at delta = 0). The power is taken of a stand-in 1 where
    delta = 0 (as in normal_force): its third derivative 15/8 delta^-1/2, which the parameter-direction companions
    (the Hessian's derivative) contain, would otherwise give NaN at every point out of contact (0 times inf)."""
    touching = delta > 0
    return k / 2 * delta**2 + 0.4 * kh * ca.if_else(touching, ca.if_else(touching, delta, 1) ** 2.5, 0)


def normal_force(delta, k, kh):
    """k delta + kh delta^1.5. Its second derivative 3/4 kh delta^-1/2 enters the dissipation's Hessian (the q-q
    block, which no solver uses) and is infinite at delta = 0: the power is taken of a stand-in 1 where delta = 0,
    so every output stays finite (a product with an infinite partial would give NaN even where it is multiplied
    by zero)."""
    touching = delta > 0
    return k * delta + kh * ca.if_else(touching, ca.if_else(touching, delta, 1) ** 1.5, 0)


def ground_gap(r, n, d, t):
    return ca.dot(n, r) - d - t


def ground_energy(r, p, dim: int):
    """p = (L, k, kh, t, n (dim), d)."""
    k, kh, t, n, d = p[1], p[2], p[3], p[4:4 + dim], p[4 + dim]
    return normal_energy(penetration(ground_gap(r, n, d, t)), k, kh)


def dissipation(delta, n, w, k, kh, c, mu, eps):
    """Damping + regularised Coulomb friction dissipation function of a point with penetration delta, outward
    unit normal n and velocity w relative to the obstacle surface."""
    wn = ca.dot(n, w)
    wt = w - wn * n
    slip = ca.sqrt(ca.dot(wt, wt) + eps**2) - eps
    return 0.5 * c * delta * wn**2 + mu * normal_force(delta, k, kh) * slip


def ground_dissipation(r, v, p, dim: int):
    """p = (L, k, kh, t, n (dim), d, c, mu, eps)."""
    k, kh, t, n, d = p[1], p[2], p[3], p[4:4 + dim], p[4 + dim]
    c, mu, eps = p[5 + dim], p[6 + dim], p[7 + dim]
    delta = penetration(ground_gap(r, n, d, t))
    return dissipation(delta, n, v, k, kh, c, mu, eps)


def _radial(d, p, dim: int):
    """The part of d = r - c normal to the drum axis (2D: d itself; 3D: axis a = p[5:8], unit)."""
    if dim == 2:
        return d
    a = p[5:8]
    return d - ca.dot(a, d) * a


def circle_energy(d, p, dim: int):
    """d = r - c; p = (L, k, kh, t, R[, ax, ay, az])."""
    k, kh, t, R = p[1], p[2], p[3], p[4]
    dp = _radial(d, p, dim)
    return normal_energy(penetration(ca.sqrt(ca.dot(dp, dp)) - R - t), k, kh)


def circle_dissipation(d, w, omega, p, dim: int):
    """d = r - c, w = r' - c', omega: the drum's angular velocity about its axis (2D: about z);
    p = (L, k, kh, t, R[, ax, ay, az], c, mu, eps)."""
    k, kh, t, R = p[1], p[2], p[3], p[4]
    o = 5 if dim == 2 else 8
    c, mu, eps = p[o], p[o + 1], p[o + 2]
    dp = _radial(d, p, dim)
    rho = ca.sqrt(ca.dot(dp, dp))
    n = dp / rho
    spin = omega * ca.vertcat(-d[1], d[0]) if dim == 2 else omega * ca.cross(p[5:8], d)
    return dissipation(penetration(rho - R - t), n, w - spin, k, kh, c, mu, eps)


def _body_drum_geometry(x, E, p, first: int = 5):
    """Radial part of the point x = r - r_b (relative to the body's centre) from the axis of a drum carried by a
    spatial body of axis vectors E = (e1, e2, e3): axis a = sum a_k e_k, through the body point sum s_k e_k
    (p = (..., a1, a2, a3, ..., s1, s2, s3): a from p[first], s last, both in body components). Linear in (x, E)
    before the projection, so the fields stay linear in the kernel's inputs."""
    a = p[first] * E[0] + p[first + 1] * E[1] + p[first + 2] * E[2]
    d = x - (p[-3] * E[0] + p[-2] * E[1] + p[-1] * E[2])
    return d - ca.dot(a, d) * a


# -- exact contact in statics: the gap of one point as a constraint g >= 0 (no law, no stiffness) ----------------

def circle_gap(d, p, dim: int):
    """Gap |d|_perp - R - t of a point d = r - c outside a drum; p = (L, xi, t, R[, ax, ay, az])."""
    dp = d if dim == 2 else d - ca.dot(p[4:7], d) * p[4:7]
    return ca.sqrt(ca.dot(dp, dp)) - p[3] - p[2]


def body_drum_gap(u, p):
    """Gap of a point outside a spatial body's drum, u = (r - r_b, e1, e2, e3);
    p = (L, xi, t, R, a (3), s (3)), a and s in body components."""
    dp = _body_drum_geometry(u[:3], (u[3:6], u[6:9], u[9:12]), p, first=4)
    return ca.sqrt(ca.dot(dp, dp)) - p[3] - p[2]


def body_drum_energy(u, p):
    """u = (r - r_b, e1, e2, e3): a centre-line point relative to the centre r_b of a spatial body (natural
    coordinates, ancf_sym.bodies.spatial) and its axis vectors; p = (L, k, kh, t, R, a (3), s (3))."""
    k, kh, t, R = p[1], p[2], p[3], p[4]
    dp = _body_drum_geometry(u[:3], (u[3:6], u[6:9], u[9:12]), p)
    return normal_energy(penetration(ca.sqrt(ca.dot(dp, dp)) - R - t), k, kh)


def body_drum_dissipation(u, p):
    """u = (r - r_b, e1, e2, e3, r' - r_b', e1', e2', e3'); p = (L, k, kh, t, R, a (3), c, mu, eps, s (3)). The
    drum's material point at x = r - r_b moves at r_b' + sum_k (e_k . x) e_k' (exact while the axes are orthonormal:
    e_k . x are the point's body coordinates), so w = x' - sum_k (e_k . x) e_k' is the velocity relative to the drum
    surface, the body's spin and tumbling included."""
    k, kh, t, R = p[1], p[2], p[3], p[4]
    c, mu, eps = p[8], p[9], p[10]
    x, E, Ed = u[:3], (u[3:6], u[6:9], u[9:12]), (u[15:18], u[18:21], u[21:24])
    dp = _body_drum_geometry(x, E, p)
    rho = ca.sqrt(ca.dot(dp, dp))
    w = u[12:15] - sum((ca.dot(e, x) * ed for e, ed in zip(E, Ed)), ca.SX.zeros(3))
    return dissipation(penetration(rho - R - t), dp / rho, w, k, kh, c, mu, eps)
