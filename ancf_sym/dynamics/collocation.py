"""Collocation (implicit Runge-Kutta) time steps: Radau IIA and Gauss-Legendre, on the same StepSystem.

First-order form y = (q, v): q' = v, M v' = F(t) - C v - grad U(q) - J^T lam, Phi(q) = 0. With the s stage
positions Q_i (and stage multipliers) as unknowns, the stage velocities V = W (Q - q_n) / h (W = A^-1 of the
Butcher matrix) are eliminated exactly, leaving for each stage i

    R_i = 1/h^2 sum_j (W^2)_ij M (Q_j - q_n) - 1/h (W 1)_i M v_n + 1/h sum_j W_ij C (Q_j - q_n)
          + grad U(Q_i) + J(Q_i)^T lam_i - F(t_n + c_i h) = 0,        Phi(Q_i) = 0,

with the exact tangent dR_i/dQ_j = (W^2)_ij M / h^2 + W_ij C / h + delta_ij (K(Q_i) + H_Phi(lam_i)).
Radau IIA (order 2s - 1, L-stable, stiffly accurate: q_{n+1} = Q_s) handles the index-3 constraints at every
stage; Gauss-Legendre (order 2s, symplectic: energy of linear systems is conserved exactly) takes the end point
from the quadrature, q_{n+1} = q_n + h sum b_j V_j, so exact constraints are met at the stages only and the end
point drifts by O(h^(s+1)) (reported as the constraint violation).

`stage_function(system, tableau)`: CasADi Functions of (Q, lam, q_n, v_n, h, F) returning the stage residual and
its sparse Jacobian on a StepSystem. The optimal-control transcription (ancf_sym.control) writes the same condensed
equations with its own unknowns (the moved supports' states and the controls enter them; all intervals at once)
and shares the tableaus (`tableau`).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.polynomial.legendre as leg

from ..scene import SceneError
from ..sparsity import dm, mx_nonzeros
from .damping import StiffnessDamping, rayleigh_mx
from .integrator import StepOutcome, initial_acceleration
from .newton import Counters, Factor, NewtonOptions, newton
from .step_system import StepSystem


@dataclass(frozen=True)
class Tableau:
    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int

    @property
    def s(self) -> int:
        return len(self.c)

    @property
    def stiffly_accurate(self) -> bool:
        return bool(np.allclose(self.A[-1], self.b)) and abs(self.c[-1] - 1.0) < 1e-14


def _collocation_matrix(c: np.ndarray) -> np.ndarray:
    """A_ij = int_0^{c_i} l_j(t) dt for the Lagrange basis l_j on the nodes c."""
    s = len(c)
    V = np.vander(c, s, increasing=True)  # V[i, k] = c_i^k; l_j(t) = sum_k coef[k, j] t^k
    coef = np.linalg.inv(V)
    k = np.arange(s)
    P = c[:, None] ** (k + 1)[None, :] / (k + 1)[None, :]  # int_0^{c_i} t^k
    return P @ coef


def tableau(kind: str, stages: int) -> Tableau:
    """Radau IIA ('radau', order 2s-1) or Gauss-Legendre ('gauss', order 2s) collocation with s stages."""
    if isinstance(stages, bool) or not isinstance(stages, (int, np.integer)) or not 1 <= stages <= 4:
        raise SceneError(f"stages must be an integer in 1..4, got {stages!r}")
    s = int(stages)
    if kind == "gauss":
        c = (leg.legroots([0] * s + [1]) + 1) / 2
        order = 2 * s
    elif kind == "radau":
        # right Radau points: zeros of P_s(2x-1) - P_{s-1}(2x-1)
        coef = np.zeros(s + 1)
        coef[s], coef[s - 1] = 1.0, -1.0
        c = np.sort((leg.legroots(coef) + 1) / 2)
        c[-1] = 1.0
        order = 2 * s - 1
    else:
        raise SceneError(f"collocation kind must be 'radau' or 'gauss', got {kind!r}")
    c = np.sort(np.real(c))
    A = _collocation_matrix(c)
    s_ = len(c)
    b = (1.0 / np.arange(1, s_ + 1)) @ np.linalg.inv(np.vander(c, s_, increasing=True))  # int_0^1 l_j
    return Tableau(kind, A, b, c, order)


def stage_function(system: StepSystem, tab: Tableau, linsol: str = "qr") -> dict:
    """CasADi Functions of one collocation step on `system` (unknowns: stage positions Q (nf x s), scaled stage
    multipliers (mc x s); the true multipliers are kc * lam):

    residual(Q, lam, qn, vn, h, F, kc[, kel]) -> (R (s(nf+mc)), norms [|R_q|inf, |Phi|inf])
    iteration(...) -> (dz, norms [|R_q|, |Phi|, |dQ|, |dlam|, max|Jac|]) : full Newton update, sparse `linsol`
    jacobian(...) -> (R, norms [.., .., max|Jac|], Jacobian nonzeros) ; `sparsity` of that Jacobian.
    F: nf x s generalized forces at the stage times (constant forces of linear terms included).
    Equation ordering: for each stage, nf force rows then mc constraint rows; unknowns likewise per stage."""
    S = system
    nf, mc, s = S.nf, S.mc, tab.s
    W = np.linalg.inv(tab.A)
    W2 = W @ W
    w1 = W.sum(axis=1)
    Q = ca.MX.sym("Q", nf, s)
    lam = ca.MX.sym("lam", mc, s)
    qn, vn = ca.MX.sym("qn", nf), ca.MX.sym("vn", nf)
    h, kc = ca.MX.sym("h"), ca.MX.sym("kc")
    F = ca.MX.sym("F", nf, s)
    kel = ca.MX.sym("kel", S.kel.size) if S.kel is not None else None
    Mdm = dm(S.M)
    dQ = Q - ca.repmat(qn, 1, s)
    MdQ = ca.mtimes(Mdm, dQ)
    Mv = ca.mtimes(Mdm, vn)
    CdQ = ca.horzcat(*[rayleigh_mx(S, dQ[:, j], kel)[0] for j in range(s)]) if S.rayleigh is not None else None
    _, C = rayleigh_mx(S, qn, kel)
    rows, blocks_diag, dfv = [], [], []
    phis = []
    if mc:  # constraint, Jacobian and multiplier Hessian as a function of pure symbols (AD needs them)
        qs, ls = ca.MX.sym("q", nf), ca.MX.sym("l", mc)
        ph = S.constraint_mx(qs)
        Hq = ca.hessian(ca.dot(ls, ph), qs)[0] if len(S.cons.qrow) else ca.MX(nf, nf)
        cons_f = ca.Function("constraint_stage", [qs, ls], [ph, ca.jacobian(ph, qs), Hq])
    for i in range(s):
        g, K = S.forces_f(Q[:, i])[:2]
        Ri = ca.mtimes(MdQ, ca.DM(W2[i])) / h**2 - w1[i] / h * Mv + g - F[:, i]
        if CdQ is not None:
            Ri += ca.mtimes(CdQ, ca.DM(W[i])) / h
        Si = K
        if S.damp_f is not None:  # strain-rate damping at the stage velocity V_i = sum_j W_ij (Q_j - q_n) / h
            fd, dfx, dfv_i = S.damp_f(Q[:, i], ca.mtimes(dQ, ca.DM(W[i])) / h)
            Ri += fd
            Si = Si + dfx
            dfv.append(dfv_i)
        if mc:
            phi, Jx, Hl = cons_f(Q[:, i], lam[:, i])
            Ri += kc * ca.mtimes(Jx.T, lam[:, i])
            if len(S.cons.qrow):
                Si = Si + kc * Hl
            rows.append(ca.vertcat(Ri, kc * phi))
            phis.append(phi)
            blocks_diag.append((Si, Jx))
        else:
            rows.append(Ri)
            blocks_diag.append((Si, None))
    R = ca.vertcat(*rows)
    # Jacobian by blocks (the kernels give K; the coupling through M and C is constant per step)
    blocks = []
    for i in range(s):
        row = []
        for j in range(s):
            Bij = W2[i, j] / h**2 * Mdm + (W[i, j] / h * C if S.rayleigh is not None else 0)
            if dfv:
                Bij = Bij + W[i, j] / h * dfv[i]
            Si, Jx = blocks_diag[i]
            if i == j:
                Bij = Bij + Si
            if mc:
                top = ca.horzcat(Bij, kc * Jx.T if i == j else ca.MX(nf, mc))
                bot = ca.horzcat(kc * Jx if i == j else ca.MX(mc, nf), ca.MX(mc, mc))
                Bij = ca.vertcat(top, bot)
            row.append(Bij)
        blocks.append(row)
    Jac = ca.blockcat(blocks)
    Rq = ca.vertcat(*[R[i * (nf + mc):i * (nf + mc) + nf] for i in range(s)])
    rq = ca.mmax(ca.fabs(Rq))
    rc = ca.mmax(ca.fabs(ca.vertcat(*phis))) if mc else ca.MX(0)
    jac_nz = mx_nonzeros(Jac)
    jmax = ca.mmax(ca.fabs(jac_nz))
    dz = -ca.solve(Jac, R, linsol)
    zq = ca.vertcat(*[dz[i * (nf + mc):i * (nf + mc) + nf] for i in range(s)])
    zl = ca.vertcat(*[dz[i * (nf + mc) + nf:(i + 1) * (nf + mc)] for i in range(s)]) if mc else ca.MX(0)
    ins = [Q, lam, qn, vn, h, F, kc] + ([kel] if kel is not None else [])
    names = ["Q", "lam", "qn", "vn", "h", "F", "kc"] + (["kel"] if kel is not None else [])
    return {
        "residual": ca.Function("collocation_residual", ins, [R, ca.vertcat(rq, rc)], names, ["R", "norms"]),
        "iteration": ca.Function("collocation_iteration", ins,
                                 [dz, ca.vertcat(rq, rc, ca.mmax(ca.fabs(zq)), ca.mmax(ca.fabs(zl)), jmax)],
                                 names, ["dz", "norms"]),
        "jacobian": ca.Function("collocation_jacobian", ins, [R, ca.vertcat(rq, rc, jmax), jac_nz], names,
                                ["R", "norms", "jac"]),
        "sparsity": Jac.sparsity(),
    }


class _StageNewton:
    """Adapter with the buffer interface of StepSystem that `newton` drives (x: stage positions, lam)."""

    def __init__(self, S: StepSystem, fns: dict, s: int):
        import scipy.sparse as sp
        self.S, self.s = S, s
        nf, mc = S.nf, S.mc
        self.nf, self.mc = nf * s, mc * s
        self.nz = self.nf + self.mc
        self.x, self.lam = np.zeros(nf * s), np.zeros(mc * s)
        self.qn, self.vn, self.h, self.F, self.kc = np.zeros(nf), np.zeros(nf), np.zeros(1), np.zeros(nf * s), np.ones(1)
        self.r, self.dz, self.norms = np.zeros(self.nz), np.zeros(self.nz), np.zeros(5)
        self._jn = np.zeros(3)
        self.floor, self.span = 0.0, S.span
        spj = fns["sparsity"]
        self.kkt = sp.csc_matrix((np.zeros(spj.nnz()), np.array(spj.row(), dtype=np.int32),
                                  np.array(spj.colind(), dtype=np.int32)), shape=(self.nz, self.nz))
        # the Functions take Q, lam column-major (nf x s): our x, lam hold them stage after stage = same memory
        args = [self.x, self.lam, self.qn, self.vn, self.h, self.F, self.kc] + ([S.kel] if S.kel is not None else [])
        self._bufs = []
        # equation/unknown order inside the Functions is per stage [q rows, constraint rows]; x/lam are split,
        # so the iteration's dz and R are permuted back with `perm`
        perm = np.concatenate([np.r_[i * (nf + mc) + np.arange(nf)] for i in range(s)] +
                              [np.r_[i * (nf + mc) + nf + np.arange(mc)] for i in range(s)]).astype(np.int64)
        self.perm = perm
        self._dz_raw, self._r_raw = np.zeros(self.nz), np.zeros(self.nz)
        for key, outs in (("iteration", (self._dz_raw, self.norms)), ("residual", (self._r_raw, self.norms[:2])),
                          ("jacobian", (self._r_raw, self._jn, self.kkt.data))):
            buf, ev = fns[key].buffer()
            for i, a in enumerate(args):
                buf.set_arg(i, memoryview(a))
            for i, a in enumerate(outs):
                buf.set_res(i, memoryview(a))
            self._bufs.append((buf, ev, args, outs))
        self._it, self._res, self._jac = (b[1] for b in self._bufs)
        if mc:  # modified Newton factorizes the Jacobian in the Functions' order: permute it once per use
            self._P = sp.csc_matrix((np.ones(self.nz), (np.arange(self.nz), perm)), shape=(self.nz, self.nz))

    def iterate(self):
        self._it()
        self.dz[:] = self._dz_raw[self.perm]
        self.floor = float(np.finfo(float).eps * self.norms[4] * self.span)
        return self.dz

    def residual(self):
        self._res()
        self.r[:] = self._r_raw[self.perm]
        return self.r

    def jacobian(self):
        self._jac()
        self.r[:] = self._r_raw[self.perm]
        self.norms[:2] = self._jn[:2]
        self.norms[4] = self._jn[2]
        self.floor = float(np.finfo(float).eps * self._jn[2] * self.span)
        if self.mc:
            return (self._P @ self.kkt @ self._P.T).tocsc()
        return self.kkt


def _lagrange(nodes: np.ndarray, t: float) -> np.ndarray:
    """Weights of the Lagrange polynomial through `nodes` evaluated at t (extrapolation of the last step)."""
    return np.array([np.prod([(t - nodes[m]) / (nodes[j] - nodes[m]) for m in range(len(nodes)) if m != j])
                     for j in range(len(nodes))])


class CollocationIntegrator:
    """Radau IIA / Gauss-Legendre steps with Newton on the exact tangent of the coupled stage system (an Integrator:
    ancf_sym.dynamics.integrator; one step per call, not chunkable)."""
    chunkable = False

    def __init__(self, system: StepSystem, kind: str, stages: int, newton_opts: NewtonOptions, tol_q: float,
                 tol_x: float, counters: Counters):
        if system.drives is not None:
            raise SceneError(f"integrator={kind!r}: drives and torques (time-dependent constraints and forces) run "
                             "with the alpha schemes (newmark, hht, generalized_alpha), not collocation")
        self.S = system
        self.tab = tableau(kind, stages)
        self.opts, self.tol_q, self.tol_x, self.counters = newton_opts, tol_q, tol_x, counters
        self.order = stages  # of the extrapolation error estimate used for step-size control
        self.fns = stage_function(system, self.tab)
        self.N = _StageNewton(system, self.fns, self.tab.s)
        self._factor = Factor()
        nf, mc = system.nf, system.mc
        self.q, self.v, self.a, self.lam = np.zeros(nf), np.zeros(nf), np.zeros(nf), np.zeros(mc)
        self.new = dict(q=np.zeros(nf), v=np.zeros(nf), a=np.zeros(nf), lam=np.zeros(mc))
        self._prev = None  # (h, Q stages) of the last accepted step, for extrapolation
        self.kdamp = StiffnessDamping(system, counters)
        self._W = np.linalg.inv(self.tab.A)

    def initialize(self, q0, v0, Q0, t0: float = 0.0) -> None:
        self.q[:], self.v[:] = q0, v0
        self.kdamp.update(self.q)
        a, lam = initial_acceleration(self.S, q0, v0, Q0, self.kdamp.matrix(), t0)
        self.a[:], self.lam[:] = a, lam

    def _guess(self, h: float) -> np.ndarray:
        """Stage positions: extrapolated collocation polynomial of the last step, else Taylor."""
        c = self.tab.c
        if self._prev is None:
            return np.stack([self.q + ci * h * self.v + 0.5 * (ci * h) ** 2 * self.a for ci in c], axis=1)
        h0, Qp, q_start = self._prev
        nodes = np.r_[0.0, c]
        vals = np.column_stack([q_start, Qp])
        tau = 1.0 + c * h / h0
        return np.column_stack([vals @ _lagrange(nodes, t) for t in tau])

    def attempt(self, t: float, h: float, loads=None) -> StepOutcome:
        """Try the step t -> t + h (loads(t): time-dependent generalized force on the unknowns, or None)."""
        S, N, tab = self.S, self.N, self.tab
        s, nf, mc = tab.s, S.nf, S.mc
        guess = self._guess(h)
        self._guess_cache = guess
        N.x[:] = guess.ravel(order="F")
        kc = S.stiffness_scale() / (h * h)
        if mc:
            N.lam[:] = np.tile(self.lam / kc, s)
        N.qn[:], N.vn[:], N.h[0], N.kc[0] = self.q, self.v, h, kc
        F = np.tile(S.f_lin[:, None], (1, s))
        if loads is not None:
            for i, ci in enumerate(tab.c):
                F[:, i] += loads(t + ci * h)
        N.F[:] = F.ravel(order="F")
        out = newton(N, self._factor, (h, kc), self.opts, self.counters, self.tol_q, self.tol_x)
        if not out.converged:
            return StepOutcome(False, out.iterations, out.reason)
        Qs = N.x.reshape((nf, s), order="F")
        V = (Qs - self.q[:, None]) @ self._W.T / h
        Vd = (V - self.v[:, None]) @ self._W.T / h
        if tab.stiffly_accurate:
            qn1, vn1 = Qs[:, -1].copy(), V[:, -1].copy()
        else:
            qn1 = self.q + h * V @ tab.b
            vn1 = self.v + h * Vd @ tab.b
        self.new["q"][:] = qn1
        self.new["v"][:] = vn1
        self.new["a"][:] = Vd[:, -1]  # (first-step guesses only)
        if mc:
            lam_st = N.lam.reshape((mc, s), order="F") * kc
            self.new["lam"][:] = lam_st[:, -1]
        self._pending = (h, Qs.copy(), self.q.copy())
        return StepOutcome(True, out.iterations)

    def error_estimate(self, h: float) -> np.ndarray:
        """Difference between the step's end point and the extrapolated collocation polynomial of the previous
        step (order s + 1: conservative for methods of order 2s - 1 and 2s)."""
        if self._prev is None:
            return np.zeros_like(self.q)
        h0, Qp, q_start = self._prev
        nodes = np.r_[0.0, self.tab.c]
        pred = np.column_stack([q_start, Qp]) @ _lagrange(nodes, 1.0 + h / h0)
        return self.new["q"] - pred

    def accept(self) -> None:
        self._prev = self._pending
        for k in ("q", "v", "a", "lam"):
            getattr(self, k)[:] = self.new[k]
        self.kdamp.update(self.q)


__all__ = ["Tableau", "tableau", "stage_function", "CollocationIntegrator"]
