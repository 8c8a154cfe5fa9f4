"""Statics with exact frictionless contact: IPOPT with the contact rows as inequality constraints, then the
second-order check on the active set. User guide: docs/contact.md (Statics with exact contact).

The contact rows g(x) >= 0 (ancf_sym.contact.exact: ground rows n.r(xi_k) - level - t, linear; drum rows
|r(xi_k) - c|_perp - R - t from the compiled gap kernels, with their exact Jacobian and Hessians) join the equality
rows of supports and joints. Newton's full steps know equalities only, so a scene with exact contact is solved by
IPOPT; the contact forces are IPOPT's multipliers (result.constraint_forces["contact"], one per contact point in the
order of contact.exact.rows, >= 0 [N]) and so are the supports' reactions.

1. Start. Members with exact contact of more than HALVE_ABOVE elements together: the scene with them meshed twice
   coarser is solved first (recursively, down to HALVE_ABOVE), and IPOPT starts from its solution interpolated onto this mesh, with
   its multipliers (a point's force halved onto the two elements that split its element) and a barrier parameter
   at the size of the start's complementarity (WARM_MU) instead of IPOPT's 0.1: measured on a slack rope on the
   ground (EA 1e7 N, 5 N/m, 12 m between pins 10 m apart), mu = 0.1 means 1 m of slack at forces of 0.1 N per
   point, the first step threw the warm start 0.37 m off and IPOPT never came back (500 iterations at 128
   elements); from the coarse solution with WARM_MU, 13 - 55 iterations per mesh at 64 - 512 elements
   (bench/exact_contact_refinement.py). Else (or if that fails) IPOPT from the given start: full steps, then its
   line search.
2. Second-order check (stability): the reduced Hessian of the Lagrangian (the kernels' Hessian plus the drum rows'
   curvature and the joints' times their multipliers: IPOPT's own hess_lag) on the tangent space of the equality
   rows and of the strongly active contact rows (force above the complementarity scale, see _active) must be
   positive definite, and no contact force may pull. The rows may be dependent (five points on an element's four
   transverse coordinates), so the inertia count uses their rank (inertia.reduced_inertia with rank_tol); a banded
   Cholesky of H + rho J^T J settles the usual stable case in O(n). A stationary point that fails is left along its
   direction of negative curvature (IPOPT from there), the lower stable point kept; none found: not a success.
3. Continuation check: the answer's potential may not lie above the coarse mesh's answer (COARSE_MARGIN): the fine
   space holds every coarse shape, so a higher fine answer is another, worse stationary point. Then the next start
   is tried (IPOPT from the given start); if none gives a stable answer at or below the coarse one, the solve fails
   with status Coarser_Mesh_Lower_Potential and the potentials in its attempts.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.contact import exact as contact_exact
from ancf_sym.statics import coarse as statics_coarse
from ancf_sym.statics.inertia import STABILITY_EPS, banded_cholesky, reduced_inertia
from ancf_sym.util.interrupts import interruptible

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
HALVE_ABOVE = 48  # elements of the contact members (together) above which the twice coarser mesh is the start
HALVE_MIN = 4  # elements a halved member keeps at least
WARM_MU = 1e-10  # IPOPT's initial barrier parameter from a coarse start, relative to the load work W [J]
RANK_TOL = 1e-9  # dependent contact rows: eigenvalues of J H^-1 J^T below this (relative) are their round-off
COARSE_MARGIN = 1e-6  # relative to W: a fine answer above the coarse one by more is a worse stationary point


@dataclass
class _Nlp:
    """IPOPT's problem with the contact rows (built once per StaticProblem)."""
    blocks: list
    nlp: dict
    grad_f: ca.Function
    jac_g: ca.Function
    hess_lag: ca.Function
    lb: np.ndarray
    m: int  # equality rows (supports, joints)
    solvers: dict = field(default_factory=dict)

    @property
    def mc(self) -> int:
        return len(self.lb)


def _build(asm) -> _Nlp:
    blocks = contact_exact.rows(asm)
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
    return _Nlp(blocks, {"x": x, "p": load, "f": f, "g": g_all}, grad_f, jac_g, hess_lag, lb, m)


def _parts(problem) -> _Nlp:
    if problem.contact_nlp is None:
        problem.contact_nlp = _build(problem.asm)
        if problem.nlp is None:
            problem.build_nlp()  # (the gradient's round-off floor)
    return problem.contact_nlp


