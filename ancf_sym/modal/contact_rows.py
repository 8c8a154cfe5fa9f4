"""Exact (unilateral) contacts in the linear model: the points in contact at the equilibrium are equality rows there.

IPOPT's answer holds every point's force f_i and gap g_i at f_i g_i = mu (its last barrier parameter, ~1e-8): no
point has exactly zero force or gap. A point is active (in contact, held for small motions: its gap row g_i(x) = 0
joins the constraints) where its gap is the smaller of the two relative to their scales, g_i / L < f_i / f_max (L
the structure's length scale); the others lift off freely (a point touching with zero force counts as free: the
linear model cannot hold a one-sided constraint). The rows' curvature enters the Hessian of the Lagrangian with the
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


def active_rows(asm, result: StaticResult) -> tuple[sp.csr_matrix, sp.csc_matrix, np.ndarray]:
    """(Jacobian of the active gap rows (k x n), their curvature -sum f_i Hess g_i (n x n), the active forces)."""
    if not isinstance(result, StaticResult) or not result.success:
        raise SceneError("linearize: a scene with exact contact needs its static result (a successful StaticResult: "
                         "the contact forces say which points are held), not a coordinate vector")
    f = np.asarray(result.constraint_forces["contact"], float)
    blocks = contact_exact.rows(asm)
    g = contact_exact.gaps(asm, result.x, blocks)
    active = g / asm.mesh.length_scale < f / max(float(f.max(initial=0.0)), 1e-300)
    x, lam = ca.MX.sym("x", asm.n), ca.MX.sym("lam", len(f))
    _, _, J, H_up = contact_exact.casadi_rows(asm, blocks, x, lam)
    fun = ca.Function("contact_rows", [x, lam], [J, H_up])
    Jv, Hv = fun(result.x, -f)  # (IPOPT's multipliers of the lower bounds: -f)
    J = sp.csr_matrix(Jv.sparse())[np.flatnonzero(active)]
    Hu = sp.csc_matrix(Hv.sparse())
    H = (Hu + Hu.T - sp.diags(Hu.diagonal())).tocsc()
    return J, H, f[active]
