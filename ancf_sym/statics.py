"""Static equilibrium: minimise the total potential with IPOPT (exact sparse Hessian from the kernels).

Strategy, from measurements (docs/statics.md): IPOPT's line search creeps along the narrow valley that a large EA/EI
makes, while full Newton steps converge in a few iterations. So the first attempt accepts every trial step
(IPOPT's inertia correction still keeps the steps descent directions); if it fails, IPOPT runs again with its
line search; if that fails, the loads are stepped up (continuation) from the last good point. Termination is
relative to the gradient's round-off floor, which grows with the element count. A stationary point with a
negative-curvature direction (e.g. a straight column past the Euler load) is left along that direction.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from . import fields
from .assembly import Assembly
from .checks import check_fields
from .interrupts import check_stop, interruptible
from .mesh import check_stretch
from .scene import Scene, SceneError
from .schema import STATIC_OPTIONS

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
RESOLVABLE = 0.1  # a round-off floor above this fraction of the largest applied force cannot resolve the loads
UNRESOLVED = 1e4  # largest residual / row round-off floor accepted after the Newton polish (measured <= 80 when right)
STABILITY_EPS = 100 * np.finfo(float).eps  # negative-curvature threshold, relative to the reduced Hessian's norm


@dataclass
class StaticOptions:
    tol: float | None = None  # IPOPT tol; default relative to the gradient round-off floor
    max_iter: int = 500
    load_steps: int = 8  # continuation steps if the direct solves fail
    escape_saddle: bool = True
    print_level: int = 0

    def __post_init__(self):
        check_fields(self, STATIC_OPTIONS, "analysis")  # types and ranges as declared in ancf_sym.schema


@dataclass
class StaticResult:
    status: str
    success: bool
    iterations: int
    wall_s: float
    x: np.ndarray
    energies: dict
    constraint_forces: dict  # label -> multipliers (exact constraints) or penalty forces
    constraint_violation: float
    stable: bool | None  # smallest eigenvalue of the reduced Hessian > 0 (None if not checked)
    attempts: list = field(default_factory=list)  # what was tried, in order
    assembly: Assembly | None = None

    @property
    def potential(self) -> float:
        return float(sum(self.energies.values()))

    @property
    def strain_energy(self) -> float:
        return float(sum(v for k, v in self.energies.items() if k not in ("gravity", "loads", "penalty")))

    def nodes(self, member: str) -> np.ndarray:
        """Node positions (public nodes) [m]."""
        mm = self.assembly.mesh.members[member]
        xn = self.assembly.member_coordinates(self.x, member)
        return xn[mm.public_nodes, :self.assembly.scene.dim]

    def slopes(self, member: str) -> np.ndarray:
        mm = self.assembly.mesh.members[member]
        d = self.assembly.scene.dim
        return self.assembly.member_coordinates(self.x, member)[mm.public_nodes, d:2 * d]

    def tip(self, member: str) -> np.ndarray:
        return self.nodes(member)[-1]

    def along(self, member: str, per_element: int = 8) -> dict:
        """s, r, axial strain |r_x|-1 and curvature along the member."""
        mm = self.assembly.mesh.members[member]
        return fields.sample(mm, self.assembly.member_coordinates(self.x, member), per_element)

    def to_dict(self) -> dict:
        return {
            "status": self.status, "success": self.success, "iterations": self.iterations, "wall_s": self.wall_s,
            "energies": self.energies, "potential": self.potential if self.success else None,
            "constraint_violation": self.constraint_violation, "stable": self.stable, "attempts": self.attempts,
            "members": {name: {"nodes": self.nodes(name).tolist(), "slopes": self.slopes(name).tolist()}
                        for name in self.assembly.mesh.members},
            "constraint_forces": {k: np.asarray(v).tolist() for k, v in self.constraint_forces.items()},
        }


class StaticProblem:
    """The IPOPT problem of a scene, built once (load factor as a parameter) and solved as often as needed."""

    def __init__(self, scene_or_assembly: Scene | Assembly):
        self.asm = scene_or_assembly if isinstance(scene_or_assembly, Assembly) else Assembly(scene_or_assembly)
        a = self.asm
        x, lam = ca.MX.sym("x", a.n), ca.MX.sym("load_factor")
        f, grad, hess, g = a.casadi_parts(x, lam)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.shape[0])
        hl = lam_f * hess
        if g.shape[0] and len(a.exact.qrow):
            hl += ca.triu(ca.hessian(ca.dot(lam_g, g), x)[0])
        self.nlp = {"x": x, "p": lam, "f": f, "g": g}
        self.grad_f = ca.Function("nlp_grad_f", [x, lam], [f, grad], ["x", "p"], ["f", "grad_f_x"])
        self.hess_lag = ca.Function("nlp_hess_l", [x, lam, lam_f, lam_g], [hl],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        self.floor = self._roundoff_floor()
        self._solvers: dict = {}

    def _roundoff_floor(self) -> float:
        """Gradient round-off floor [N]: machine eps x largest stiffness entry x size of the coordinates.

        Measured on the 3 m cantilever (60..6000 elements) IPOPT's achievable residual sat at 0.4-0.8 of this."""
        ev = self.asm.evaluate(self.asm.x0)  # penalty springs included: their round-off is as real as the kernels'
        kmax = float(abs(ev.hessian).max()) if ev.hessian.nnz else 1.0
        # largest generalized force at the start: IPOPT stops at once if its tolerance is above it
        self.load_scale = float(np.max(np.abs(ev.gradient))) if ev.gradient.size else 0.0
        span = float(np.max(np.abs(self.asm.x0))) + 1.0
        return float(np.finfo(float).eps * kmax * span)

    def tolerance(self, opts: StaticOptions) -> float:
        """IPOPT tol [N] (unscaled problem): the user's, else twice the round-off floor."""
        return float(opts.tol) if opts.tol is not None else max(2.0 * self.floor, 1e-14)

    def solver(self, line_search: bool, opts: StaticOptions):
        key = (line_search, opts.tol, opts.max_iter, opts.print_level)
        if key not in self._solvers:
            tol = self.tolerance(opts)
            ipopt = {"tol": tol, "dual_inf_tol": tol, "acceptable_tol": 10 * tol, "acceptable_dual_inf_tol": 10 * tol,
                     "acceptable_iter": 3, "max_iter": int(opts.max_iter), "constr_viol_tol": 1e-10,
                     "nlp_scaling_method": "none", "print_level": opts.print_level, "sb": "yes"}
            if not line_search:
                ipopt["accept_every_trial_step"] = "yes"
            self._solvers[key] = ca.nlpsol("statics", "ipopt", self.nlp, {
                "ipopt": ipopt, "print_time": False, "grad_f": self.grad_f, "hess_lag": self.hess_lag,
                "error_on_fail": False})
        return self._solvers[key]

    def _run(self, x0, lam_g0, load, line_search, opts):
        S = self.solver(line_search, opts)
        m = self.asm.exact.m
        args = {"x0": x0, "p": load, "lbg": np.zeros(m), "ubg": np.zeros(m)}
        if lam_g0 is not None:
            args["lam_g0"] = lam_g0
        with interruptible():  # Ctrl-C / SIGTERM inside IPOPT: raised here, not tried again as a failed attempt
            sol = S(**args)
        st = S.stats()
        check_stop(st["return_status"])
        x = np.asarray(sol["x"]).ravel()
        ok = st["return_status"] in SUCCESS and np.all(np.isfinite(x))
        return ok, st["return_status"], int(st["iter_count"]), x, np.asarray(sol["lam_g"]).ravel()

    def solve(self, opts: StaticOptions | None = None, x0: np.ndarray | None = None) -> StaticResult:
        opts = opts or StaticOptions()
        a = self.asm
        t0 = time.perf_counter()
        x = a.x0.copy() if x0 is None else np.asarray(x0, float).copy()
        if x.shape != (a.n,) or not np.all(np.isfinite(x)):
            raise SceneError(f"warm start x0 must be {a.n} finite numbers, got shape {np.shape(x0)}")
        if x0 is not None:
            check_stretch(a.mesh, x, "warm start x0")
        attempts, iters = [], 0
        ok, status, lam_g = False, "not run", None
        if opts.tol is None and self.floor > RESOLVABLE * self.load_scale > 0:
            # e.g. a penalty factor so large that eps x its stiffness exceeds the loads: IPOPT would stop at once
            # (or wander) and call the reference state an equilibrium; refuse to pretend.
            attempts.append({"method": "none", "status": "Round_Off_Floor_Above_Loads", "iterations": 0,
                             "detail": f"gradient round-off floor {self.floor:.3g} N exceeds {RESOLVABLE:g} x the "
                                       f"largest applied force {self.load_scale:.3g} N: stiffness (or penalty factor)"
                                       f" too large for double precision at these loads"})
            return self._result(False, "Round_Off_Floor_Above_Loads", 0, time.perf_counter() - t0, x, None, None,
                                attempts)
        ceiling = self._start_ceiling(x)
        for line_search in (False, True):
            ok, status, it, xs, lg = self._run(x, None, 1.0, line_search, opts)
            iters += it
            attempts.append({"method": "full steps" if not line_search else "line search", "status": status, "iterations": it})
            if ok and a.energy(xs) > ceiling:  # full steps can jump into another basin and converge there
                ok = False
                attempts[-1]["rejected"] = "potential above that of the feasible start point"
            if ok:
                x, lam_g = xs, lg
                break
        if not ok:  # continuation from the last converged load level
            xk, lgk = x, None
            for k in range(1, opts.load_steps + 1):
                okk, status, it, xs, lg = self._run(xk, lgk, k / opts.load_steps, True, opts)
                iters += it
                attempts.append({"method": f"load step {k}/{opts.load_steps}", "status": status, "iterations": it})
                if not okk:
                    break
                xk, lgk = xs, lg
            else:
                ok, x, lam_g = True, xk, lgk
        stable = None
        if ok:
            x, lam_g, worst = self._polish(x, lam_g, attempts)
            if worst > UNRESOLVED:  # some rows far above their own round-off: not an equilibrium, say so
                ok, status = False, "Unresolved_Residual"
                attempts.append({"method": "newton polish", "status": status, "iterations": 0,
                                 "detail": f"after IPOPT and Newton polishing a residual is {worst:.3g} x its row's "
                                           f"round-off floor (limit {UNRESOLVED:g}): stiffnesses too far apart (e.g. "
                                           "a penalty factor too large) for double precision at these loads"})
        if ok:
            stable, direction = self.stability(x, lam_g)
            if stable is False and opts.escape_saddle:
                x, lam_g, status, stable, iters = self._leave_saddle(x, lam_g, status, direction, iters, attempts, opts)
        wall = time.perf_counter() - t0
        return self._result(ok, status, iters, wall, x, lam_g, stable, attempts)

    def _kkt_residual(self, x, lam):
        """(residual of grad f + J^T lam and c(x), KKT matrix, per-row round-off floor) at (x, lam)."""
        a = self.asm
        ev = a.evaluate(x)
        H, r = ev.hessian.tocsc(), ev.gradient.copy()
        span = float(np.max(np.abs(x))) + 1.0
        floor = np.finfo(float).eps * span * np.maximum(abs(H).max(axis=1).toarray().ravel(), 1e-300)
        if not a.exact.m:
            return r, H, floor
        J = a.exact.jacobian(x)
        r = np.concatenate([r + J.T @ lam, a.exact.value(x)])
        if len(a.exact.qrow):
            H = H + a.exact.hessian(lam)
        K = sp.bmat([[H, J.T], [J, None]], format="csc")
        cfloor = np.finfo(float).eps * span * np.maximum(abs(J).max(axis=1).toarray().ravel(), 1e-300)
        return r, K, np.concatenate([floor, cfloor])

    def _polish(self, x, lam_g, attempts, steps: int = 4):
        """Newton steps on the KKT system from IPOPT's point. IPOPT has one absolute tolerance, twice the round-off
        floor of the STIFFEST row; rows many orders softer (bending next to a 1e10 EA/L penalty clamp) can stay
        unresolved: a 10 N transverse tip load below that tolerance came back as Solve_Succeeded 0.87 mm off.
        A step is kept only while it lowers the worst residual measured against each row's own round-off floor."""
        a = self.asm
        n = a.n
        lam = np.zeros(a.exact.m) if lam_g is None else np.asarray(lam_g, float).ravel()
        try:
            r, K, floor = self._kkt_residual(x, lam)
            worst = float(np.max(np.abs(r) / floor)) if r.size else 0.0
            moved, k = 0.0, 0
            for k in range(steps):
                if worst <= 10.0:
                    break
                d = splu(K).solve(-r)
                if not np.all(np.isfinite(d)):
                    break
                xn, ln = x + d[:n], lam + d[n:]
                rn, Kn, fn = self._kkt_residual(xn, ln)
                wn = float(np.max(np.abs(rn) / fn))
                if not wn < worst:
                    break
                moved = max(moved, float(np.max(np.abs(d[:n]))))
                x, lam, r, K, floor, worst = xn, ln, rn, Kn, fn, wn
        except (RuntimeError, ValueError):  # singular KKT matrix (redundant constraints): keep the last point
            return x, (lam if lam_g is not None else None), 0.0
        if moved > 1e-12 * self._length_scale():
            attempts[-1]["polish"] = {"newton_steps": k, "max_move": moved, "residual_over_floor": worst}
        return x, (lam if lam_g is not None else None), worst

    def _leave_saddle(self, x, lam_g, status, direction, iters, attempts, opts):
        """Restart from x nudged along the negative-curvature direction (full steps first, then line search);
        keep the first converged point of lower potential."""
        a = self.asm
        e0 = a.energy(x)
        for scale in (1e-3, 1e-2, 1e-1):
            xp = x + scale * self._length_scale() * direction
            for line_search in (False, True):
                ok, st, it, xs, lg = self._run(xp, lam_g, 1.0, line_search, opts)
                iters += it
                attempts.append({"method": f"leave saddle ({scale:g} L, {'line search' if line_search else 'full steps'})",
                                 "status": st, "iterations": it})
                if ok and a.energy(xs) < e0 - 1e-12 * abs(e0):
                    stable, _ = self.stability(xs, lg)
                    return xs, lg, st, stable, iters
        return x, lam_g, status, False, iters

    def _start_ceiling(self, x: np.ndarray) -> float:
        """Highest potential an accepted solution may have: that of the start point, if it satisfies the exact
        constraints (a minimiser started there cannot rightly end higher), plus the energy round-off
        (gradient floor x length scale); +inf for an infeasible start."""
        a = self.asm
        if a.exact.m and np.max(np.abs(a.exact.value(x))) > 1e-9 * self._length_scale():
            return np.inf
        return a.energy(x) + 10 * self.floor * self._length_scale()

    def _length_scale(self) -> float:
        return max(mm.member.length for mm in self.asm.mesh.members.values())

    def stability(self, x: np.ndarray, lam_g: np.ndarray | None = None,
                  dense_limit: int = 1500) -> tuple[bool | None, np.ndarray | None]:
        """Is the reduced Hessian of the Lagrangian (on the tangent space of the exact constraints) positive definite?
        lam_g: IPOPT's constraint multipliers, for the curvature of the bilinear (rigid-joint) constraints.

        Returns (stable, direction of most negative curvature in full coordinates)."""
        a = self.asm
        if a.n > dense_limit:
            return None, None
        H = a.evaluate(x).hessian.toarray()
        if lam_g is not None and a.exact.m and len(a.exact.qrow):
            H += a.exact.hessian(np.asarray(lam_g, float)).toarray()
        if a.exact.m:
            J = a.exact.jacobian(x).toarray()
            Z = sla.null_space(J)
        else:
            Z = np.eye(a.n)
        Hr = Z.T @ H @ Z
        w, V = np.linalg.eigh(0.5 * (Hr + Hr.T))
        scale = max(abs(w).max(), 1e-300)
        d = Z @ V[:, 0]
        # Negative beyond the eigenvalues' round-off floor eps ||Hr||: an exactly zero mode (a free rotation about a
        # pin) computed within 0.2 eps ||Hr|| for EA L^2/EI = 1e5..1e10 and 8..300 elements, while a column past its
        # Euler load has an eigenvalue of only -4e-11 ||Hr|| (EA L^2/EI = 1e5, 32 elements, 1.01 P_cr) down to
        # -4e-14 ||Hr|| (1e8, 32 elements): the old threshold -1e-10 ||Hr|| called those straight columns stable.
        return bool(w[0] > -STABILITY_EPS * scale), d / np.max(np.abs(d))

    def _result(self, ok, status, iters, wall, x, lam_g, stable, attempts) -> StaticResult:
        a = self.asm
        if not ok:  # never hand NaN to the caller: report the start point's energies with the failure
            x = x if np.all(np.isfinite(x)) else a.x0
        ev = a.evaluate(x, hessian=False)
        forces: dict[str, list] = {}
        if lam_g is not None and a.exact.m:
            for lbl, v in zip(a.exact.labels, lam_g):
                forces.setdefault(lbl, []).append(float(v))
        if a.penalty is not None:
            c = a.penalty.value(x)
            for lbl, k, cv in zip(a.penalty.labels, a.penalty.k, c):
                forces.setdefault(lbl, []).append(float(k * cv))
        viol = float(np.max(np.abs(a.constraints.value(x)))) if a.constraints.m else 0.0
        return StaticResult(status, ok, iters, wall, x, ev.energies, forces, viol, stable, attempts, a)


def solve_static(scene: Scene | Assembly, options: StaticOptions | None = None,
                 warm_start: StaticResult | np.ndarray | None = None, **kw) -> StaticResult:
    """Static equilibrium of a scene. Keyword arguments are StaticOptions fields (tol, max_iter, load_steps,
    escape_saddle, print_level). warm_start: a previous result (same scene) or a coordinate vector."""
    if isinstance(scene, Scene):
        scene.validate_for_statics()
    opts = options or StaticOptions(**kw)
    x0 = warm_start.x if isinstance(warm_start, StaticResult) else warm_start
    return StaticProblem(scene).solve(opts, x0)