def _ipopt(problem, P: _Nlp, x, lam_g, opts, line_search: bool, mu: float | None):
    """One IPOPT run from x (multipliers lam_g and initial barrier mu: a warm start). (ok, status, its, x, lam_g)."""
    key = (line_search, mu, opts.max_iter, opts.print_level)
    if key not in P.solvers:
        tol = max(2.0 * problem.floor, 1e-14)  # the gradient's round-off floor (absolute, as the statics' IPOPT)
        ipopt = {"tol": tol, "dual_inf_tol": tol, "acceptable_tol": 10 * tol, "acceptable_dual_inf_tol": 10 * tol,
                 "acceptable_iter": 3, "max_iter": int(opts.max_iter), "constr_viol_tol": 1e-10,
                 "nlp_scaling_method": "none", "print_level": opts.print_level, "sb": "yes"}
        if not line_search:
            ipopt["accept_every_trial_step"] = "yes"
        if mu is not None:  # start at the given point and multipliers, not pushed into the interior
            ipopt.update({"mu_init": mu, "warm_start_init_point": "yes", "warm_start_bound_push": 1e-12,
                          "warm_start_mult_bound_push": 1e-12, "warm_start_slack_bound_push": 1e-12})
        P.solvers[key] = ipopt
    m, mc = P.m, P.mc
    args = {"x0": x, "p": 1.0, "lbg": np.r_[np.zeros(m), P.lb], "ubg": np.r_[np.zeros(m), np.full(mc, np.inf)]}
    if lam_g is not None:
        args["lam_g0"] = lam_g
    with interruptible() as rec:  # Ctrl-C / SIGTERM inside IPOPT (or its build) stop the solve, not this attempt
        if isinstance(P.solvers[key], dict):  # built once per (options) and kept
            P.solvers[key] = ca.nlpsol("statics_contact", "ipopt", P.nlp, {
                "ipopt": P.solvers[key], "print_time": False, "grad_f": P.grad_f, "jac_g": P.jac_g,
                "hess_lag": P.hess_lag, "error_on_fail": False})
        S = P.solvers[key]
        if rec.exc is None:
            sol = S(**args)
    st = S.stats()
    if st["return_status"] in ("User_Requested_Stop", "User_Interrupt"):  # Ctrl-C inside IPOPT: stop the solve
        raise KeyboardInterrupt
    xs = np.asarray(sol["x"]).ravel()
    ok = st["return_status"] in SUCCESS and bool(np.all(np.isfinite(xs)))
    return ok, st["return_status"], int(st["iter_count"]), xs, np.asarray(sol["lam_g"]).ravel()


def _force_scale(problem, lam_g: np.ndarray) -> float:
    """F [N]: the load work over the length, or the largest multiplier (a prestressed scene without loads)."""
    return max(problem.work / problem.asm.mesh.length_scale, float(np.max(np.abs(lam_g), initial=0.0)), 1e-300)


def _active(problem, gap: np.ndarray, force: np.ndarray, F: float) -> np.ndarray:
    """Strongly active contact rows: force / F above gap / L (L the structure's length), i.e. the point's
    complementarity leans to contact. IPOPT's interior point leaves forces ~ mu / gap on free points (1e-9 .. 1e-5 N
    measured) and gaps of ~1e-9 m on loaded ones (forces ~0.1 N): they separate by orders."""
    L = problem.asm.mesh.length_scale
    return (force > 0) & (force / F > np.maximum(gap, 0.0) / L)


