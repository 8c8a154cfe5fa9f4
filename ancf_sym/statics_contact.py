"""Statics with exact frictionless contact: IPOPT with the contact rows as inequality constraints.

The contact rows n.r(xi_k) - level - t >= 0 (ancf_sym.contact.unilateral, linear in x: no Hessian term) join the
equality rows of supports and joints. Newton's full steps know equalities only, so a scene with exact contact is
solved by IPOPT alone (full steps first, then its line search); the contact forces are IPOPT's multipliers
(result.constraint_forces["contact"], one per contact point, >= 0 [N]) and so are the supports' reactions. The
stability check is skipped (stable = None): the reduced Hessian would have to be taken on the active contact set.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from . import contact
from .interrupts import interruptible

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def _nlp(asm, rows):
    x, load = ca.MX.sym("x", asm.n), ca.MX.sym("load_factor")
    f, grad, hess, g = asm.casadi_parts(x, load)
    A, b, _ = rows
    Ac = A.tocsc()
    Ac.sort_indices()
    Adm = ca.DM(ca.Sparsity(Ac.shape[0], Ac.shape[1], Ac.indptr.tolist(), Ac.indices.tolist()), Ac.data)
    m = g.shape[0]
    g_all = ca.vertcat(g, ca.mtimes(Adm, x))
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g_all.shape[0])
    hl = lam_f * hess
    if m and len(asm.exact.qrow):
        hl += ca.triu(ca.hessian(ca.dot(lam_g[:m], g), x)[0])
    grad_f = ca.Function("nlp_grad_f", [x, load], [f, grad], ["x", "p"], ["f", "grad_f_x"])
    hess_lag = ca.Function("nlp_hess_l", [x, load, lam_f, lam_g], [hl], ["x", "p", "lam_f", "lam_g"],
                           ["triu_hess_gamma_x_x"])
    return {"x": x, "p": load, "f": f, "g": g_all}, grad_f, hess_lag


def solve(problem, x: np.ndarray, opts, t0: float):
    """StaticResult of StaticProblem `problem` with exact contact rows, from x."""
    a = problem.asm
    rows = contact.unilateral(a)
    nlp, grad_f, hess_lag = _nlp(a, rows)
    m, mc = a.exact.m, len(rows[1])
    lbg, ubg = np.r_[np.zeros(m), rows[1]], np.r_[np.zeros(m), np.full(mc, np.inf)]
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
                                                             "hess_lag": hess_lag, "error_on_fail": False})
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
    res.constraint_violation = max(res.constraint_violation, float(np.max(rows[1] - rows[0] @ res.x, initial=0.0)))
    return res
