"""The transcription: K intervals of an implicit Runge-Kutta method in condensed form (stage positions as
variables), the decision-vector layout, and the NLP's constraints with their exact Jacobian and Lagrangian Hessian
assembled from the compiled kernels (see the package docstring).

The NLP is written part by part, one function each: the stage equations and the supports' collocation rows, the
continuity rows, the end-at-rest rows, the path and terminal rows and the cost (ancf_sym.control.bounds), then the
kernels' forces with their Jacobian and Hessian blocks at all collocation points."""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels
from ancf_sym.model.assembly import MappedKernel
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.dynamics.collocation import Tableau, interval_end, stage_residual
from ancf_sym.util.sparsity import dm as _dm, gather_sum, scatter
from ancf_sym.control.bounds import Bounds, cost, path_rows
from ancf_sym.control.model import ControlModel, end_mode_count
from ancf_sym.control.options import ControlOptions


class Layout:
    """The decision vector, interval after interval: [q_0 | v_k, s_k, s'_k, Q_k (s x nf), SP_k, SV_k, U_k
    (s x ...), q_k+1 (Gauss only) | ... | v_K, s_K, s'_K | T]. Radau's last stage is the interval's end, so
    q_k+1 is that stage's variable (no separate copy, no continuity row). idx: the indices of each part
    ("q", "v", "s", "sv" per node (K+1 rows), "Q", "SP", "SV", "U" per interval and stage); iT: the horizon's
    index (free time) or None; nw: the length."""

    def __init__(self, model: ControlModel, options: ControlOptions):
        K, s, nf, nc, nu = options.K, options.s, model.nf, model.nc, model.nu
        radau = options.tab.stiffly_accurate
        self._next = 0
        take = self._take
        iq, iv = np.zeros((K + 1, nf), np.int64), np.zeros((K + 1, nf), np.int64)
        isb, isvb = np.zeros((K + 1, nc), np.int64), np.zeros((K + 1, nc), np.int64)
        iQ, iSP, iSV = np.zeros((K, s, nf), np.int64), np.zeros((K, s, nc), np.int64), np.zeros((K, s, nc), np.int64)
        iU = np.zeros((K, s, nu), np.int64)
        iq[0] = take(nf)
        for k in range(K):
            iv[k], isb[k], isvb[k] = take(nf), take(nc), take(nc)
            iQ[k], iSP[k], iSV[k] = take(s, nf), take(s, nc), take(s, nc)
            iU[k] = take(s, nu) if options.control_form == "polynomial" else np.broadcast_to(take(1, nu), (s, nu))
            iq[k + 1] = iQ[k, s - 1] if radau else take(nf)
        iv[K], isb[K], isvb[K] = take(nf), take(nc), take(nc)
        self.iT = int(take(1)[0]) if options.free_time else None
        self.nw = self._next
        self.idx = {"q": iq, "v": iv, "s": isb, "sv": isvb, "Q": iQ, "SP": iSP, "SV": iSV, "U": iU}

    def _take(self, *shape: int) -> np.ndarray:
        size = int(np.prod(shape))
        out = np.arange(self._next, self._next + size, dtype=np.int64).reshape(shape)
        self._next += size
        return out


@dataclass
class Blocks:
    """The decision vector's parts as CasADi matrices (a column per interval start/end or per collocation point)."""
    w: ca.MX
    T: ca.MX
    h: ca.MX
    q0: ca.MX
    v0: ca.MX
    q1: ca.MX
    v1: ca.MX
    s0: ca.MX
    sv0: ca.MX
    s1: ca.MX
    sv1: ca.MX
    Q: ca.MX
    SP: ca.MX
    SV: ca.MX
    U: ca.MX