def stability(problem, x: np.ndarray, lam_g: np.ndarray) -> tuple[bool | None, np.ndarray | None, str]:
    """Second-order conditions at a KKT point of the contact problem (x, IPOPT's multipliers lam_g): no pulling
    contact force, and the Hessian of the Lagrangian positive definite on the tangent space of the equality rows and
    the strongly active contact rows. (stable, direction of negative curvature (max-norm 1) or None, reason)."""
    P = _parts(problem)
    m = P.m
    g, J = P.jac_g(x, 1.0)
    gap = np.asarray(g).ravel()[m:] - P.lb
    force = -np.asarray(lam_g, float)[m:]  # an active lower bound has a negative multiplier
    F = _force_scale(problem, lam_g)
    act = _active(problem, gap, force, F)
    pulling = force < -1e-6 * F  # (interior point: >= 0 up to round-off)
    if np.any(pulling & (gap <= 1e-9 * problem.asm.mesh.length_scale)):
        k = int(np.argmin(force))
        return False, None, f"contact point {k} pulls with {force[k]:.3g} N (a minimum needs forces >= 0)"
    Hu = _scipy(P.hess_lag(x, 1.0, 1.0, lam_g))
    H = sp.csc_matrix(Hu + sp.triu(Hu, 1).T)
    Js = _scipy(J).tocsr()
    Ja = Js[np.r_[np.arange(m), m + np.flatnonzero(act)]]
    hmax = float(np.abs(H.diagonal()).max()) if H.nnz else 1.0
    sigma = STABILITY_EPS * hmax
    if Ja.shape[0]:
        jn = float(sp.linalg.norm(Ja, axis=1).max()) or 1.0
        Hr = sp.csc_matrix(H + (hmax / jn**2) * (Ja.T @ Ja))
    else:
        Hr = H
    # H + rho J^T J + sigma I positive definite: the reduced Hessian is (its quadratic form on the null space of J)
    if banded_cholesky(Hr, sigma) is not None:
        return True, None, ""
    inertia = reduced_inertia(H, Ja if Ja.shape[0] else None, rank_tol=RANK_TOL)
    if inertia.stable:
        return True, None, ""
    if inertia.stable is None:
        return None, None, "the inertia could not be read (the factorisation pivoted off the diagonal)"
    return False, inertia.direction, (f"{inertia.negative} direction(s) of negative curvature on the tangent space "
                                      f"of the supports and the {int(act.sum())} active contact points")


def _scipy(M) -> sp.csc_matrix:
    M = ca.DM(M)
    r, c = M.sparsity().get_triplet()
    return sp.csc_matrix((np.asarray(M.nonzeros(), float), (r, c)), shape=M.shape)


def _coarse_start(problem, opts):
    """(coarse result, x on this mesh, lam_g on this mesh) from the twice coarser mesh, or None."""
    if problem.contact_coarse is None:
        sc = problem.asm.scene
        members = {c.member for c in sc.contacts if c.method == "exact"}
        total = sum(sc.members[m].elements for m in members)
        # every contact member halved that stays at HALVE_MIN elements or more (a rope in three members joined by
        # hinges halves all three: halving only the long one left a 96-element coarse mesh that IPOPT could not
        # solve from the reference)
        long = {m for m in members if sc.members[m].elements >= 2 * HALVE_MIN} if total > HALVE_ABOVE else set()
        coarse = statics_coarse.coarsened(sc, long, 2) if long else None
        problem.contact_coarse = False
        if coarse is not None:
            from ancf_sym.scene.builder import SceneError

            try:  # a coarse mesh the scene's checks refuse (too coarse for a curve, say) is no start
                coarse.validate_for_statics()
                problem.contact_coarse = (problem.coarser(coarse), long)
            except SceneError:
                pass
    if problem.contact_coarse is False:
        return None
    cp, long = problem.contact_coarse
    rc = cp.solve(opts)
    if not rc.success:
        return rc, None, None
    a = problem.asm
    xf = statics_coarse.interpolate(cp.asm, rc.x, a)
    xf = problem.S.full(problem.S.reduce(xf))
    Pc, P = _parts(cp), _parts(problem)
    lam_c = rc.contact_multipliers
    out, i = [lam_c[:Pc.m]], Pc.m
    for rb in Pc.blocks:
        lb = lam_c[i:i + rb.m]
        i += rb.m
        if rb.contact.member in long:  # a coarse element's point force onto the two halves, each half of it
            lb = np.repeat(lb.reshape(-1, rb.contact.gauss), 2, axis=0).ravel() / 2
        out.append(lb)
    lam = np.concatenate(out)
    return rc, xf, (lam if lam.size == P.m + P.mc else None)


