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

The one home of these equations (used by the integrator here, the optimal-control transcription with all its
intervals at once, and the control warm start, in NumPy): `stage_rates` (V and the stage accelerations from Q),
`stage_residual` (M a + the other forces), `stage_tangent` (the exact dR/dQ by blocks), `interval_end` (q, v at
the interval's end) and `Tableau.extrapolate` (the interval's polynomial beyond its end: Newton's first guess).
`stage_function(system, tableau)`: CasADi Functions of (Q, lam, q_n, v_n, h, F) returning the stage residual and
its sparse Jacobian on a StepSystem.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.polynomial.legendre as leg
import scipy.sparse as sp

from ancf_sym.util.casadi_buffers import bind
from ancf_sym.scene.builder import SceneError
from ancf_sym.util.sparsity import dm, mx_nonzeros
from ancf_sym.dynamics.stiffness_damping import StiffnessDamping
from ancf_sym.system.damping import rayleigh_mx
from ancf_sym.dynamics.integrator import StepOutcome, initial_acceleration
from ancf_sym.dynamics.newton import Counters, Factor, NewtonOptions, newton
from ancf_sym.system.step_system import StepSystem


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

    @property
    def W(self) -> np.ndarray:
        """A^-1: stage velocities from stage positions, V = (Q - q_n) W^T / h."""
        return np.linalg.inv(self.A)

    def extrapolate(self, q_start: np.ndarray, Q: np.ndarray, tau) -> np.ndarray:
        """The interval's collocation polynomial (through q_start at 0 and the stage positions Q (n x s) at c) at
        the local times tau (n x len(tau)); tau > 1 extrapolates into the next interval."""
        base = lagrange_basis(np.r_[0.0, self.c], np.atleast_1d(np.asarray(tau, float)))
        return np.column_stack([q_start, Q]) @ base.T


def lagrange_basis(nodes: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Lagrange basis values l_r(tau) (len(tau) x len(nodes)) on the nodes."""
    out = np.ones((len(tau), len(nodes)))
    for r in range(len(nodes)):
        for m in range(len(nodes)):
            if m != r:
                out[:, r] *= (tau - nodes[m]) / (nodes[r] - nodes[m])
    return out


# -- the condensed stage equations (dynamics, control transcription and warm start alike) ---------------------------

def _symbolic(*xs) -> bool:
    return any(isinstance(x, (ca.MX, ca.SX, ca.DM)) for x in xs)


def _mul(A, B):
    """A B for CasADi operands (SciPy matrices as DM with their pattern) or NumPy/SciPy ones."""
    if _symbolic(A, B):
        return ca.mtimes(dm(A) if sp.issparse(A) else A, dm(B) if sp.issparse(B) else B)
    return A @ B


def _per_interval(row: np.ndarray, K: int, symbolic: bool):
    """kron(I_K, row): the same stage weights in each of K intervals (sparse DM or dense array)."""
    if symbolic:
        return dm(sp.kron(sp.identity(K, format="csc"), sp.csc_matrix(row)))
    return row if K == 1 else np.kron(np.eye(K), row)


def _columns(x, n: int):
    return x if _symbolic(x) else np.asarray(x, float).reshape(n, -1, order="F")


def stage_rates(tab: Tableau, Q, qn, vn, h):
    """Stage velocities V and accelerations A (n x K s, like Q) of K intervals at once: Q holds the stage positions
    interval after interval, qn and vn (n x K) the intervals' start states. With W = A^-1 (the collocation
    polynomial through q_n and the stages), V = (Q - q_n) W^T / h and A = (V - v_n) W^T / h per interval.
    CasADi expressions or NumPy arrays."""
    sym = _symbolic(Q, qn, vn, h)
    n = Q.shape[0]
    qn, vn = _columns(qn, n), _columns(vn, n)
    K = qn.shape[1]
    W = tab.W
    Wb = _per_interval(W.T, K, sym)  # (X Wb)[:, k s + j] = sum_m X[:, k s + m] W[j, m]
    R1 = _per_interval(W.sum(axis=1)[None, :], K, sym)  # (K x K s): the start value x (W 1)_j
    V = (_mul(Q, Wb) - _mul(qn, R1)) / h
    A = (_mul(V, Wb) - _mul(vn, R1)) / h
    return V, A


def stage_residual(tab: Tableau, h, M, Q, qn, vn, forces=None):
    """The condensed collocation equations R = M a(Q) + forces (n x K s, one column per stage) and the stage
    velocities and accelerations (V, A) of `stage_rates`. forces: the other terms at the stages (internal minus
    external), an array/expression or a function of V (velocity-dependent forces); None: inertia alone."""
    V, A = stage_rates(tab, Q, qn, vn, h)
    R = _mul(M, A)
    if forces is not None:
        R = R + (forces(V) if callable(forces) else forces)
    return R, V, A


def stage_tangent(tab: Tableau, h, M, diag: list, velocity: list | None = None) -> list:
    """The exact tangent dR_i/dQ_j of one interval's stage equations as s x s blocks (nested lists; assemble with
    ca.blockcat or sp.bmat): (W^2)_ij M / h^2 + W_ij D_i / h + delta_ij K_i, with diag[i] = K_i the position
    derivative of stage i's forces and velocity[i] = D_i their velocity derivative (None: no velocity forces)."""
    W = tab.W
    W2 = W @ W
    blocks = []
    for i in range(tab.s):
        row = []
        for j in range(tab.s):
            B = W2[i, j] / h**2 * M
            if velocity is not None:
                B = B + W[i, j] / h * velocity[i]
            if i == j:
                B = B + diag[i]
            row.append(B)
        blocks.append(row)
    return blocks