def blocks(w: ca.MX, layout: Layout, options: ControlOptions) -> Blocks:
    """Views of w by part: a matrix (last index dimension x the rest) per index array."""
    I = layout.idx

    def mat(ix):
        m = ix.shape[-1]
        cols = ix.size // m if m else int(np.prod(ix.shape[:-1]))
        if m == 0:
            return ca.MX(0, cols)
        return ca.reshape(w[ix.reshape(-1).tolist()], m, cols)
    T = w[layout.iT] if options.free_time else ca.DM(options.T_guess)
    h = T / options.K
    return Blocks(w=w, T=T, h=h, q0=mat(I["q"][:-1]), v0=mat(I["v"][:-1]), q1=mat(I["q"][1:]), v1=mat(I["v"][1:]),
                  s0=mat(I["s"][:-1]), sv0=mat(I["sv"][:-1]), s1=mat(I["s"][1:]), sv1=mat(I["sv"][1:]),
                  Q=mat(I["Q"]), SP=mat(I["SP"]), SV=mat(I["SV"]), U=mat(I["U"]))


def interval_matrices(tab: Tableau, K: int) -> tuple[ca.DM, ca.DM, ca.DM]:
    """(A of every interval, the start repeated over the stages, the quadrature over each interval) as constant
    block-diagonal matrices acting on a row of stage values."""
    IK = sp.identity(K, format="csc")
    Abig = _dm(sp.kron(IK, sp.csc_matrix(tab.A.T)))
    R1 = _dm(sp.kron(IK, sp.csc_matrix(np.ones((1, tab.s)))))
    Bk = _dm(sp.kron(IK, sp.csc_matrix(tab.b[:, None])))  # (Ks x K): quadrature over each interval
    return Abig, R1, Bk


def collocation_rows(model: ControlModel, tab: Tableau, b: Blocks, Abig: ca.DM, R1: ca.DM,
                     Pp: int) -> tuple[list, ca.MX, ca.MX]:
    """The condensed stage equations of all intervals (M a + the support and control forces - f_lin; the kernels'
    grad U is added to these rows later) and the supports' stage values by collocation. Returns (rows, stage
    velocities, stage accelerations)."""
    nc = model.nc
    Ua, Uf = b.U[:nc, :], b.U[nc:, :]
    rest = -ca.repmat(ca.DM(model.f_lin), 1, Pp)
    if nc:
        rest += ca.mtimes(_dm(model.Mfc), Ua)
    if model.nF:
        rest -= ca.mtimes(ca.DM(model.Bf), Uf)
    dyn, Vst, Acc = stage_residual(tab, b.h, model.Mff, b.Q, b.q0, b.v0, rest)
    rows = [ca.vec(dyn)]
    if nc:
        rows += [ca.vec(b.SV - ca.mtimes(b.sv0, R1) - b.h * ca.mtimes(Ua, Abig)),
                 ca.vec(b.SP - ca.mtimes(b.s0, R1) - b.h * ca.mtimes(b.SV, Abig))]
    return rows, Vst, Acc


def continuity_rows(model: ControlModel, tab: Tableau, b: Blocks, Vst: ca.MX, Acc: ca.MX, Bk: ca.DM) -> list:
    """Each interval's end (by the quadrature weights) equals the next interval's start: v (and q for Gauss;
    Radau's last stage is the next start) and the supports' states."""
    nc = model.nc
    rows = []
    q_end, v_end = interval_end(tab, b.h, b.q0, b.v0, b.Q, Vst, Acc)
    if not tab.stiffly_accurate:
        rows.append(ca.vec(b.q1 - q_end))
    rows.append(ca.vec(b.v1 - v_end))
    if nc:
        Ua = b.U[:nc, :]
        rows += [ca.vec(b.s1 - b.s0 - b.h * ca.mtimes(b.SV, Bk)), ca.vec(b.sv1 - b.sv0 - b.h * ca.mtimes(Ua, Bk))]
    return rows


def end_rows(model: ControlModel, w: ca.MX, layout: Layout, q_end: np.ndarray, Phi: np.ndarray, nm: int) -> list:
    """The scene at rest at its end equilibrium q_end on its nm lowest modes (columns of Phi): modal amplitudes
    of the displacement and the velocity vanish at T."""
    K, I = layout.idx["q"].shape[0] - 1, layout.idx
    PM = ca.DM(Phi[:, :nm].T @ model.Mff.toarray())
    return [ca.mtimes(PM, w[I["q"][K].tolist()] - ca.DM(q_end)), ca.mtimes(PM, w[I["v"][K].tolist()])]


