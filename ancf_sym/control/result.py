"""The result of a control problem: the optimum's trajectories, controls, timings and the re-simulation."""
from __future__ import annotations

from typing import Any

import numpy as np

from ancf_sym.util.names import lookup
from ancf_sym.scene.builder import SceneError
from ancf_sym.control.resimulation import ResimulationReport, resimulate_motion
from ancf_sym.dynamics.collocation import lagrange_basis as _basis
from ancf_sym.control.view import ControlProblemView



class ControlResult:
    """The optimum (or, on failure, IPOPT's last iterate) of a ControlProblem.

    status / success / iterations / wall_s (IPOPT), cost, T; t_nodes, q (full coordinates at the state nodes,
    (len, n)), support channels `channel(name)` -> (position, velocity) at the nodes, controls at t_points;
    stats (IPOPT's), kernel_time_s (estimated time in the kernels) and resimulate()."""

    def __init__(self, prob: ControlProblemView, w, lam_g, status, success, stats, solve_s, warm_s, warm, attempts=()):
        self.prob, self.w, self.lam_g = prob, w, lam_g
        self.attempts = list(attempts)
        self.status, self.success, self.stats = status, bool(success), stats
        self.iterations = int(sum(a["iterations"] for a in attempts)) if attempts else int(stats.get("iter_count", 0))
        self.wall_s, self.warm_start_s, self.warm = solve_s, warm_s, warm
        self.build_s = prob.build_s + prob.solver_build_s
        Z, U, T = prob.unpack(w)
        self.Z, self.U, self.T = Z, U, T
        self.cost = float(prob.f_function(w))
        self.constraint_violation = prob.violation(w)
        self.violations = prob.violations(w)
        self.t_nodes = prob.node_times(T)
        self.t_points = prob.point_times(T)
        nf, nc = prob.nf, prob.nc
        self.q_free, self.v_free = Z[:, :nf], Z[:, nf:2 * nf]
        self.s, self.sv = Z[:, 2 * nf:2 * nf + nc], Z[:, 2 * nf + nc:]
        self.controls = U

    def summary(self) -> str:
        """One line: status, cost, iterations, wall time, horizon."""
        return (f"IPOPT {self.status}: cost {self.cost:.6g}, {self.iterations} iterations, {self.wall_s:.3g} s "
                f"(+ {self.warm_start_s:.3g} s warm start), horizon {self.T:.4g} s, constraint violation "
                f"{self.constraint_violation:.2g}")

    def __repr__(self) -> str:
        return f"<ControlResult {self.summary()}; controls {self.prob.channels + self.prob.force_names}>"

    def _repr_html_(self) -> str:
        from ancf_sym.util.html import html_table
        return html_table("ControlResult", self.summary(), [
            ("status", self.status), ("cost", f"{self.cost:.6g}"), ("IPOPT iterations", self.iterations),
            ("solve (warm start, build)", f"{self.wall_s:.3g} s ({self.warm_start_s:.3g} s, {self.build_s:.3g} s)"),
            ("horizon", f"{self.T:.4g} s"), ("constraint violation", f"{self.constraint_violation:.2g}"),
            ("controls", ", ".join(self.prob.channels + self.prob.force_names))])

    @property
    def q(self) -> np.ndarray:
        p = self.prob
        return (p.part.E @ self.q_free.T + p.part.c[:, None] + p.B @ self.s.T).T

    def channel(self, name: str):
        k = lookup("support channel", name, self.prob.channels)
        return self.s[:, k], self.sv[:, k]

    def control(self, name: str) -> np.ndarray:
        names = self.prob.channels + self.prob.force_names
        return self.U[:, lookup("control", name, names)]

    def point(self, member: str, at: Any = "end", t: np.ndarray | None = None) -> np.ndarray:
        """Position of a centreline point at the state nodes (t=None) or at times t (collocation polynomials)."""
        idx, wts = self.prob.probe(member, at)
        if t is None:
            return np.stack([self.q[:, row] @ wts for row in idx], axis=1)
        q = self.state_at(t)[0]
        return np.stack([q[:, row] @ wts for row in idx], axis=1)

    def _intervals(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, the interval k of each time, the local time tau in [0, 1] there)."""
        t = np.atleast_1d(np.asarray(t, float))
        h = self.T / self.prob.K
        k = np.clip(np.floor(t / h).astype(int), 0, self.prob.K - 1)
        return t, k, np.clip(t / h - k, 0.0, 1.0)

    def state_at(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(full coordinates, support positions, velocities of the free coordinates) at times t from each interval's
        collocation polynomial (constant at rest after T)."""
        p = self.prob
        t, k, tau = self._intervals(t)
        base = _basis(p.tau, tau)  # (len, s+1)
        nodes = k[:, None] * (p.s + 1) + np.arange(p.s + 1)[None, :]
        Zt = np.einsum("lr,lrz->lz", base, self.Z[nodes])
        after = t >= self.T
        Zt[after] = self.Z[-1]
        nf, nc = p.nf, p.nc
        q = (p.part.E @ Zt[:, :nf].T + p.part.c[:, None] + p.B @ Zt[:, 2 * nf:2 * nf + nc].T).T
        return q, Zt[:, 2 * nf:2 * nf + nc], Zt[:, nf:2 * nf]

    def control_at(self, t) -> np.ndarray:
        """Controls at times t: each interval's Lagrange polynomial through its collocation points (zero after T)."""
        p = self.prob
        t, k, tau = self._intervals(t)
        base = _basis(p.tab.c, tau) if p.s > 1 else np.ones((len(t), 1))
        pts = k[:, None] * p.s + np.arange(p.s)[None, :]
        u = np.einsum("lj,lju->lu", base, self.U[pts])
        u[t > self.T * (1 + 1e-12)] = 0.0
        return u

    def control_in_interval(self, k: int, tau: np.ndarray) -> np.ndarray:
        """Controls of interval k at local times tau in [0, 1] (its Lagrange polynomial through the points)."""
        p = self.prob
        tau = np.atleast_1d(np.asarray(tau, float))
        base = _basis(p.tab.c, tau) if p.s > 1 else np.ones((len(tau), 1))
        return base @ self.U[k * p.s:(k + 1) * p.s]

    def support_motion(self):
        """Functions of t -> (s, s', s'') of the controlled supports consistent with the optimal accelerations:
        s'' = the control polynomials, integrated exactly from the start (a rest-hold after T)."""
        p = self.prob
        return _integrated_motion(self, p)

    def ipopt_times(self) -> dict:
        """Calls and wall time of IPOPT's function evaluations, summed over the attempts."""
        keys = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
        srcs = [a.get("calls", {}) for a in self.attempts] or [self.stats]
        return {k: {"calls": int(sum(d.get(f"n_call_{k}", 0) for d in srcs)),
                    "s": float(sum(d.get(f"t_wall_{k}", 0.0) for d in srcs))} for k in keys}

    def kernel_time(self) -> dict:
        """Estimated time in the compiled kernels during the solve: calls x measured seconds per mapped pass
        (nlp_g: gradients; nlp_jac_g: the full kernels; nlp_hess_l: the third-derivative kernels)."""
        kt = self.prob.kernel_times(self.w)
        it = self.ipopt_times()
        est = it["nlp_g"]["calls"] * kt["gradient"] + it["nlp_jac_g"]["calls"] * kt["full"] + \
            it["nlp_hess_l"]["calls"] * kt["hvp"]
        fn = sum(v["s"] for v in it.values())
        return {"kernel_s": est, "functions_s": fn, "solve_s": self.wall_s,
                "share_of_solve": est / self.wall_s if self.wall_s > 0 else float("nan"),
                "per_call": kt}

    def resimulate(self, dt: float | None = None, after: float | None = None, integrator: str = "radau",
                   **kw) -> ResimulationReport:
        """Integrate the optimal controls with the dynamics integrator (ancf_sym.dynamics.simulate, Radau IIA by
        default, steps dividing the collocation intervals) from the start state, through T and `after` seconds of
        rest (default 3 periods of the slowest mode); compare with the collocation trajectory. See
        resimulate_motion."""
        rep = resimulate_motion(self.prob, self.T, self.support_motion(), self, dt=dt, after=after,
                                integrator=integrator, **kw)
        if rep is None:
            raise SceneError("re-simulation with the dynamics integrator needs a scene whose only position support "
                             "is the controlled one (moving frame); this scene has others")
        return rep

    def to_dict(self) -> dict:
        return {"status": self.status, "success": self.success, "iterations": self.iterations, "wall_s": self.wall_s,
                "build_s": self.build_s, "cost": self.cost, "T": self.T,
                "constraint_violation": self.constraint_violation}