def interval_end(tab: Tableau, h, qn, vn, Q, V, A):
    """(q, v) at the ends of K intervals (n x K): Q's last stage if the method is stiffly accurate (Radau IIA), else
    q_n + h sum_j b_j V_j; v_n + h sum_j b_j A_j."""
    sym = _symbolic(Q, qn, vn, h)
    n = Q.shape[0]
    qn, vn = _columns(qn, n), _columns(vn, n)
    Bk = _per_interval(tab.b[:, None], qn.shape[1], sym)  # (K s x K): quadrature over each interval
    s = tab.s
    q_end = Q[:, s - 1::s] if tab.stiffly_accurate else qn + h * _mul(V, Bk)
    return q_end, vn + h * _mul(A, Bk)


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
    Q = ca.MX.sym("Q", nf, s)
    lam = ca.MX.sym("lam", mc, s)
    qn, vn = ca.MX.sym("qn", nf), ca.MX.sym("vn", nf)
    h, kc = ca.MX.sym("h"), ca.MX.sym("kc")
    F = ca.MX.sym("F", nf, s)
    kel = ca.MX.sym("kel", S.kel.size) if S.kel is not None else None
    _, C = rayleigh_mx(S, qn, kel)
    diag, dfv, jacs, phis = [], [], [], []
    if mc:  # constraint, Jacobian and multiplier Hessian as a function of pure symbols (AD needs them)
        qs, ls = ca.MX.sym("q", nf), ca.MX.sym("l", mc)
        ph = S.constraint_mx(qs)
        Hq = ca.hessian(ca.dot(ls, ph), qs)[0] if len(S.cons.qrow) else ca.MX(nf, nf)
        cons_f = ca.Function("constraint_stage", [qs, ls], [ph, ca.jacobian(ph, qs), Hq])

    def forces(V):
        """Stage i: grad U(Q_i) + C V_i + strain-rate damping(Q_i, V_i) + J(Q_i)^T lam_i - F_i."""
        cols = []
        for i in range(s):
            g, K = S.forces_f(Q[:, i])[:2]
            fi = g - F[:, i]
            if S.rayleigh is not None:
                fi += rayleigh_mx(S, V[:, i], kel)[0]
            if S.damp_f is not None:
                fd, dfx, dfv_i = S.damp_f(Q[:, i], V[:, i])
                fi += fd
                K = K + dfx
                dfv.append(dfv_i)
            if mc:
                phi, Jx, Hl = cons_f(Q[:, i], lam[:, i])
                fi += kc * ca.mtimes(Jx.T, lam[:, i])
                if len(S.cons.qrow):
                    K = K + kc * Hl
                phis.append(phi)
                jacs.append(Jx)
            diag.append(K)
            cols.append(fi)
        return ca.horzcat(*cols)
    Rq_cols = stage_residual(tab, h, S.mass_dm(), Q, qn, vn, forces)[0]
    R = ca.vertcat(*[ca.vertcat(Rq_cols[:, i], kc * phis[i]) if mc else Rq_cols[:, i] for i in range(s)])
    # Jacobian by blocks (the kernels give K; the coupling through M and C is constant per step)
    velocity = None
    if S.rayleigh is not None or dfv:
        velocity = [(C if S.rayleigh is not None else 0) + (dfv[i] if dfv else 0) for i in range(s)]
    blocks = stage_tangent(tab, h, S.mass_dm(), diag, velocity)
    if mc:  # each stage's constraint rows and multiplier columns
        blocks = [[ca.vertcat(ca.horzcat(B, kc * jacs[i].T if i == j else ca.MX(nf, mc)),
                              ca.horzcat(kc * jacs[i] if i == j else ca.MX(mc, nf), ca.MX(mc, mc)))
                   for j, B in enumerate(row)] for i, row in enumerate(blocks)]
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
            buf, ev = bind(fns[key], args, outs)
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
        return self.tab.extrapolate(q_start, Qp, 1.0 + c * h / h0)

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
        V, Vd = stage_rates(tab, Qs, self.q, self.v, h)
        qn1, vn1 = interval_end(tab, h, self.q, self.v, Qs, V, Vd)
        self.new["q"][:] = qn1[:, 0]
        self.new["v"][:] = vn1[:, 0]
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
        return self.new["q"] - self.tab.extrapolate(q_start, Qp, 1.0 + h / h0)[:, 0]

    def accept(self) -> None:
        self._prev = self._pending
        for k in ("q", "v", "a", "lam"):
            getattr(self, k)[:] = self.new[k]
        self.kdamp.update(self.q)


__all__ = ["Tableau", "tableau", "lagrange_basis", "stage_rates", "stage_residual", "stage_tangent", "interval_end",
           "stage_function", "CollocationIntegrator"]