def point_states(model: ControlModel, b: Blocks, Vst: ca.MX, Pp: int) -> tuple[ca.DM, ca.MX, ca.MX]:
    """(E, all coordinates Xp, all velocities Vp) at the collocation points (a column each)."""
    Ed = _dm(model.part.E)
    Xp = ca.mtimes(Ed, b.Q) + ca.repmat(ca.DM(model.part.c), 1, Pp)
    Vp = ca.mtimes(Ed, Vst)
    if model.nc:
        Xp += ca.mtimes(ca.DM(model.B), b.SP)
        Vp += ca.mtimes(ca.DM(model.B), b.SV)
    return Ed, Xp, Vp


@dataclass
class KernelTerm:
    """One nonlinear energy term mapped over all collocation points: its kernels (main: energy, gradient,
    Hessian; gfun: the gradient from the energy's reverse companion; hvp: the third-derivative companion), the
    element coordinates Xe and parameters Pm, and where each entry goes: rows (vec(G) entry -> dynamics row or -1),
    the Jacobian's and the Hessian's (row, column, entry) triplets."""
    main: ca.Function
    gfun: ca.Function
    hvp: ca.Function
    idx_all: np.ndarray
    Pm: ca.DM
    Xe: ca.MX
    rows: np.ndarray
    jac: tuple[np.ndarray, np.ndarray, np.ndarray]
    hess: tuple[np.ndarray, np.ndarray, np.ndarray]


def kernel_term(mk: MappedKernel, model: ControlModel, layout: Layout, Xv: ca.MX, Pp: int) -> KernelTerm:
    """The mapped kernels of one energy term at the Pp collocation points, and the maps of their entries onto
    the dynamics rows (free coordinates) and the decision variables (stage positions, controlled channels)."""
    t, N, nd, n, nf, nc = mk.term, mk.N, mk.nd, model.n, model.nf, model.nc
    M = Pp * N
    idx_all = (t.idx[None, :, :] + n * np.arange(Pp)[:, None, None]).reshape(M, nd)
    coord = np.tile(t.idx, (Pp, 1))  # (M, nd) scene coordinate of each element entry
    pnt = np.repeat(np.arange(Pp), N)  # collocation point of each mapped column
    Xe = ca.reshape(Xv[idx_all.ravel().tolist()], nd, M)
    Pm = ca.DM(np.tile(mk.P, (Pp, 1)).T)
    efun = kernels.load_energy(t.element, t.effect, t.gauss)
    Xs = ca.MX.sym("Xe", nd, M)
    gfun = ca.Function(f"grad_{t.element}_{t.effect}", [Xs], [ca.gradient(ca.sum2(efun.map(M)(Xs, Pm)), Xs)])
    iQf, iSPf = layout.idx["Q"].reshape(Pp, nf), layout.idx["SP"].reshape(Pp, nc)
    pos_c = model.pos[coord]
    a_row = np.where(pos_c >= 0, pnt[:, None] * nf + np.maximum(pos_c, 0), -1)  # dynamics row
    a_var = np.full(coord.shape, -1, dtype=np.int64)  # decision variable
    a_var[pos_c >= 0] = iQf[np.broadcast_to(pnt[:, None], coord.shape)[pos_c >= 0], pos_c[pos_c >= 0]]
    for k2, cd in enumerate(model.chan_coord):
        hit = coord == cd
        a_var[hit] = iSPf[np.broadcast_to(pnt[:, None], coord.shape)[hit], k2]
    # Jacobian: vec(H) entry (col * nd + a) * nd + b -> (row of b, variable of a)
    rb = np.broadcast_to(a_row[:, None, :], (M, nd, nd)).ravel()
    va = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
    jkeep = np.flatnonzero((rb >= 0) & (va >= 0))
    # Hessian of the Lagrangian: d(H v)/dq (symmetric), upper triangle
    hr = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
    hc = np.broadcast_to(a_var[:, None, :], (M, nd, nd)).ravel()
    hkeep = np.flatnonzero((hr >= 0) & (hc >= 0) & (hr <= hc))
    return KernelTerm(main=mk.kernel.map(M), gfun=gfun, hvp=kernels.load_hvp(t.element, t.effect).map(M),
                      idx_all=idx_all, Pm=Pm, Xe=Xe, rows=a_row.ravel(), jac=(rb[jkeep], va[jkeep], jkeep),
                      hess=(hr[hkeep], hc[hkeep], hkeep))