def solve(problem, x: np.ndarray, opts, t0: float, warm_given: bool = False):
    """StaticResult of StaticProblem `problem` with exact contact rows, from x (the reference, or the caller's warm
    start: warm_given)."""
    a = problem.asm
    P = _parts(problem)
    attempts, iters = [], 0
    work = max(problem.work, 1e-300)
    coarse = None if warm_given else _coarse_start(problem, opts)
    starts = []  # (label, x, lam_g, mu)
    if coarse is not None:
        rc = coarse[0]
        info = {"elements": {k: m.elements for k, m in problem.contact_coarse[0].asm.scene.members.items()},
                "status": rc.status, "iterations": rc.iterations, "stable": rc.stable}
        iters += rc.iterations
        if coarse[1] is not None:
            info["potential"] = rc.potential
            starts.append(("ipopt from the coarse mesh's solution", coarse[1], coarse[2], WARM_MU * work))
        attempts.append({"method": "coarse mesh", **info})
    starts += [("ipopt with contact rows, full steps", x, None, None),
               ("ipopt with contact rows, line search", x, None, None)]
    best, reasons = None, []
    for label, xs0, lg0, mu in starts:
        ok, status, it, xs, lg = _ipopt(problem, P, xs0, lg0, opts, label.endswith("full steps") is False, mu)
        iters += it
        attempts.append({"method": label, "status": status, "iterations": it})
        if not ok:
            continue
        cand, it2 = _settle(problem, P, xs, lg, opts, attempts)
        iters += it2
        if cand is None:
            reasons.append(attempts[-1].get("detail", "unstable"))
            continue
        if best is None or cand[2] < best[2]:
            best = cand
        if coarse is not None and coarse[1] is not None and best[2] > coarse[0].potential + COARSE_MARGIN * work:
            attempts[-1]["rejected"] = (f"potential {best[2]:.10g} J above the coarse mesh's "
                                        f"{coarse[0].potential:.10g} J")
            reasons.append(attempts[-1]["rejected"])
            continue
        break
    if best is not None and coarse is not None and coarse[1] is not None and \
            best[2] > coarse[0].potential + COARSE_MARGIN * work:
        best = None
    wall = time.perf_counter() - t0
    if best is None:
        status = "Unstable_Stationary_Point" if any("curvature" in r or "pulls" in r for r in reasons) else (
            "Coarser_Mesh_Lower_Potential" if reasons else (attempts[-1]["status"] if attempts else "not run"))
        if status == "Solve_Succeeded":
            status = "Unresolved"
        reasons = list(dict.fromkeys(reasons))
        if reasons:
            attempts.append({"method": "none", "status": status, "iterations": 0, "detail": "; ".join(reasons)})
        res = problem.make_result(False, status, iters, wall, x, None, attempts, "", None)
        res.constraint_violation = max(res.constraint_violation,
                                       float(np.max(-contact_exact.gaps(a, res.x, P.blocks), initial=0.0)))
        return res
    xs, lg, _ = best
    res = problem.make_result(True, "Solve_Succeeded", iters, wall, xs, True, attempts, "ipopt contact", None)
    res.contact_multipliers = lg
    forces = {k: v for k, v in res.constraint_forces.items() if k not in set(a.exact.labels)}
    for lbl, v in zip(a.exact.labels, lg[:P.m]):  # reactions from IPOPT's multipliers
        forces.setdefault(lbl, []).append(float(v))
    forces["contact"] = np.maximum(-lg[P.m:], 0.0).tolist()  # an active lower bound has a negative multiplier
    res.constraint_forces = forces
    res.constraint_violation = max(res.constraint_violation,
                                   float(np.max(-contact_exact.gaps(a, res.x, P.blocks), initial=0.0)))
    return res


def _settle(problem, P: _Nlp, x, lam_g, opts, attempts):
    """The second-order check at IPOPT's point; an unstable one is left along its negative curvature (both senses,
    growing nudges), IPOPT (line search) from there, and the first stable point of lower potential kept.
    ((x, lam_g, potential) or None, iterations)."""
    a = problem.asm
    stable, d, why = stability(problem, x, lam_g)
    e0 = a.energy(x)
    attempts[-1]["stable"] = stable
    if stable:
        return (x, lam_g, e0), 0
    attempts[-1]["detail"] = why
    its = 0
    if d is None or not opts.escape_saddle:
        return None, 0
    L = a.mesh.length_scale
    d = d * np.sign(d[np.argmax(np.abs(d))])  # an eigenvector's sign is arbitrary: its largest entry positive, so
    # equal problems (a drum fixed or on a held body) leave the same saddle for the same branch
    for scale in (1e-3, 1e-2, 1e-1):
        for sign in (1.0, -1.0):  # (IPOPT's own barrier start: measured, a warm one found no twisted beam3d branch)
            ok, st, it, xs, lg = _ipopt(problem, P, x + sign * scale * L * d, None, opts, True, None)
            its += it
            entry = {"method": f"leave saddle ({sign * scale:g} L, line search)", "status": st, "iterations": it}
            attempts.append(entry)
            if ok and a.energy(xs) < e0 - 1e-12 * abs(e0):
                s2, _, why2 = stability(problem, xs, lg)
                entry["stable"] = s2
                if s2:
                    return (xs, lg, a.energy(xs)), its
                entry["detail"] = why2
    attempts.append({"method": "none", "status": "Unstable_Stationary_Point", "iterations": 0,
                     "detail": why + "; no stable point of lower potential found along it"})
    return None, its
