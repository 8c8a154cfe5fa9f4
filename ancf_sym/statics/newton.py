"""Full-step Newton for static equilibrium on the free coordinates, a convergence test in the solution's terms.

The iteration runs on the free coordinates (supports that fix coordinates eliminated, hinges identified, the
remaining exact rows with Lagrange multipliers). Two ways to evaluate one iteration (residual, tangent, update), one
loop; which one depends on the scene, never on how often it is solved:
- kernels (KernelNewton), every scene without multiplier rows: the compiled kernels called directly, their
  gradients and Hessians scattered onto the free coordinates and LAPACK's band (statics.evaluation), a banded Cholesky
  (dpbtrf): nothing to build. The whole loop below runs as one call into hand-written C (newton_loop,
  csrc/newton_loop.c: the same operations in the same order, so the same steps) where the evaluation is plain
  (no penalty springs, a band within BAND_LIMIT): measured ~11 - 16 us per iteration on 6 - 18 elements, ~47 us
  at 60, ~5.5 ms at 6000 (this Python loop: ~50 us, ~87 us, ~6 ms); other scenes iterate here in Python;
- graph (NewtonStatics), scenes with multiplier rows (rigid joints, skew clamps): the dynamics' StepSystem with
  every kernel, the KKT matrix and its sparse QR in one CasADi Function, ~35 ms (60 elements) to ~1 s (6000) to
  build, then about as fast per iteration.
Ctrl-C stops a solve between two iterations (the C loop checks Python's signals before each).
Where the tangent is not positive definite and the updates are still large, KernelNewton takes the plain step (banded
LU) if it is small or lowers the potential, else shifts its diagonal until the step does (_shifted_step); full
Newton steps everywhere else.

Convergence (`tol`, relative, the same at any mesh size):
- increment: the last applied Newton update, positions in units of the structure's length L and slopes
  (dimensionless) as they are, max norm, <= tol;
- energy decrement: -r . dz = dz^T K dz (twice the energy the update still gains), in units of the load work
  W = sum |r_i(x0)| s_i (the start residual times the coordinate scales: the weight times L under gravity), <= tol.
The answer is the point AFTER that update: Newton's error there is of the order of the update squared, so it lies
within tol^2 L of the discrete solution, far below tol. The start state is never accepted while a load acts: its
update is the (non-zero) response to the loads and it is applied before the test.
Round-off: when the updates stop contracting (each more than half the previous) while the residual sits at its
round-off level (within ROUND_OFF x eps x max|K| x span), they measure the round-off of the solution itself; above tol it cannot be resolved in double precision (e.g. a penalty factor so stiff that
eps x its force swamps the loads) and the run says so.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from scipy.sparse.linalg import splu

from ancf_sym.model.assembly import Assembly
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.contact.steps import limiter
from scipy.linalg.lapack import dgbsv, dpbtrf, dpbtrs

from ancf_sym.statics.inertia import banded_cholesky, banded_solve
from ancf_sym.statics.newton_loop import CompiledLoop, compiled_loop
from ancf_sym.statics.evaluation import ReducedEvaluation
from ancf_sym.system.step_system import StepSystem
from ancf_sym.model.reduced import ReducedModel

from ancf_sym.statics.criteria import (EPS, NO_PROGRESS, PYTHON_LOOP, ROUND_OFF, SHIFT, SHIFT_BELOW, SHIFT_MAX, STALL,
                                      STALL_COUNT, WILD, NewtonRun, coordinate_scales)


class NewtonStatics:
    """Full-step Newton on a scene's free coordinates (StepSystem with no mass and no damping)."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        self.S = S = StepSystem(asm)
        self.energy = None  # potential at the last evaluated point (KernelNewton: what a shifted step must lower)
        self.scale = coordinate_scales(asm)[S.part.roots]
        nf, mc = S.nf, S.mc
        xf, lam, p = ca.MX.sym("x", nf), ca.MX.sym("lam", mc), ca.MX.sym("p", nf)
        g, K = S.forces_f(xf)[:2]
        r_q = g + p
        if mc:
            # drive rows (held in statics, e.g. fairleads in water: ancf_sym.statics.water) at their t = 0 values
            w0 = ca.DM(S.drives.w(0.0)) if S.drives is not None and S.drives.m else None
            phi = S.constraint_mx(xf, w0)
            Jx = ca.jacobian(phi, xf)
            r_q = r_q + ca.mtimes(Jx.T, lam)
            if len(S.cons.qrow):
                K = K + ca.hessian(ca.dot(lam, phi), xf)[0]
            r = ca.vertcat(r_q, phi)
            KKT = ca.blockcat([[K, Jx.T], [Jx, ca.MX(mc, mc)]])
            rc = ca.mmax(ca.fabs(phi))
        else:
            r, KKT, rc = r_q, K, ca.MX(0)
        dz = -ca.solve(KKT, r, S.linsol)
        inc = ca.mmax(ca.fabs(dz[:nf] / ca.DM(self.scale))) if nf else ca.MX(0)
        kmax = ca.mmax(ca.fabs(KKT)) if nf else ca.MX(0)
        norms = ca.vertcat(ca.mmax(ca.fabs(r_q)) if nf else ca.MX(0), rc, inc, -ca.dot(r, dz), kmax)
        f = ca.Function("statics_newton", [xf, lam, p], [dz, norms], ["x", "lam", "p"], ["dz", "norms"])
        self.x, self.lam, self.p = np.zeros(nf), np.zeros(mc), np.zeros(nf)
        self.dz, self.norms = np.zeros(nf + mc), np.zeros(5)
        self._buf, self._eval = bind(f, (self.x, self.lam, self.p), (self.dz, self.norms))
        self.f = f
        self.span = S.span
        self.step_limit = limiter(asm)  # penalty drums: steps cut back before a point reaches a drum's axis

    def load_work(self, x_full: np.ndarray, load: float = 1.0) -> float:
        """W = sum |r_i| s_i of the residual at x_full without multipliers (free rows): the loads' energy scale
        [J] (under gravity from the undeformed state: the weight times L)."""
        return float(np.sum(np.abs(self.gradient(x_full) - load * self.S.f_lin) * self.scale))

    def gradient(self, x_full: np.ndarray) -> np.ndarray:
        """Gradient of the nonlinear potential on the free coordinates."""
        return np.asarray(self.S.grad_f(self.S.reduce(x_full))).ravel()

    def solve(self, x_full: np.ndarray, tol: float, max_iter: int, work: float, load: float = 1.0,
              lam: np.ndarray | None = None, max_step: float = np.inf, finish: float = 0.0) -> NewtonRun:
        """Newton from x_full (which must satisfy the eliminated supports and hinges) at the given load factor.

        work: the load work W [J] for the energy decrement's scale. finish > 0: a converged run also reports the
        answer's potential and stability (KernelNewton only; this graph leaves them to the caller)."""
        S = self.S
        self.x[:] = S.reduce(x_full)
        self.lam[:] = 0.0 if lam is None else lam
        self.p[:] = -load * S.f_lin
        self.load = load
        nf = S.nf
        W = max(work, np.finfo(float).tiny)
        hist: list = []
        status, inc, dec, stall, it = "max_iter", math.inf, math.inf, 0, 0
        best, best_at = math.inf, 0
        for it in range(1, max_iter + 1):
            self.norms[:] = np.nan  # a failed evaluation (e.g. a singular KKT matrix) writes nothing: not finite
            self._eval()
            rq, rc, inc, dec, kmax = self.norms.tolist()  # Python floats: scalar tests on them cost less
            floor = EPS * kmax * self.span
            dec = abs(dec) / W
            if not (math.isfinite(inc) and math.isfinite(rq) and math.isfinite(dec)):
                status = "not_finite"
                it -= 1
                break
            if inc > max_step:  # a step longer than max_step structure lengths is cut back along its direction
                self.dz *= max_step / inc
                inc, dec = max_step, dec * (max_step / inc)
            cut = 1.0
            if self.step_limit is not None:  # no contact point carried through a drum (ancf_sym.contact.steps)
                cut = self.step_limit(S.full(self.x), S.full_v(self.dz[:nf]))
                if cut < 1.0:
                    self.dz *= cut
                    inc, dec = inc * cut, dec * cut
            self.x += self.dz[:nf]
            if S.mc:
                self.lam += self.dz[nf:]
            hist.append((inc, dec))
            if inc < best:
                best, best_at = inc, it
            if inc <= tol and dec <= tol and cut == 1.0:  # (a cut step is no Newton step: never the last one)
                status = "converged"
                break
            if inc > WILD:
                status = "diverged"
                break
            if cut < 1.0:  # a cut step makes its way toward a contact, not a Newton contraction: no stall test
                stall, best, best_at = 0, inc, it
                continue
            if len(hist) > 1:
                stall = stall + 1 if inc > STALL * hist[-2][0] else 0
                if hist[-1][0] > 1e8 * hist[0][0] + 1e8:
                    status = "diverged"
                    break
                if stall >= STALL_COUNT and inc < 1e-3 and rq <= ROUND_OFF * floor:
                    status = "round_off"
                    break
                if stall >= 2 * STALL_COUNT or it - best_at > NO_PROGRESS:  # cycling well above round-off, or no
                    status = "stalled"  # new smallest update for NO_PROGRESS iterations: not in Newton's basin
                    break
        x = S.full(self.x)
        return NewtonRun(status == "converged", status, it, x, self.lam.copy(), float(inc), float(dec),
                         float(self.norms[0]), floor if it else 0.0, hist)


