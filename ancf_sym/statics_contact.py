"""Statics with exact frictionless contact: IPOPT with the contact rows as inequality constraints.

The contact rows g(x) >= 0 (ancf_sym.contact_exact: ground rows n.r(xi_k) - level - t, linear; drum rows
|r(xi_k) - c|_perp - R - t from the compiled gap kernels, with their exact Jacobian and Hessians) join the equality
rows of supports and joints. Newton's full steps know equalities only, so a scene with exact contact is solved by
IPOPT alone (full steps first, then its line search); the contact forces are IPOPT's multipliers
(result.constraint_forces["contact"], one per contact point in the order of contact_exact.rows, >= 0 [N]) and so
are the supports' reactions. The stability check is skipped (stable = None): the reduced Hessian would have to be
taken on the active contact set.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from . import contact_exact
from .interrupts import interruptible

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def _nlp(asm, blocks):
    x, load = ca.MX.sym("x", asm.n), ca.MX.sym("load_factor")
    f, grad, hess, g = asm.casadi_parts(x, load)
    m = g.shape[0]
    mc = sum(r.m for r in blocks)
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", m + mc)
    gc, lb, Jc, Hc = contact_exact.casadi_rows(asm, blocks, x, lam_g[m:])
    g_all = ca.vertcat(g, gc)
    hl = lam_f * hess + Hc
    if m and len(asm.exact.qrow):
        hl += ca.triu(ca.hessian(ca.dot(lam_g[:m], g), x)[0])
    grad_f = ca.Function("nlp_grad_f", [x, load], [f, grad], ["x", "p"], ["f", "grad_f_x"])
    # the constraint Jacobian given, not differentiated: the gap kernels are compiled (no AD through them)
    jac = ca.vertcat(ca.jacobian(g, x), Jc) if m else Jc
    jac_g = ca.Function("nlp_jac_g", [x, load], [g_all, jac], ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function("nlp_hess_l", [x, load, lam_f, lam_g], [hl], ["x", "p", "lam_f", "lam_g"],
                           ["triu_hess_gamma_x_x"])
    return {"x": x, "p": load, "f": f, "g": g_all}, grad_f, jac_g, hess_lag, lb


def solve(problem, x: np.ndarray, opts, t0: float):
    """StaticResult of StaticProblem `problem` with exact contact rows, from x."""
    a = problem.asm
    blocks = contact_exact.rows(a)
    nlp, grad_f, jac_g, hess_lag, lb = _nlp(a, blocks)
    m, mc = a.exact.m, len(lb)
    lbg, ubg = np.r_[np.zeros(m), lb], np.r_[np.zeros(m), np.full(mc, np.inf)]
    attempts, iters, ok, status, lam_g = [], 0, False, "not run", None
    if problem._nlp is None:
        problem._build_nlp()
    tol = max(2.0 * problem.floor, 1e-14)  # the gradient's round-off floor (absolute, as the statics' IPOPT)
    for line_search in (False, True):
        ipopt = {"tol": tol, "dual_inf_tol": tol, "acceptable_tol": 10 * tol, "acceptable_dual_inf_tol": 10 * tol,
                 "acceptable_iter": 3, "max_iter": int(opts.max_iter), "constr_viol_tol": 1e-10,
                 "nlp_scaling_method": "none", "print_level": opts.print_level, "sb": "yes"}
        if not line_search:
            ipopt["accept_every_trial_step"] = "yes"
        with interruptible() as rec:  # Ctrl-C / SIGTERM inside IPOPT (or its build) stop the solve, not this attempt
            S = ca.nlpsol("statics_contact", "ipopt", nlp, {"ipopt": ipopt, "print_time": False, "grad_f": grad_f,
                                                             "jac_g": jac_g, "hess_lag": hess_lag, "error_on_fail": False})
            if rec.exc is None:
                sol = S(x0=x, p=1.0, lbg=lbg, ubg=ubg)
        st = S.stats()
        status, it = st["return_status"], int(st["iter_count"])
        iters += it
        attempts.append({"method": "ipopt with contact rows, " + ("line search" if line_search else "full steps"),
                         "status": status, "iterations": it})
        xs = np.asarray(sol["x"]).ravel()
        if status in SUCCESS and np.all(np.isfinite(xs)):
            ok, x, lam_g = True, xs, np.asarray(sol["lam_g"]).ravel()
            break
    res = problem._result(ok, status if ok or status != "Solve_Succeeded" else "Unresolved", iters,
                          time.perf_counter() - t0, x, None, attempts, "ipopt contact" if ok else "", None)
    if ok:  # reactions from IPOPT's multipliers (the gradient alone no longer balances the supports)
        forces = {k: v for k, v in res.constraint_forces.items() if k not in set(a.exact.labels)}
        for lbl, v in zip(a.exact.labels, lam_g[:m]):
            forces.setdefault(lbl, []).append(float(v))
        forces["contact"] = np.maximum(-lam_g[m:], 0.0).tolist()  # an active lower bound has a negative multiplier
        res.constraint_forces = forces
    res.constraint_violation = max(res.constraint_violation,
                                   float(np.max(-contact_exact.gaps(a, res.x, blocks), initial=0.0)))
    return res
