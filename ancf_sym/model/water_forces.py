"""The water's forces at the wet points as CasADi expressions of the full coordinates X and velocities V (exact
derivatives by AD of one vectorized graph, as the strain-rate damping):
- the water line: the weight of the displaced water that a member above the still water line does not displace
  (the gravity term already carries the buoyancy of a fully submerged member), a potential;
- Morison drag on the relative velocity, normal and tangential (MoorDyn's convention), not conservative;
- the added mass's matrix, normal and tangential to the line;
- under waves (ancf_sym.model.waves), the drag on the velocity relative to current and waves together, and the fluid
  inertia force of the waves' acceleration (Froude-Krylov and added mass, normal and tangential, MoorDyn's
  convention)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ancf_sym.util.sparsity import dm
from ancf_sym.scene.water import Water
from ancf_sym.model.water_points import WetPoints

EPS_SPEED = 1e-4  # [m/s] |u| is sqrt(u.u + EPS^2): its derivative stays finite at zero relative speed; the force's
# relative change is EPS^2 / (2 u^2), below 1e-8 for the 1 cm/s and faster relative speeds drag matters at


def _col(v):
    """A per-point coefficient as a CasADi column: numbers as DM, an MX expression (a coefficient that depends on a
    parameter, ancf_sym.sensitivity.water_derivative) as it is."""
    return v if isinstance(v, (ca.MX, ca.SX)) else ca.DM(v)


def _mat(A):
    """A point map (B, Bx) as a CasADi matrix: sparse as DM, an MX (a map that depends on a parameter) as it is."""
    return A if isinstance(A, ca.MX) else dm(A)


def _tmat(A):
    """The transpose of a point map (the generalized force's B')."""
    return A.T if isinstance(A, ca.MX) else dm(A.T.tocsr())


def _split(Y: ca.MX, dim: int, P: int) -> list:
    return [Y[k * P:(k + 1) * P] for k in range(dim)]


def gravity_magnitude(scene) -> float:
    """|g| of a scene in water: gravity must point down the vertical axis (y in 2D, z in 3D) or be zero."""
    g = np.asarray(scene.gravity, float)
    if np.any(g[:-1] != 0) or g[-1] > 0:
        from ancf_sym.util.checks import fail

        raise fail("scene.gravity", "must point down the vertical axis (the last coordinate) in water", g.tolist())
    return float(-g[-1])


def _smooth_fill(xi: ca.MX) -> ca.MX:
    """Integral of the submerged fraction s(xi) = 3 xi^2 - 2 xi^3 of the section over the immersion xi in [0, 1]
    (0 dry, 1 submerged): xi^3 - xi^4 / 2, continued by 0 below and xi - 1/2 above (C2: s' = 0 at both ends)."""
    inside = xi ** 3 - 0.5 * xi ** 4
    return ca.if_else(xi <= 0, 0, ca.if_else(xi >= 1, xi - 0.5, inside))


def water_line_energy(wp: WetPoints, water: Water, g: float, X: ca.MX) -> ca.MX | None:
    """Potential [J] that corrects the gravity term's buoyancy (rho_w g A per length, everywhere) to rho_w g A s(xi)
    with xi = (surface - z + d/2) / d the section's immersion: rho_w g A (d P(xi) - (surface - z)), P = _smooth_fill.
    Zero where the section is under water (xi >= 1). None if no member has buoyancy."""
    if not wp.buoyant:
        return None
    P = wp.P
    z = ca.mtimes(_mat(wp.B[(wp.dim - 1) * P:wp.dim * P, :]), X)
    d = _col(wp.d)
    depth = water.surface - z
    xi = (depth + 0.5 * d) / d
    coef = _col(water.density * g * wp.area * wp.wL)
    return ca.dot(coef, d * _smooth_fill(xi) - depth)


def current_mx(water: Water, z: ca.MX, dim: int, scale) -> list:
    """Current velocity components at heights z (piecewise linear by height, constant outside), times scale."""
    c = water.current
    out = []
    for k in range(dim):
        if c is None:
            out.append(ca.MX.zeros(z.shape))
            continue
        u = float(c.u[0, k]) + 0 * z
        for j in range(len(c.z) - 1):  # u0 + sum of slope_j (clip(z, z_j, z_j+1) - z_j)
            slope = (c.u[j + 1, k] - c.u[j, k]) / (c.z[j + 1] - c.z[j])
            if slope:
                u = u + slope * (ca.fmin(ca.fmax(z, c.z[j]), c.z[j + 1]) - c.z[j])
        out.append(scale * u)
    return out


def point_positions(wp: WetPoints, X: ca.MX) -> list:
    """r at the wet points: dim columns of P."""
    return _split(ca.mtimes(_mat(wp.B), X), wp.dim, wp.P)


def drag_force(wp: WetPoints, water: Water, X: ca.MX, V: ca.MX | None, scale=1.0, flow: list | None = None) -> ca.MX:
    """Generalized Morison drag force [N] (full coordinates) on the relative velocity u_r = u_current (+ flow) - r_t:
    f = 1/2 rho_w (cd d |u_n| u_n + cd_axial pi d |u_t| u_t) per unit length, u_t = (u_r . t) t, u_n = u_r - u_t,
    t = r_x / |r_x|; integrated at the wet points (Q = B^T (w L f)). scale multiplies the current (statics'
    continuation); flow: the waves' velocity at the points (dim columns), or None."""
    dim, P = wp.dim, wp.P
    r = point_positions(wp, X)
    rx = _split(ca.mtimes(_mat(wp.Bx), X), dim, P)
    u = current_mx(water, r[-1], dim, scale)
    if flow is not None:
        u = [a + b for a, b in zip(u, flow)]
    if V is not None:
        v = _split(ca.mtimes(_mat(wp.B), V), dim, P)
        u = [a - b for a, b in zip(u, v)]
    n2 = sum(c * c for c in rx)
    ut_len = sum(a * b for a, b in zip(u, rx)) / ca.sqrt(n2)  # u_r . t
    t = [c / ca.sqrt(n2) for c in rx]
    ut = [ut_len * c for c in t]
    un = [a - b for a, b in zip(u, ut)]
    sp_n = ca.sqrt(sum(c * c for c in un) + EPS_SPEED ** 2)
    sp_t = ca.sqrt(ut_len * ut_len + EPS_SPEED ** 2)
    kn = _col(0.5 * water.density * wp.cd * wp.d * wp.wL)
    kt = _col(0.5 * water.density * wp.cd_axial * np.pi * wp.d * wp.wL)
    f = ca.vertcat(*[kn * sp_n * a + kt * sp_t * b for a, b in zip(un, ut)])
    return ca.mtimes(_tmat(wp.B), f)


def inertia_areas(wp: WetPoints) -> tuple[np.ndarray, np.ndarray]:
    """(A_b, A_m) per point [m^2]: the displaced area (0 where the member has no buoyancy) and the area the added
    mass is taken on (the displaced area, or pi d^2 / 4 of a member without buoyancy)."""
    return wp.area, wp.inertia_area


def fluid_inertia_force(wp: WetPoints, water: Water, X: ca.MX, acc: list) -> ca.MX:
    """Generalized force [N] (full coordinates) of the water's acceleration acc (dim columns at the wet points) on
    the line: Froude-Krylov (the undisturbed pressure gradient, rho_w A_b acc) and the added mass of the water
    accelerating past the line (rho_w A_m Ca on the normal part, CaAx on the tangential one), per unit length
    f = rho_w ((A_b + Ca A_m) a_n + (A_b + CaAx A_m) a_t), a_t = (acc . t) t, a_n = acc - a_t (MoorDyn's
    (1 + Can) and (1 + Cat) on the submerged volume); Q = B^T (w L f)."""
    dim, P = wp.dim, wp.P
    rx = _split(ca.mtimes(_mat(wp.Bx), X), dim, P)
    n2 = sum(c * c for c in rx)
    at_len = sum(a * b for a, b in zip(acc, rx)) / n2  # (acc . r_x) / |r_x|^2: a_t = at_len r_x
    ab, am = inertia_areas(wp)
    kn = _col(water.density * (ab + wp.ca * am) * wp.wL)
    kt = _col(water.density * (ab + wp.ca_axial * am) * wp.wL)
    f = ca.vertcat(*[kn * (a - at_len * c) + kt * at_len * c for a, c in zip(acc, rx)])
    return ca.mtimes(_tmat(wp.B), f)


def added_mass_matrix(wp: WetPoints, water: Water, x: np.ndarray):
    """The added mass [kg] on the full coordinates, B^T diag(rho_w A (ca (I - t t') + ca_axial t t') w L) B with
    the tangents t of state x (frozen there: the dynamics' mass matrix stays constant over a run)."""
    import scipy.sparse as sp

    dim, P = wp.dim, wp.P
    rx = (wp.Bx @ x).reshape(dim, P)
    t = rx / np.linalg.norm(rx, axis=0)
    a = water.density * inertia_areas(wp)[1] * wp.wL
    rows, cols, vals = [], [], []
    for i in range(dim):
        for j in range(dim):
            m = a * (wp.ca * ((i == j) - t[i] * t[j]) + wp.ca_axial * t[i] * t[j])
            rows.append(i * P + np.arange(P))
            cols.append(j * P + np.arange(P))
            vals.append(m)
    D = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(dim * P, dim * P))
    return (wp.B.T @ D @ wp.B).tocsc()


def added_mass_product(wp: WetPoints, water: Water, X: ca.MX, Acc: ca.MX) -> ca.MX:
    """The added mass of added_mass_matrix times Acc (full coordinates) in a graph of the state X: B' (w L rho_w A
    (ca (a - t (t . a)) + ca_axial t (t . a))), a = B Acc at the points, t the tangents of X (exact derivatives with
    respect to the state and, through symbolic coefficients, to a parameter: ancf_sym.sensitivity.water_derivative)."""
    dim, P = wp.dim, wp.P
    rx = _split(ca.mtimes(_mat(wp.Bx), X), dim, P)
    al = _split(ca.mtimes(_mat(wp.B), Acc), dim, P)
    n2 = sum(c * c for c in rx)
    ta = sum(a * c for a, c in zip(al, rx)) / n2  # (a . r_x) / |r_x|^2: (t . a) t = ta r_x
    k = _col(water.density * inertia_areas(wp)[1] * wp.wL)
    f = ca.vertcat(*[k * (wp.ca * (a - ta * c) + wp.ca_axial * ta * c) for a, c in zip(al, rx)])
    return ca.mtimes(_tmat(wp.B), f)