def _banded_lu_solve(ab: np.ndarray, r: np.ndarray) -> np.ndarray:
    """K^-1 r for a symmetric K in LAPACK's upper banded storage, by the banded LU with partial pivoting (LAPACK
    dgbsv, O(n bw^2)): for tangents that are not positive definite, where the sparse LU took ~1 s at 400 000
    coordinates (measured) and this takes ~0.05 s. NaN where K is singular. dgbsv called directly (what
    scipy.linalg.solve_banded calls, in the storage it builds): its checks and copies cost ~30 us a call, measured on
    6 elements (35 -> 6 us), where one indefinite step per solve is common."""
    bw, n = ab.shape[0] - 1, ab.shape[1]
    full = np.zeros((3 * bw + 1, n))  # bw rows for the LU's fill-in, then K's upper band, diagonal, lower band
    full[bw:2 * bw + 1] = ab
    for d in range(1, bw + 1):  # K[j + d, j] = K[j, j + d], stored at ab[bw - d, j + d]
        full[2 * bw + d, :n - d] = ab[bw - d, d:]
    x, info = dgbsv(bw, bw, full, r, overwrite_ab=1)[2:]
    return x if info == 0 else np.full(n, np.nan)


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """a . b without BLAS: a threaded ddot waits milliseconds for its threads on a busy machine (measured at 24 000
    coordinates: 18 ms instead of 0.09 ms with 2 cores shared by several processes)."""
    return float(np.multiply(a, b).sum())