def kernel_parts(terms: list[KernelTerm], lam_g: ca.MX, ng: int, nw: int) -> tuple[ca.MX, ca.MX, ca.MX, ca.MX]:
    """The kernels' share of the constraints: (g from the gradient kernels (IPOPT's g evaluations), g and its
    Jacobian from the full kernels (one call gives both), the Lagrangian Hessian from the third-derivative
    kernels with v = the dynamics multipliers at each element coordinate)."""
    rows_of_g = np.concatenate([t.rows for t in terms]) if terms else np.zeros(0, np.int64)
    g_kernel = gather_sum([ca.vec(t.gfun(t.Xe)) for t in terms], rows_of_g, ng)
    outs = [t.main(t.Xe, t.Pm) for t in terms]
    g_kernel_full = gather_sum([ca.vec(o[1]) for o in outs], rows_of_g, ng)
    if not outs:
        return g_kernel, g_kernel_full, ca.MX(ng, nw), ca.MX(nw, nw)
    offsets = np.cumsum([0] + [t.Xe.shape[1] * t.Xe.shape[0] ** 2 for t in terms])
    n_jac = int(offsets[-1])
    dh_vals = []
    for t in terms:
        nd, M = t.Xe.shape
        vmat = ca.reshape(ca.vertcat(lam_g, ca.MX.zeros(1))[np.where(t.rows >= 0, t.rows, ng).tolist()], nd, M)
        dh_vals.append(ca.vec(t.hvp(t.Xe, t.Pm, vmat)[1]))

    def cat(part, i, shift=False):
        return np.concatenate([getattr(t, part)[i] + (offsets[j] if shift else 0) for j, t in enumerate(terms)])
    J_kernel = scatter([ca.vec(o[2]) for o in outs], cat("jac", 0), cat("jac", 1), ng, cat("jac", 2, True), n_jac,
                       n_cols=nw)
    H_kernel = scatter(dh_vals, cat("hess", 0), cat("hess", 1), nw, cat("hess", 2, True), n_jac)
    return g_kernel, g_kernel_full, J_kernel, H_kernel


