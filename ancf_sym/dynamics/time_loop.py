"""The time loop of a dynamic run: fixed steps (many per compiled call where the integrator is chunkable) or
adaptive ones, step rejection and halving on Newton failure, the work of the damping forces and time loads along
each step, and the outputs.

A step whose Newton iteration fails is rejected and retried with half the step (recorded in `rejected`); the run
ends with status "newton_failed" at the last good state when the step would fall below dt_min. damping_work and
external_work are the work of the forces of the discrete equations along each step, dq.(f_n + f_n+1)/2 (exact
in the energy identity of trapezoidal Newmark).
"""
from __future__ import annotations

import bisect
import functools
import math
from typing import Any, Callable

import numpy as np

from ancf_sym.contact import gap as contact_gap
from ancf_sym.system.damping import damping_force_rows
from ancf_sym.dynamics.integrator import ChunkedIntegrator, Integrator
from ancf_sym.dynamics.options import DynamicOptions
from ancf_sym.dynamics.recording import ENERGY_CREATION_LIMIT, Recorder, hermite
from ancf_sym.system.step_system import StepSystem
from ancf_sym.dynamics.time_loads import LoadSum

CHUNK = 64  # steps per compiled call in fixed-step runs of the alpha schemes (the rest of the grid: step by step)


@functools.lru_cache(maxsize=256)
def chunk_size(n_grid: int) -> int:
    """Steps per compiled call on a fixed grid of n_grid steps (0: none, shorter than CHUNK): the size in
    [CHUNK/2, CHUNK] that leaves the fewest steps to the one-by-one loop (a step there costs ~2x a chunked one),
    the largest of those; e.g. 1000 steps: 20 x 50 instead of 15 x 64 + 40."""
    if n_grid < CHUNK:
        return 0
    return min(range(CHUNK // 2, CHUNK + 1), key=lambda s: (n_grid % s, -s))


class TimeLoop:
    """The time loop: fixed or adaptive steps with rejection, or (fixed step, an integrator that is chunkable)
    chunks of chunk_size(n) steps in one compiled call; bookkeeping and outputs per accepted step."""

    def __init__(self, S: StepSystem, integ: Integrator, opts: DynamicOptions, loads: LoadSum | None,
                 rec: Recorder, outputs: np.ndarray | None, every: int | None,
                 progress: Callable[[float, float], Any] | None, dt_min: float, dt_max: float, err_tol: float):
        self.S, self.integ, self.opts, self.loads, self.rec = S, integ, opts, loads, rec
        self.outputs, self.every, self.progress = outputs, every, progress
        self.dt_min, self.dt_max, self.err_tol = dt_min, dt_max, err_tol
        self.t = opts.t_start
        self.eps_t = 1e-9 * opts.dt
        self._const_pl: dict = {}
        self.W_d = self.W_ext = 0.0
        self.steps, self.rejected = 0, []
        self.status, self.message = "completed", ""
        self.h_min, self.h_max = math.inf, 0.0
        # the works of damping and loads feed the energy balance only: not booked in a run without energies
        self.book = rec.with_energies
        self.fd_prev = S.damping_force(integ.q, integ.v, self.t) if S.damped and self.book else None
        self.Qn = loads(opts.t_start) if loads else None
        self.fD_prev = S.drive_force(integ.q, integ.lam, self.t)  # drives' and torques' force (their work: external)
        self.lam_prev = integ.lam.copy()
        # penalty contact: every accepted state checked for a surface the law's points missed (contact.gap)
        self.gaps = contact_gap.Watch(S) if contact_gap.checked_contacts(S.asm.scene) else None
        self.free = None  # contact scenes: chunks on the contact-free graph while out of reach (dynamics.reach)
        self.on_step = None  # called as on_step(t_new) after each step accepted one at a time (the integrator's state)
        self.out_i = 0
        self._out = outputs.tolist() if outputs is not None else None  # (bisection in _accepted_many)
        if outputs is None or outputs[0] <= self.t + self.eps_t:
            rec.record(self.t, integ.q, integ.v, 0.0, 0.0, integ.lam)
            self.out_i = 1

    # -- bookkeeping ------------------------------------------------------------------------------------------
    def _accepted(self, t_old, t_new, q_old, v_old, q_new, v_new, fd, lam_new=None):
        """Work of the scheme's own forces along the step, dq.(f_n + f_n+1)/2 (the trapezoidal rule's energy
        identity, exact for Newmark; f_n is the force of the equation that ended at t_n, with its damping matrix),
        then the outputs in (t_old, t_new]. lam_new: the multipliers at t_new (drives' reactions)."""
        lam_old = self.lam_prev
        if self.fD_prev is not None:
            fD = self.S.drive_force(q_new, lam_new, t_new)
            self.W_ext += 0.5 * float((q_new - q_old) @ (self.fD_prev + fD))
            self.fD_prev = fD
            self.lam_prev = np.array(lam_new, float)
        if self.book and (fd is not None or self.loads is not None):
            dq = q_new - q_old
            if fd is not None:
                self.W_d += 0.5 * float(dq @ (self.fd_prev + fd))
                self.fd_prev = fd
            if self.loads is not None:
                Qnew = self.loads(t_new)
                self.W_ext += 0.5 * float(dq @ (self.Qn + Qnew))
                self.Qn = Qnew
        self.steps += 1
        h = t_new - t_old
        self.h_min, self.h_max = min(self.h_min, h), max(self.h_max, h)
        self.t = t_new
        rec, out = self.rec, self.outputs
        if out is None:
            if self.steps % self.every == 0 or t_new >= self.opts.t_end - self.eps_t:
                rec.record(t_new, q_new, v_new, self.W_d, self.W_ext, lam_new)
                if self.progress:
                    self.progress(t_new, self.opts.t_end)
            return
        while self.out_i < len(out) and out[self.out_i] <= t_new + self.eps_t:
            tau = out[self.out_i]
            if abs(tau - t_new) <= self.eps_t:
                rec.record(tau, q_new, v_new, self.W_d, self.W_ext, lam_new)
            else:
                qi, vi = hermite(t_old, t_new, q_old, v_old, q_new, v_new, tau)
                li = None if lam_new is None else lam_old + (tau - t_old) / (t_new - t_old) * (lam_new - lam_old)
                rec.record(tau, qi, vi, self.W_d, self.W_ext, li)
            self.out_i += 1
            if self.progress:
                self.progress(tau, self.opts.t_end)

    def _check_gaps(self, flush: bool = False) -> None:
        """End the run (status contact_penetration_hidden) once an accepted state's centre line reached into a
        surface that the penalty law's points did not see."""
        w = self.gaps
        if flush:
            w.flush()
        if w.found is not None and self.status == "completed":
            self.status = contact_gap.DYNAMIC_STATUS
            self.message = (f"at t = {w.found[0]:.6g} s {w.found[1]}; outputs after that time are not valid")

    def _check_energy(self) -> None:
        """End the run (status energy_blowup) once the recorded energy balance shows the scheme creating energy."""
        b = self.rec.blowup
        if b is not None and self.status == "completed":
            self.status = "energy_blowup"
            self.message = (f"the integrator created {b[1]:.3g} J by t = {b[0]:.6g} s, more than "
                            f"{ENERGY_CREATION_LIMIT:g} x the energy scale {b[2]:.3g} J: the run went unstable "
                            f"(try a smaller dt or more numerical dissipation); outputs after that time are not valid")

    # -- loops ------------------------------------------------------------------------------------------------
    def go(self):
        o = self.opts
        if o.adaptive:
            self.per_step(o.t_end)
            if self.gaps is not None:
                self._check_gaps(flush=True)
            return
        n_grid = o.n_grid
        k = 0
        if self.integ.chunkable:
            size = chunk_size(n_grid)
            while size and n_grid - k >= size and self.status == "completed":
                n_ok = self.chunk(k, size)
                k += n_ok
                if n_ok < size:  # the graph flagged step k+1: the per-step loop takes it (Newton in Python, rejection)
                    self.per_step(self.grid(k + 1), k)
                    k += 1
            if k < n_grid and self.status == "completed":  # the rest (< size steps): the same step graph, one by one
                self.per_step(self.grid(n_grid), k)  # (cheaper than building a chunk function of that length)
        else:
            self.per_step(o.t_start + n_grid * o.dt, 0)
        if self.status == "completed" and self.t < o.t_end - self.eps_t:
            self.per_step(o.t_end, n_grid)
        if self.gaps is not None:
            self._check_gaps(flush=True)

    def grid(self, k: int) -> float:
        return self.opts.t_start + k * self.opts.dt

    def chunk(self, k: int, n: int) -> int:
        """Steps k+1 .. k+n in one call; returns how many were accepted."""
        integ: ChunkedIntegrator = self.integ  # (chunkable)
        S, o = self.S, self.opts
        nf = S.nf
        if self.loads is None:  # the same constant load at every step: one array per chunk length
            pl = self._const_pl.get(n)
            if pl is None:
                pl = self._const_pl[n] = np.repeat(-S.f_lin[:, None], n, axis=1)
                pl.flags.writeable = False  # (run_chunk copies a read-only load array into its buffer once)
        else:
            pl = -np.column_stack([S.f_lin + self.loads(self.grid(k + j + 1)) for j in range(n)])
        if S.nw:  # the drives' time inputs below the loads
            pl = np.vstack([pl, np.column_stack([S.w(self.grid(k + j + 1)) for j in range(n)])])
        q_old, v_old = integ.q.copy(), integ.v.copy()
        if self.free is not None:
            states, n_ok, free = self.free.run_chunk(o.dt, pl)
        else:
            (states, n_ok), free = integ.run_chunk(o.dt, pl), False
        if self.gaps is not None and n_ok and not free:  # (free: every state out of reach, no gap below 0)
            self.gaps.check([self.grid(k + j + 1) for j in range(n_ok)], states[:n_ok, :nf])
            self._check_gaps()
        t_old = self.t
        if (not self.book or (not S.damped and self.loads is None)) and S.drives is None:  # only the outputs
            self._accepted_many(k, n_ok, states, q_old, v_old)
            self._check_energy()
            return n_ok
        times = [self.grid(k + j + 1) for j in range(n_ok)]  # (the water's forces under waves read the time)
        if free:  # every kept state out of reach: the contacts' damping and friction forces are exactly 0
            FS = self.free.free_S
            FD = damping_force_rows(FS, states[:n_ok, :nf], states[:n_ok, nf:2 * nf], times) if FS.damped and \
                self.book else None
            if FD is None:
                self.fd_prev = np.zeros(nf)
                if self.loads is None and S.drives is None:
                    self._accepted_many(k, n_ok, states, q_old, v_old)
                    self._check_energy()
                    return n_ok
                FD = np.zeros((n_ok, nf))
        else:
            FD = damping_force_rows(S, states[:n_ok, :nf], states[:n_ok, nf:2 * nf], times) if S.damped and \
                self.book else None
        for j in range(n_ok):
            t_new = self.grid(k + j + 1)
            q_new, v_new = states[j, :nf], states[j, nf:2 * nf]
            fd = None if FD is None else FD[j]
            self._accepted(t_old, t_new, q_old, v_old, q_new, v_new, fd, states[j, 5 * nf:5 * nf + S.mc])
            t_old, q_old, v_old = t_new, q_new, v_new
        self._check_energy()
        return n_ok

    def _accepted_many(self, k: int, n_ok: int, states: np.ndarray, q_old: np.ndarray, v_old: np.ndarray):
        """Bookkeeping of the accepted grid steps k+1 .. k+n_ok of a chunk (nothing to integrate along them): the
        outputs that fall in them, as `_accepted` would record them step by step, recorded together
        (Recorder.record_many). (Plain float arithmetic and bisection: a handful of numbers per chunk, where numpy
        calls cost microseconds each right after the compiled chunk.)"""
        if not n_ok:
            return
        nf = self.S.nf
        out, o = self.outputs, self.opts
        t0, dt, eps_t = o.t_start, o.dt, self.eps_t
        t_first = self.t
        steps0 = self.steps
        self.steps += n_ok
        self.h_min, self.h_max = min(self.h_min, dt), max(self.h_max, dt)
        self.t = self.grid(k + n_ok)
        if out is None:
            last = self.steps if self.t >= o.t_end - eps_t else None
            js = [s - steps0 - 1 for s in range(steps0 + 1, self.steps + 1) if s % self.every == 0 or s == last]
            if js:
                rows = states[js]
                self._record_many([self.grid(k + j + 1) for j in js], rows[:, :nf], rows[:, nf:2 * nf])
            return
        # the outputs in (t_first, T(n_ok - 1)] and, for each, the first step j that ends at or after it (T(j) =
        # t_start + (k + 1 + j) dt, the grid's times as `grid` computes them)
        i0 = self.out_i
        i1 = bisect.bisect_right(self._out, t0 + (k + n_ok) * dt + eps_t, i0)
        if i1 == i0:
            return
        taus, js = self._out[i0:i1], []
        for tau in taus:
            x = tau - eps_t
            j = min(max(int((x - t0) / dt) - k - 1, 0), n_ok)
            while j < n_ok and t0 + (k + 1 + j) * dt < x:
                j += 1
            while j > 0 and t0 + (k + j) * dt >= x:
                j -= 1
            js.append(j)
        rows = states[js]  # (a copy: the interpolated rows are written in)
        Q, V = rows[:, :nf], rows[:, nf:2 * nf]
        for i, (tau, j) in enumerate(zip(taus, js)):
            tj = t0 + (k + 1 + j) * dt
            if abs(tau - tj) > eps_t:
                if j == 0:
                    ta, qa, va = t_first, q_old, v_old
                else:
                    ta, qa, va = t0 + (k + j) * dt, states[j - 1, :nf], states[j - 1, nf:2 * nf]
                Q[i], V[i] = hermite(ta, tj, qa, va, Q[i], V[i], tau)
        self.out_i = i1
        self._record_many(taus, Q, V)

    def _record_many(self, ts: list, Q: np.ndarray, V: np.ndarray) -> None:
        self.rec.record_many(ts, Q, V, self.W_d, self.W_ext)
        if self.progress:
            for t in ts:
                self.progress(t, self.opts.t_end)

    def per_step(self, t_stop: float, k_grid: int = 0):
        """Single steps with rejection (halving on Newton failure, error control if adaptive) until t_stop."""
        o, integ = self.opts, self.integ
        eps_t = self.eps_t
        h = o.dt
        while self.t < t_stop - eps_t and self.status == "completed":
            t = self.t
            if o.adaptive:
                h_try = min(h, self.dt_max, o.t_end - t)
            else:
                h_try = min(h, t_stop - t)
            if t_stop - (t + h_try) < eps_t:
                h_try = t_stop - t
            t_new = t + h_try
            if abs(t_new - t_stop) <= eps_t:
                t_new = t_stop  # no round-off drift of the fixed-step grid
                h_try = t_new - t
            out = integ.attempt(t, h_try, self.loads)
            reject_reason, err_ratio = None, None
            if not out.converged:
                reject_reason = f"newton: {out.reason}"
            elif o.adaptive:
                e = integ.error_estimate(h_try)
                err_ratio = float(np.max(np.abs(e))) / self.err_tol if len(e) else 0.0
                if not math.isfinite(err_ratio) or err_ratio > 1.0:
                    reject_reason = f"error estimate {err_ratio:.3g} x tol"
            if reject_reason is not None:
                self.rejected.append({"t": t, "h": h_try, "reason": reject_reason, "iterations": out.iterations})
                factor = 0.5 if err_ratio is None or not math.isfinite(err_ratio) else \
                    max(0.2, min(0.9, 0.9 * err_ratio ** (-1.0 / (integ.order + 1))))
                h = h_try * factor
                if h < self.dt_min:
                    self.status = "newton_failed" if err_ratio is None else "step_size_underflow"
                    self.message = (f"step at t = {t:.6g} s rejected with h = {h_try:.3g} s ({reject_reason}); a "
                                    f"smaller step would go below dt_min = {self.dt_min:.3g} s")
                    return
                continue
            q_old, v_old = integ.q.copy(), integ.v.copy()
            q_new, v_new = integ.new["q"].copy(), integ.new["v"].copy()
            fd = self.S.damping_force(q_new, v_new, t_new) if self.S.damped and self.book else None  # (K_el: this step)
            integ.accept()
            if self.on_step is not None:
                self.on_step(t_new)
            self._accepted(t, t_new, q_old, v_old, q_new, v_new, fd, integ.lam)
            self._check_energy()
            if self.gaps is not None:
                self.gaps.add(t_new, q_new)
                self._check_gaps()
            if o.adaptive:  # grow only with a clear margin (the estimate is noisy on stiff, slender members)
                f = 0.8 * max(err_ratio, 1e-10) ** (-1.0 / (integ.order + 1))
                h = min(h_try * min(1.25, max(1.0, f)), self.dt_max) if err_ratio < 0.5 else h_try
            elif h < o.dt:
                h = min(o.dt, 2 * h)  # after a rejection, climb back towards dt

