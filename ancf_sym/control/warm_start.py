"""The warm start: the problem's own collocation equations integrated interval by interval for a smooth
rest-to-rest support motion, so that IPOPT starts with every dynamics row satisfied."""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp

from ancf_sym.dynamics.collocation import interval_end, stage_rates, stage_residual, stage_tangent
from ancf_sym.control.bounds import Bounds
from ancf_sym.control.model import ControlModel, newton
from ancf_sym.control.options import ControlOptions
from ancf_sym.control.transcription import Transcription


class WarmStart:
    """Initial guesses of a control problem's decision vector, from the model's own collocation equations (so
    that IPOPT starts with every dynamics row satisfied) or from a given trajectory."""

    def __init__(self, model: ControlModel, options: ControlOptions, bounds: Bounds, transcription: Transcription,
                 q_start: np.ndarray):
        self.model, self.options, self.bounds, self.tr = model, options, bounds, transcription
        self.q_start = q_start

    def naive_motion(self, T: float) -> Callable:
        """Smooth rest-to-rest support motion (quintic, zero velocity and acceleration at both ends): a function
        of t giving (s, s', s'') arrays (len(t) x channels)."""
        m, b = self.model, self.bounds
        s0, sT = m.chan_vector(b.start_values), m.chan_vector(b.end_values)
        d = sT - s0

        def motion(t):
            x = np.clip(np.atleast_1d(np.asarray(t, float)) / T, 0.0, 1.0)
            p = 10 * x**3 - 15 * x**4 + 6 * x**5
            dp = (30 * x**2 - 60 * x**3 + 30 * x**4) / T
            ddp = (60 * x - 180 * x**2 + 120 * x**3) / T**2
            return s0 + np.multiply.outer(p, d), np.multiply.outer(dp, d), np.multiply.outer(ddp, d)
        return motion

    def guess_from_trajectory(self, T: float, q_of_t: Callable, v_of_t: Callable, motion: Callable,
                              forces: Callable | None = None) -> np.ndarray:
        """Decision vector from free coordinates q_of_t(t) and velocities v_of_t(t) ((len(t), nf) arrays), the
        support motion motion(t) -> (s, s', s'') and the controlled forces forces(t) -> (len(t), nF)."""
        m, tr = self.model, self.tr
        nf, nc = m.nf, m.nc
        tn = tr.node_times(T)
        Z = np.zeros((tr.Nn, tr.nz))
        Z[:, :nf], Z[:, nf:2 * nf] = q_of_t(tn), v_of_t(tn)
        sp_, sv_, _ = motion(tn)
        Z[:, 2 * nf:2 * nf + nc], Z[:, 2 * nf + nc:] = sp_, sv_
        tp = tr.point_times(T)
        U = np.zeros((tr.Pp, m.nu))
        if nc:
            U[:, :nc] = motion(tp)[2]
        if m.nF and forces is not None:
            U[:, nc:] = forces(tp)
        return tr.pack(Z, U, T)

    def collocation_simulation(self, T: float, controls: np.ndarray,
                               max_iter: int = 20) -> tuple[np.ndarray, bool, str]:
        """Integrate the scene with the OCP's own collocation equations for given point controls (Pp x nu), from
        the start state: each interval's stage equations solved by Newton on their exact sparse Jacobian.
        Returns (decision vector, converged?, message); the vector satisfies every dynamics row the NLP has."""
        m, tr = self.model, self.tr
        K, s, nf, nc = self.options.K, self.options.s, m.nf, m.nc
        tab = self.options.tab
        h = T / K
        U = np.asarray(controls, float).reshape(tr.Pp, m.nu)
        Mff, Mfc = m.Mff, m.Mfc
        Z = np.zeros((tr.Nn, tr.nz))
        q, v = self.q_start.copy(), np.zeros(nf)
        sc, svc = m.chan_vector(self.bounds.start_values), np.zeros(nc)
        fscale = max(float(np.max(np.abs(m.f_lin))), 1e-300)
        message = ""
        ok_all = True
        Qs = np.array([q + tab.c[j] * h * v for j in range(s)])  # stage positions, a row per stage
        for k in range(K):
            Uk = U[k * s:(k + 1) * s]
            Ua, Uf = Uk[:, :nc], Uk[:, nc:]
            SV = svc[None, :] + h * tab.A @ Ua
            SP = sc[None, :] + h * tab.A @ SV
            rest = np.tile(-m.f_lin[:, None], (1, s))  # the support and control forces at the stages
            if nc:
                rest += Mfc @ Ua.T
            if m.nF:
                rest -= m.Bf @ Uf.T

            def residual(Qs, q=q, v=v, rest=rest, SP=SP):
                """The interval's stage equations (rows: stages) and their exact Jacobian."""
                g, Ks = np.zeros((nf, s)), []
                for j in range(s):
                    g[:, j], Kj, _ = m.forces(Qs[j], SP[j])
                    Ks.append(Kj)
                R = stage_residual(tab, h, Mff, Qs.T, q, v, rest + g)[0]
                return R.T, lambda: sp.bmat(stage_tangent(tab, h, Mff, Ks), format="csc")
            Qs, rn, ok = newton(residual, Qs, 1e-9 * fscale, max_iter, halvings=20,
                                tol_step=1e-12 * m.length_scale)
            if not ok:
                ok_all = False
                message = f"interval {k}: Newton did not converge (residual {rn:.3g} N)"
                break
            V, Acc = stage_rates(tab, Qs.T, q, v, h)
            r = k * (s + 1)
            Z[r] = np.r_[q, v, sc, svc]
            for j in range(s):
                Z[r + 1 + j] = np.r_[Qs[j], V[:, j], SP[j], SV[j]]
            Qs_prev, q_prev = Qs, q
            q, v = (x[:, 0] for x in interval_end(tab, h, q, v, Qs.T, V, Acc))
            sc, svc = sc + h * tab.b @ SV, svc + h * tab.b @ Ua
            Qs = tab.extrapolate(q_prev, Qs_prev.T, 1.0 + tab.c).T  # the interval's polynomial, extrapolated
        if ok_all:
            Z[-1] = np.r_[q, v, sc, svc]
        else:  # hold the last good state
            last = k * (s + 1)
            Z[last:] = np.r_[q, v, sc, svc]
        return tr.pack(Z, U, T), ok_all, message

    def warm_start(self) -> tuple[np.ndarray, dict]:
        """A simulation of the naive (quintic rest-to-rest) support motion with the OCP's own collocation
        equations: every dynamics row holds at the start, only the end conditions are off."""
        T = self.options.T_guess
        motion = self.naive_motion(T)
        U = np.zeros((self.tr.Pp, self.model.nu))
        if self.model.nc:
            U[:, :self.model.nc] = motion(self.tr.point_times(T))[2]
        w, ok, msg = self.collocation_simulation(T, U)
        return w, {"method": "collocation simulation of a quintic rest-to-rest motion", "converged": ok,
                   "message": msg}