class KernelNewton(NewtonStatics):
    """The same Newton loop with each iteration evaluated from the compiled kernels (statics.evaluation: no graph to
    build) and solved by a banded Cholesky (LAPACK dpbtrf; banded LU where the tangent is not positive definite,
    sparse factorisations where the band is wide). Scenes without multiplier rows only (ReducedModel.mc == 0). evaluation: another strain measure's
    (ReducedEvaluation.variant) for a start. `solve` runs the loop in C (newton_loop) where the evaluation allows it
    (decided at the first solve; a solve the C loop hands back, a singular band, runs here again from its start);
    afterwards the evaluation holds the kernels' values at the point they were evaluated last, as after this loop."""

    def __init__(self, asm: Assembly, reduction: ReducedModel, evaluation: ReducedEvaluation | None = None):
        assert reduction.mc == 0, "multiplier rows need the graph (NewtonStatics)"
        self.asm, self.S = asm, reduction
        self.ev = evaluation or ReducedEvaluation(asm, reduction)
        self.scale = coordinate_scales(asm)[reduction.part.roots]
        nf = reduction.nf
        self.x, self.lam, self.p = np.zeros(nf), np.zeros(0), np.zeros(nf)
        self.dz, self.norms = np.zeros(nf), np.zeros(5)
        self.span = reduction.span
        self.step_limit = limiter(asm)
        self.energy = None
        self.load = 1.0
        self.mu, self.prev_inc = 0.0, math.inf  # the last shift that made a step go downhill (the next try starts a tenth of it)
        self.trial = None  # the point x + dz of an accepted step whose potential was evaluated (reused by the next _eval)
        self._loop: CompiledLoop | bool | None = None  # the loop in C (newton_loop), False: the Python loop; bound on first solve

    def potential(self, x_full: np.ndarray, load: float = 1.0) -> float:
        """Total potential at x_full with the loads scaled by `load` [J] (linear terms: -load f_lin . x)."""
        self.ev.evaluate(x_full)
        return self.ev.energy - load * _dot(self.S.f_lin_full, x_full)

    def tangent(self, x_full: np.ndarray, hessian: bool = True):
        """(None, gradient of the nonlinear potential on the free coordinates, reduced Hessian or None)."""
        self.ev.evaluate(x_full)
        return None, self.ev.g.copy(), self.ev.matrix() if hessian else None

    def gradient(self, x_full: np.ndarray) -> np.ndarray:
        self.ev.evaluate(x_full)
        return self.ev.g.copy()

    def positive_definite(self, x_full: np.ndarray, sigma_rel: float) -> bool | None:
        """Reduced Hessian + sigma I positive definite (sigma = sigma_rel x max |H_ii|) by the banded Cholesky; None
        where the band is wide (the caller then counts the inertia). An evaluation at this very array (the result's)
        is reused."""
        if self.ev.at is not x_full:
            self.ev.evaluate(x_full)
        ab = self.ev.band()
        if ab is None:
            return None
        d = ab[-1]
        hmax = float(np.max(np.abs(d), initial=0.0))
        if not hmax > 0:
            return None
        ab[-1] += sigma_rel * hmax
        return dpbtrf(ab, lower=0, overwrite_ab=1)[1] == 0

    def _eval(self) -> None:
        R, ev = self.S, self.ev
        x_full = R.full(self.x)
        trial, self.trial = self.trial, None
        if trial is not None and ev.at is trial and np.array_equal(x_full, trial):
            x_full = trial  # the last step was accepted on its potential: the kernels were evaluated there already
        else:
            ev.evaluate(x_full)
        r = ev.g + self.p
        done = False
        ab = ev.band()
        if ab is not None:
            kmax = float(abs(ab[-1]).max())  # the diagonal: no entry of a positive definite K is larger
            cb, info = dpbtrf(ab, lower=0)
            if info == 0:
                self.dz[:] = -dpbtrs(cb, r, lower=0)[0]
                done = True
            else:  # not positive definite (or round-off made it look so): the plain step by a banded LU first
                self.dz[:] = -_banded_lu_solve(ab, r)
                done = bool(np.all(np.isfinite(self.dz)))
                if self.prev_inc > SHIFT_BELOW and not abs(self.dz / self.scale).max() <= SHIFT_BELOW:
                    self.energy = ev.energy - self.load * _dot(R.f_lin_full, x_full)
                    x_try = R.full(self.x + self.dz)
                    if done and self.potential(x_try, self.load) < self.energy:
                        self.trial = x_try
                    else:
                        done = self._shifted_step(ab, r) or done
        if not done:  # a wide band (or a singular one): banded Cholesky in another order, else sparse LU
            K = ev.matrix()
            kmax = float(np.max(np.abs(K.data), initial=0.0))
            factor = banded_cholesky(K) if ab is None else None
            try:
                self.dz[:] = -(banded_solve(factor, r) if factor is not None else splu(K).solve(r))
            except RuntimeError:  # singular: the loop reads the NaN as not_finite
                self.dz[:] = np.nan
        self.norms[:] = (abs(r).max(), 0.0, abs(self.dz / self.scale).max(), -_dot(r, self.dz), kmax)
        self.prev_inc = self.norms[2]

    def solve(self, x_full: np.ndarray, tol: float, max_iter: int, work: float, load: float = 1.0,
              lam: np.ndarray | None = None, max_step: float = np.inf, finish: float = 0.0) -> NewtonRun:
        """finish > 0: a converged run also evaluates its answer, the potential and positive_definite(x, finish)
        (in the same C call where the loop runs in C: the result needs both, and a second pass costs more)."""
        self.mu, self.prev_inc, self.trial = 0.0, math.inf, None
        if self._loop is None:
            self._loop = compiled_loop(self) or False
        if self._loop and PYTHON_LOOP is False:
            out = self._loop.run(x_full, tol, max_iter, work, load, max_step, finish)
            if out is not None:
                status, it, x, inc, dec, floor, hist, pot, stable = out
                return NewtonRun(status == "converged", status, it, x, self.lam.copy(), float(inc), float(dec),
                                 float(self.norms[0]), floor, hist, pot, stable)
            self.mu, self.prev_inc, self.trial = 0.0, math.inf, None  # (singular band: this solve in Python)
        run = super().solve(x_full, tol, max_iter, work, load, lam, max_step)
        if run.converged and finish > 0:
            run.potential = self.potential(run.x, load)
            run.stable = self.positive_definite(run.x, finish)
        return run

    def _shifted_step(self, ab: np.ndarray, r: np.ndarray) -> bool:
        """The tangent is not positive definite: a Newton step there need not go downhill (measured on coarse
        cantilevers: it climbs out of the valley again and again, 35 iterations with load steps for 6 decoupled
        elements). Solve (K + mu D) dz = -r instead (D = |diag K|, mu from SHIFT up by 10 until the factorisation
        succeeds and the potential falls); near a stable equilibrium K is positive definite again and the full,
        quadratically converging steps return. Only while the updates are above SHIFT_BELOW: closer in, the plain Newton
        step converges to whatever equilibrium is there (a saddle too: the stability check reports it, and leaving
        it is escape_saddle's decision). False if no shift up to SHIFT_MAX lowers the potential."""
        d = np.abs(ab[-1]) + np.finfo(float).eps * float(np.max(np.abs(ab[-1]), initial=0.0))
        mu = max(self.mu * 0.1, SHIFT)
        while mu <= SHIFT_MAX:
            shifted = ab.copy()
            shifted[-1] += mu * d
            cb, info = dpbtrf(shifted, lower=0, overwrite_ab=1)
            if info == 0:
                dz = -dpbtrs(cb, r, lower=0)[0]
                x_try = self.S.full(self.x + dz)
                if self.potential(x_try, self.load) < self.energy:
                    self.dz[:] = dz
                    self.mu = mu
                    self.trial = x_try
                    return True
            mu *= 10.0
        return False
