"""Exact (unilateral) contacts in the linear model: the points in contact at the equilibrium are equality rows there.

IPOPT's answer holds every point's force f_i and gap g_i at f_i g_i = mu (its last barrier parameter, ~1e-8): no
point has exactly zero force or gap. A point is active (in contact, held for small motions: its gap row g_i(x) = 0
joins the constraints) where its gap is the smaller of the two relative to their scales, g_i / L < f_i / F (L the
structure's length scale, F the largest contact force or reaction: where nothing touches, the barrier-level contact
forces are not measured against themselves); the others lift off freely (a point touching with zero force counts as
free: the linear model cannot hold a one-sided constraint). The rows' curvature enters the Hessian of the Lagrangian with the
statics' sign: min Pi subject to g >= 0 has L = Pi - sum f_i g_i, so K_L gets -sum f_i Hess g_i (drum rows; ground
rows are linear). The rows and their derivatives are the statics' own (ancf_sym.contact.exact.casadi_rows: the gap
kernels).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import exact as contact_exact
from ancf_sym.scene.builder import SceneError
from ancf_sym.statics.problem import StaticResult


def exact_multipliers(asm, result: StaticResult) -> np.ndarray:
    """The multipliers of every exact support/joint row, in asm.exact's order, from a contact statics result (the
    gradient alone no longer balances the supports where contact forces act)."""
    forces = result.constraint_forces
    taken: dict[str, int] = {}
    out = []
    for lbl in asm.exact.labels:
        k = taken.get(lbl, 0)
        out.append(float(forces[lbl][k]))
        taken[lbl] = k + 1
    return np.asarray(out)


def force_scale(result: StaticResult) -> float:
    """The force the contact forces are measured against: the largest contact force or support / joint reaction
    component (where nothing touches, the contact forces are all at IPOPT's barrier level, ~1e-10 N, and measured
    against their own largest one each would look held)."""
    return max([float(np.max(np.abs(v), initial=0.0)) for v in result.constraint_forces.values()] + [1e-300])


def contact_points(asm, result: StaticResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(contact forces [N], gaps [m], active) of every exact-contact point, in row order: active where the gap
    relative to the length scale is below the force relative to force_scale."""
    f = np.asarray(result.constraint_forces["contact"], float)
    g = contact_exact.gaps(asm, result.x, contact_exact.rows(asm))
    return f, g, g / asm.mesh.length_scale < f / force_scale(result)


def active_rows(asm, result: StaticResult) -> tuple[sp.csr_matrix, sp.csc_matrix, np.ndarray]:
    """(Jacobian of the active gap rows (k x n), their curvature -sum f_i Hess g_i (n x n), the active forces)."""
    if not isinstance(result, StaticResult) or not result.success:
        raise SceneError("linearize: a scene with exact contact needs its static result (a successful StaticResult: "
                         "the contact forces say which points are held), not a coordinate vector")
    blocks = contact_exact.rows(asm)
    f, _, active = contact_points(asm, result)
    x, lam = ca.MX.sym("x", asm.n), ca.MX.sym("lam", len(f))
    _, _, J, H_up = contact_exact.casadi_rows(asm, blocks, x, lam)
    fun = ca.Function("contact_rows", [x, lam], [J, H_up])
    Jv, Hv = fun(result.x, -f)  # (IPOPT's multipliers of the lower bounds: -f)
    J = sp.csr_matrix(Jv.sparse())[np.flatnonzero(active)]
    Hu = sp.csc_matrix(Hv.sparse())
    H = (Hu + Hu.T - sp.diags(Hu.diagonal())).tocsc()
    return J, H, f[active]