def _integrated_motion(res: ControlResult, p: ControlProblemView):
    """Exact integration of the piecewise polynomial accelerations (per interval) from s(0), s'(0)."""
    K, h, s = p.K, res.T / p.K, p.s
    nc = p.nc
    c = p.tab.c
    # per interval: acceleration polynomial coefficients in tau (highest first), then s', s polynomials
    polys = []
    s0, v0 = res.Z[0, 2 * p.nf:2 * p.nf + nc].copy(), res.Z[0, 2 * p.nf + nc:].copy()
    for k in range(K):
        ak = res.U[k * s:(k + 1) * s, :nc]
        entry = []
        for ch in range(nc):
            a_poly = np.polyfit(c, ak[:, ch], s - 1) if s > 1 else np.array([ak[0, ch]])
            a_t = np.poly1d(a_poly) * 1.0  # in tau; d/dt = (1/h) d/dtau
            v_t = np.polyint(a_t) * h + v0[ch]  # v(tau) = v0 + h int a dtau
            x_t = np.polyint(v_t) * h + s0[ch]
            entry.append((x_t, v_t, a_t))
        polys.append(entry)
        s0 = np.array([e[0](1.0) for e in entry])
        v0 = np.array([e[1](1.0) for e in entry])
    end = (s0, v0)

    def motion(t):
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.floor(t / h).astype(int), 0, K - 1)
        tau = t / h - k
        X, V, A = (np.zeros((len(t), nc)) for _ in range(3))
        for i, (ki, ti) in enumerate(zip(k, tau)):
            if t[i] >= res.T:
                X[i], V[i] = end[0] + end[1] * (t[i] - res.T), end[1]
                continue
            for ch in range(nc):
                x_t, v_t, a_t = polys[ki][ch]
                X[i, ch], V[i, ch], A[i, ch] = x_t(ti), v_t(ti), a_t(ti)
        return X, V, A
    return motion
