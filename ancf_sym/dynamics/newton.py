"""Newton's method on the step equations of a StepSystem (or any object with its buffer interface: x, lam, dz, r,
norms, floor, kkt, iterate(), residual(), jacobian()), full or modified (a SuperLU factorisation kept across
iterations and steps), with its options, work counters and outcome.

A step converges when the residual is below the force tolerance (never below twice the round-off floor) and the
constraints below the length tolerance, or when the contraction of successive updates shows the remaining error
below the update tolerance. With `line_search`, full Newton backs off along an update (Armijo on the scaled
residual) when it neither lowered the residual nor contracted: laws that saturate, such as regularised friction,
make the full update overshoot from outside a narrow region.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.util.checks import fail
from ancf_sym.scene.builder import SceneError

if TYPE_CHECKING:
    from ancf_sym.system.step_system import StepSystem


@dataclass
class NewtonOptions:
    """Newton on the exact tangent. A step converges when the residual is below tol x force scale (never below
    twice the round-off floor) and the constraints below xtol x length scale, or when the estimated error of the
    last update, theta/(1 - theta) |dz| with theta the contraction of successive updates, is below the update
    tolerance (saves the residual evaluation that would only confirm convergence). Alpha schemes: the update
    tolerance is max(xtol x length scale, lte_fraction x the step's local truncation error; the latter capped where
    the accepted error's residual on the stiffest direction would do work, alpha_step.update_tolerance), and with
    `single` a step is accepted after one full Newton iteration when Newton's own estimate 2 omega |dz0|^2 is below
    it (an iteration on a kept factor is never accepted before the next one measured the contraction)."""
    tol: float = 1e-8  # residual, relative to the scene's force scale
    xtol: float = 1e-10  # updates and constraints, relative to the scene's length scale
    max_iter: int = 12
    # keep the factorisation across iterations and steps while the iteration contracts: alpha schemes in their
    # compiled step where the step matrix is symmetric positive definite (LDL^T factor in the state), else in
    # Python (SuperLU); residuals from the gradient-only kernels
    modified: bool = False
    single: bool = True  # accept a step after one iteration when Newton's error estimate allows
    lte_fraction: float = 0.01  # alpha schemes: update tolerance also this fraction of the local truncation error
    contraction: float = 0.5  # modified Newton: refactorise when the contraction |dz_k+1| / |dz_k| exceeds this
    max_modified: int = 8  # modified Newton: at most this many iterations on one factorisation within a step
    # full Newton in Python: back off along an update that neither lowered the residual nor contracted (Armijo on
    # the scaled residual); for laws that saturate (regularised friction with a small eps) where full updates cycle.
    # None (automatic): on, with max_iter at least KINK_MAX_ITER, where the scene has a linear-law contact (its
    # tangent jumps where a point touches down), else off
    line_search: bool | None = None

    def __post_init__(self):
        if isinstance(self.lte_fraction, bool) or not isinstance(self.lte_fraction, (int, float)) or \
                not math.isfinite(self.lte_fraction) or self.lte_fraction < 0:
            raise fail("newton.lte_fraction", "must be a non-negative finite number", self.lte_fraction)
        for name in ("tol", "xtol", "contraction"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise fail(f"newton.{name}", "must be a positive finite number", v)
        for name in ("max_iter", "max_modified"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise fail(f"newton.{name}", "must be a positive integer", v)
        if self.contraction >= 1:
            raise SceneError(f"newton.contraction must be below 1, got {self.contraction!r}")
        for name in ("modified", "single", "line_search"):
            if name == "line_search" and self.line_search is None:
                continue
            if not isinstance(getattr(self, name), bool):
                raise SceneError(f"newton.{name} must be true or false, got {getattr(self, name)!r}")


# iterations a step through the kink of a linear contact law may take (the belt drive on the linear law: 12 with
# the line search still rejected 5 steps of 600, 30 none)
KINK_MAX_ITER = 30


def resolve_kinks(opts: NewtonOptions, kinked: bool) -> NewtonOptions:
    """The options with an automatic line search (None) decided: on, with at least KINK_MAX_ITER iterations, for a
    scene with a kinked (linear-law) contact; off otherwise. Explicit true/false are kept as given."""
    if opts.line_search is not None:
        return opts
    if not kinked:
        return replace(opts, line_search=False)
    return replace(opts, line_search=True, max_iter=max(opts.max_iter, KINK_MAX_ITER))


@dataclass
class Counters:
    newton_iterations: int = 0  # updates applied (linear solves)
    residuals: int = 0  # residual evaluations (each one mapped kernel call per energy term)
    jacobians: int = 0  # KKT matrix assemblies
    factorizations: int = 0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


class Factor:
    """Modified Newton: a SuperLU factorisation of the KKT matrix, remembered with the step coefficients."""

    def __init__(self):
        self.lu = None
        self.key = None

    def factorize(self, A: sp.csc_matrix, key, counters: Counters) -> bool:
        try:
            self.lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                                options={"SymmetricMode": True})
        except RuntimeError:  # exactly singular
            self.lu, self.key = None, None
            return False
        self.key = key
        counters.factorizations += 1
        return True


@dataclass
class NewtonOutcome:
    converged: bool
    iterations: int
    reason: str = ""
    residual: float = float("nan")


def newton(system: StepSystem, factor: Factor, key, opts: NewtonOptions, counters: Counters,
           tol_q: float, tol_x: float, it0: int = 0) -> NewtonOutcome:
    """Solve r(x, lam) = 0 from the buffers' current x, lam (updated in place).

    tol_q: force tolerance on the free rows [N]; tol_x: tolerance on updates and constraint rows [m].
    `key` identifies the step coefficients of a modified-Newton factorisation (refreshed when it differs).
    it0: iterations already spent on this step (count towards opts.max_iter).
    """
    if opts.modified:
        return _newton_modified(system, factor, key, opts, counters, tol_q, tol_x)
    nf = system.nf
    norms = system.norms
    it = it0
    d_prev = None
    back = None  # (x, lam, dz, merit) of the last full update, kept for a line search
    while True:
        try:
            system.iterate()
        except RuntimeError:  # (an exactly singular step matrix: the sparse LU of the time steps refuses it)
            return NewtonOutcome(False, it, "singular iteration matrix")
        counters.residuals += 1
        counters.jacobians += 1
        counters.factorizations += 1
        rq, rc, dzx, dzl = norms[0], norms[1], norms[2], norms[3]
        if not (math.isfinite(rq) and math.isfinite(rc)):
            return NewtonOutcome(False, it, "residual not finite")
        tq = max(tol_q, 2.0 * system.floor)
        if rq <= tq and rc <= tol_x:
            return NewtonOutcome(True, it, "", rq)
        d = max(dzx, dzl)
        if not math.isfinite(d):
            return NewtonOutcome(False, it, "singular iteration matrix (update not finite)", rq)
        merit = max(rq / tq, rc / tol_x)
        if back is not None and d_prev is not None and merit > back[3] and d > opts.contraction * d_prev:
            # neither the residual fell nor the updates contract: the full step left Newton's region of
            # convergence (regularised friction: its force saturates over the velocity eps, and Newton on such
            # a law overshoots by the cube of the distance); back along the last update to a sufficient decrease
            if it >= opts.max_iter:
                return NewtonOutcome(False, it, f"no convergence in {opts.max_iter} iterations (residual {rq:.3g} N, "
                                                f"constraint {rc:.3g} m; tolerances {tq:.3g} N, {tol_x:.3g} m)", rq)
            _backtrack(system, back, tq, tol_x, counters)
            back, d_prev = None, None
            continue
        if it >= opts.max_iter:
            return NewtonOutcome(False, it, f"no convergence in {opts.max_iter} iterations (residual {rq:.3g} N, "
                                            f"constraint {rc:.3g} m; tolerances {tq:.3g} N, {tol_x:.3g} m)", rq)
        if opts.line_search:
            back = (system.x.copy(), system.lam.copy(), system.dz.copy(), merit)
        system.x += system.dz[:nf]
        if system.mc:
            system.lam += system.dz[nf:]
        it += 1
        counters.newton_iterations += 1
        if d <= 0.1 * tol_x and rc <= tol_x:
            return NewtonOutcome(True, it, "", rq)
        if d_prev is not None:
            theta = d / d_prev
            if theta < 0.5 and theta / (1 - theta) * d <= tol_x:
                return NewtonOutcome(True, it, "", rq)
            if d > 1e6 * d_prev:
                return NewtonOutcome(False, it, f"diverging (update {d:.3g}, residual {rq:.3g} N)", rq)
        d_prev = d


LINE_SEARCH_HALVINGS = 12  # shortest step 2^-12 of the Newton update


def _backtrack(system, back, tq: float, tol_x: float, counters: Counters) -> None:
    """Armijo backtracking from the iterate `back` = (x, lam, dz, merit) along its Newton update dz: the first of
    t = 1/2, 1/4, ... whose scaled residual max(|r_q| / tq, |Phi| / tol_x) is below (1 - t/10^4) merit (a Newton
    update lowers every residual row by the fraction t to first order, so a short enough step always passes),
    else the shortest. Residuals only (no Jacobian); the iterate is left in system.x, system.lam."""
    x0, lam0, dz, merit0 = back
    nf = system.nf
    t = 1.0
    for _ in range(LINE_SEARCH_HALVINGS):
        t *= 0.5
        system.x[:] = x0 + t * dz[:nf]
        if system.mc:
            system.lam[:] = lam0 + t * dz[nf:]
        system.residual()
        counters.residuals += 1
        rq, rc = system.norms[0], system.norms[1]
        if math.isfinite(rq) and math.isfinite(rc) and max(rq / tq, rc / tol_x) <= (1 - 1e-4 * t) * merit0:
            return


def _newton_modified(system, factor, key, opts, counters, tol_q, tol_x) -> NewtonOutcome:
    nf, mc = system.nf, system.mc
    norms = system.norms
    stale = factor.lu is None or factor.key != key
    A_cur = None
    if stale:
        A_cur = system.jacobian()
        counters.jacobians += 1
    else:
        system.residual()
    counters.residuals += 1
    fresh = stale  # system.kkt holds the Jacobian at the current iterate
    it, on_factor = 0, 0
    s_prev, d_prev = None, None
    r = system.r
    while True:
        rq, rc = norms[0], norms[1]
        if not (math.isfinite(rq) and math.isfinite(rc)):
            return NewtonOutcome(False, it, "residual not finite")
        tq = max(tol_q, 2.0 * system.floor)
        s = max(rq / tq, rc / tol_x)
        if s <= 1.0:
            return NewtonOutcome(True, it, "", rq)
        if it >= opts.max_iter:
            return NewtonOutcome(False, it, f"no convergence in {opts.max_iter} iterations (residual {rq:.3g} N, "
                                            f"constraint {rc:.3g} m; tolerances {tq:.3g} N, {tol_x:.3g} m)", rq)
        refresh = factor.lu is None or factor.key != key
        if s_prev is not None and (s > opts.contraction * s_prev or on_factor >= opts.max_modified):
            refresh = True
        if refresh:
            if not fresh:
                A_cur = system.jacobian()
                counters.jacobians += 1
                counters.residuals += 1
                fresh = True
            if not factor.factorize(A_cur, key, counters):
                return NewtonOutcome(False, it, "singular iteration matrix", rq)
            on_factor = 0
            d_prev = None
        dz = factor.lu.solve(-r)
        d = float(np.max(np.abs(dz))) if len(dz) else 0.0
        if not math.isfinite(d):
            return NewtonOutcome(False, it, "update not finite", rq)
        it += 1
        on_factor += 1
        counters.newton_iterations += 1
        system.x += dz[:nf]
        if mc:
            system.lam += dz[nf:]
        if d_prev is not None:
            theta = d / d_prev
            if theta < 0.5 and theta / (1 - theta) * d <= tol_x and rc <= tol_x:
                return NewtonOutcome(True, it, "", rq)
        d_prev = d
        s_prev = s
        system.residual()
        counters.residuals += 1
        fresh = False
        r = system.r