class Transcription:
    """The collocation NLP of a control problem: its layout, the functions IPOPT calls (nlp, jac_g, hess_lag),
    the row and variable bounds, and the maps between decision vectors and node states (pack, unpack).

    q_start, q_end: the start and end equilibria; modes: (frequencies, M-orthonormal modes) about q_end."""

    def __init__(self, model: ControlModel, options: ControlOptions, bounds: Bounds, q_start: np.ndarray,
                 q_end: np.ndarray, modes: tuple[np.ndarray, np.ndarray]):
        self.model, self.options = model, options
        K, s, nf, nc = options.K, options.s, model.nf, model.nc
        self.tau = np.r_[0.0, options.tab.c]
        self.Pp = K * s
        self.nz = 2 * nf + 2 * nc
        self.Nn = K * (s + 1) + 1
        self.layout = Layout(model, options)
        self.idx, self.iT, self.nw = self.layout.idx, self.layout.iT, self.layout.nw
        self._build(bounds, q_end, modes)
        self.lbx, self.ubx = bounds.variable_bounds(self.idx, self.nw, self.iT, q_start)

    def _build(self, bounds: Bounds, q_end: np.ndarray, modes: tuple[np.ndarray, np.ndarray]) -> None:
        model, options, Pp = self.model, self.options, self.Pp
        tab = options.tab
        w = ca.MX.sym("w", self.nw)
        b = blocks(w, self.layout, options)
        Abig, R1, Bk = interval_matrices(tab, options.K)
        rows, Vst, Acc = collocation_rows(model, tab, b, Abig, R1, Pp)
        self._Vst_fun = ca.Function("stage_velocities", [w], [Vst])
        rows += continuity_rows(model, tab, b, Vst, Acc, Bk)
        n_dyn = sum(r.shape[0] for r in rows)
        self.n_end_modes = 0
        if options.end_rest:
            self.n_end_modes = end_mode_count(modes[0], model.nf, options.end_modes, options.end_frequency,
                                              options.K, options.T_bounds[1])
            rows += end_rows(model, w, self.layout, q_end, modes[1], self.n_end_modes)
        Ed, Xp, Vp = point_states(model, b, Vst, Pp)
        p_rows, lb_path, ub_path = path_rows(model, options, w, self.idx, Ed, Xp, Vp, b.SP, b.SV, b.U)
        g_poly = ca.vertcat(*(rows + p_rows))
        self.ng = ng = g_poly.shape[0]
        n_eq = n_dyn + 2 * self.n_end_modes
        self.lbg = np.r_[np.zeros(n_eq), *(lb_path or [np.zeros(0)])]
        self.ubg = np.r_[np.zeros(n_eq), *(ub_path or [np.zeros(0)])]
        self.g_rows = {"dynamics": (0, model.nf * Pp), "collocation": (0, n_dyn), "end": (n_dyn, n_eq),
                       "path": (n_eq, ng)}  # path: path and terminal constraints
        f = cost(model, options, b.T, b.h, b.U, Vst, b.SV, Ed)
        self._derivatives(w, f, g_poly, ca.vec(Xp))

    def _derivatives(self, w: ca.MX, f: ca.MX, g_poly: ca.MX, Xv: ca.MX) -> None:
        """The NLP and the functions IPOPT calls: g and its Jacobian, the Lagrangian Hessian (upper triangle), the
        polynomial rows differentiated by CasADi, the kernels' rows assembled from their derivative kernels."""
        ng, nw = self.ng, self.nw
        lam_g, lam_f = ca.MX.sym("lam_g", ng), ca.MX.sym("lam_f")
        terms = [kernel_term(mk, self.model, self.layout, Xv, self.Pp) for mk in self.model.nonlinear]
        self.kernel_calls = [(t.main, t.gfun, t.hvp, t.idx_all, t.Pm) for t in terms]
        g_kernel, g_kernel_full, J_kernel, H_kernel = kernel_parts(terms, lam_g, ng, nw)
        g_nlp = g_poly + g_kernel
        self.nlp = {"x": w, "f": f, "g": g_nlp}
        p0 = ca.MX.sym("p", 0)
        self.jac_g = ca.Function("nlp_jac_g", [w, p0], [g_poly + g_kernel_full, ca.jacobian(g_poly, w) + J_kernel],
                                 ["x", "p"], ["g", "jac_g_x"])
        lag_poly = lam_f * f + ca.dot(lam_g, g_poly)
        H_poly = ca.triu(ca.hessian(lag_poly, w)[0])
        self.hess_lag = ca.Function("nlp_hess_l", [w, p0, lam_f, lam_g], [H_poly + H_kernel],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        self.g_function = ca.Function("g", [w], [g_nlp])
        self.f_function = ca.Function("f", [w], [f])

    # -- decision vectors and node states ------------------------------------------------------------------------
    def stage_nodes(self) -> np.ndarray:
        """Rows of the node states that are collocation points (interval by interval)."""
        K, s = self.options.K, self.options.s
        return (np.arange(K)[:, None] * (s + 1) + np.arange(1, s + 1)[None, :]).ravel()

    def pack(self, Z: np.ndarray, U: np.ndarray, T: float | None = None) -> np.ndarray:
        """Decision vector from node states Z (Nn x [q, v, s, s']) at the node times (interval starts and the
        collocation points, then the end) and the controls U (Pp x nu) at the collocation points."""
        I, K, s, nf, nc = self.idx, self.options.K, self.options.s, self.model.nf, self.model.nc
        Z = np.asarray(Z, float).reshape(self.Nn, self.nz)
        w = np.zeros(self.nw)
        starts = np.r_[np.arange(K) * (s + 1), self.Nn - 1]
        stages = self.stage_nodes()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            w[I[key][:-1].ravel()] = Z[starts[:-1], sl].ravel()
        for key, sl in (("Q", slice(0, nf)), ("SP", slice(2 * nf, 2 * nf + nc)), ("SV", slice(2 * nf + nc, None))):
            w[I[key].reshape(-1)] = Z[stages, sl].ravel()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            if key != "q" or not self.options.tab.stiffly_accurate:
                w[I[key][-1]] = Z[-1, sl]
        w[I["U"].reshape(-1)] = np.asarray(U, float).ravel()
        if self.options.free_time:
            w[self.iT] = T if T is not None else self.options.T_guess
        return w

    def unpack(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """(Z, U, T): node states Z (Nn x [q, v, s, s']) with the stage velocities from the Runge-Kutta
        relations, controls U (Pp x nu) at the collocation points, horizon T."""
        I, K, s, nf = self.idx, self.options.K, self.options.s, self.model.nf
        w = np.asarray(w, float).ravel()
        Z = np.zeros((self.Nn, self.nz))
        Vst = np.asarray(self._Vst_fun(w)).reshape(nf, self.Pp).T if nf else np.zeros((self.Pp, 0))
        for k in range(K + 1):
            r = k * (s + 1) if k < K else self.Nn - 1
            Z[r] = np.r_[w[I["q"][k]], w[I["v"][k]], w[I["s"][k]], w[I["sv"][k]]]
            if k == K:
                break
            for j in range(s):
                Z[r + 1 + j] = np.r_[w[I["Q"][k, j]], Vst[k * s + j], w[I["SP"][k, j]], w[I["SV"][k, j]]]
        U = w[I["U"].reshape(-1)].reshape(self.Pp, self.model.nu)
        T = float(w[self.iT]) if self.options.free_time else self.options.T_guess
        return Z, U, T

    def node_times(self, T: float) -> np.ndarray:
        """Times of the node states: each interval's start and collocation points, then T."""
        h = T / self.options.K
        t = (np.arange(self.options.K)[:, None] + self.tau[None, :]).ravel() * h
        return np.r_[t, T]

    def point_times(self, T: float) -> np.ndarray:
        """Times of the collocation points (where the controls and path constraints live)."""
        h = T / self.options.K
        return (np.arange(self.options.K)[:, None] + self.options.tab.c[None, :]).ravel() * h

    def kernel_times(self, w: np.ndarray, repeat: int = 5) -> dict:
        """Seconds per call of the mapped kernels at all collocation points (one pass each): gradient (energy
        reverse companion), full (energy, gradient, Hessian) and third-derivative (hvp) kernels, at the state w."""
        m = self.model
        Z, U, T = self.unpack(w)
        Zc = Z[self.stage_nodes()]
        X = m.part.E @ Zc[:, :m.nf].T + m.part.c[:, None]
        if m.nc:
            X = X + m.B @ Zc[:, 2 * m.nf:2 * m.nf + m.nc].T
        Xflat = X.T.ravel()  # point after point
        out = {"gradient": 0.0, "full": 0.0, "hvp": 0.0}
        for main, gfun, hvp, idx_all, Pm in self.kernel_calls:
            Xe = np.ascontiguousarray(Xflat[idx_all])  # (M, nd) row-major == (nd, M) column-major
            Pnp = np.ascontiguousarray(np.asarray(Pm).T)
            V = np.ones_like(Xe)
            for key, f, args in (("gradient", gfun, [Xe]), ("full", main, [Xe, Pnp]), ("hvp", hvp, [Xe, Pnp, V])):
                buf, ev = bind(f, args, [np.zeros(f.nnz_out(i)) for i in range(f.n_out())])
                ev()
                ts = []
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    ev()
                    ts.append(time.perf_counter() - t0)
                out[key] += float(np.median(ts))
        return out
