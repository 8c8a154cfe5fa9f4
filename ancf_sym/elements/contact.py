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
    5/2 delta^1.5 and its second 15/4 delta^0.5, finite at delta = 0)."""
    return k / 2 * delta**2 + 0.4 * kh * delta**2.5


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
