"""The transcription: K intervals of an implicit Runge-Kutta method in condensed form (stage positions as
variables), the decision-vector layout, and the NLP's constraints with their exact Jacobian and Lagrangian Hessian
assembled from the compiled kernels (see the package docstring)."""
from __future__ import annotations

import time

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.dynamics.collocation import interval_end, stage_residual
from ancf_sym.util.sparsity import dm as _dm, gather_sum, scatter


class TranscriptionMixin:
    """ControlProblem's decision vector and NLP."""

    def _layout(self) -> None:
        """Decision vector, interval after interval: [q_0 | v_k, s_k, s'_k, Q_k (s x nf), SP_k, SV_k, U_k
        (s x ...), q_k+1 (Gauss only) | ... | v_K, s_K, s'_K | T]. Radau's last stage is the interval's end, so
        q_k+1 is that stage's variable (no separate copy, no continuity row)."""
        K, s, nf, nc, nu = self.K, self.s, self.nf, self.nc, self.nu
        radau = self.tab.stiffly_accurate
        counter = [0]

        def take(*shape):
            size = int(np.prod(shape))
            out = np.arange(counter[0], counter[0] + size, dtype=np.int64).reshape(shape)
            counter[0] += size
            return out
        iq, iv = np.zeros((K + 1, nf), np.int64), np.zeros((K + 1, nf), np.int64)
        isb, isvb = np.zeros((K + 1, nc), np.int64), np.zeros((K + 1, nc), np.int64)
        iQ, iSP, iSV = np.zeros((K, s, nf), np.int64), np.zeros((K, s, nc), np.int64), np.zeros((K, s, nc), np.int64)
        iU = np.zeros((K, s, nu), np.int64)
        iq[0] = take(nf)
        for k in range(K):
            iv[k], isb[k], isvb[k] = take(nf), take(nc), take(nc)
            iQ[k], iSP[k], iSV[k] = take(s, nf), take(s, nc), take(s, nc)
            iU[k] = take(s, nu) if self.control_form == "polynomial" else np.broadcast_to(take(1, nu), (s, nu))
            iq[k + 1] = iQ[k, s - 1] if radau else take(nf)
        iv[K], isb[K], isvb[K] = take(nf), take(nc), take(nc)
        self.iT = int(take(1)[0]) if self.free_time else None
        self.nw = counter[0]
        self.idx = {"q": iq, "v": iv, "s": isb, "sv": isvb, "Q": iQ, "SP": iSP, "SV": iSV, "U": iU}

    def _build_nlp(self) -> None:
        K, s, nf, nc, n = self.K, self.s, self.nf, self.nc, self.n
        tab = self.tab
        self.tau = np.r_[0.0, tab.c]
        self.Pp = Pp = K * s
        self.nz = 2 * nf + 2 * nc
        self.Nn = K * (s + 1) + 1
        self._layout()
        nw, I = self.nw, self.idx
        w = ca.MX.sym("w", nw)

        def mat(ix):  # MX (last dim x rest) of w at an index array
            m = ix.shape[-1]
            cols = ix.size // m if m else int(np.prod(ix.shape[:-1]))
            if m == 0:
                return ca.MX(0, cols)
            return ca.reshape(w[ix.reshape(-1).tolist()], m, cols)
        T = w[self.iT] if self.free_time else ca.DM(self.T_guess)
        h = T / K
        IK = sp.identity(K, format="csc")
        Abig = _dm(sp.kron(IK, sp.csc_matrix(tab.A.T)))
        R1 = _dm(sp.kron(IK, sp.csc_matrix(np.ones((1, s)))))
        Bk = _dm(sp.kron(IK, sp.csc_matrix(tab.b[:, None])))  # (Ks x K): quadrature over each interval
        q0, v0 = mat(I["q"][:-1]), mat(I["v"][:-1])
        q1, v1 = mat(I["q"][1:]), mat(I["v"][1:])
        s0, sv0, s1, sv1 = mat(I["s"][:-1]), mat(I["sv"][:-1]), mat(I["s"][1:]), mat(I["sv"][1:])
        Qm, SP, SV, U = mat(I["Q"]), mat(I["SP"]), mat(I["SV"]), mat(I["U"])
        Ua, Uf = U[:nc, :], U[nc:, :]
        # the condensed stage equations of all intervals (M a + the support and control forces - f_lin; the
        # kernels' grad U is added below) and the continuity of q, v by the quadrature weights
        rest = -ca.repmat(ca.DM(self.f_lin), 1, Pp)
        if nc:
            rest += ca.mtimes(_dm(self.Mfc), Ua)
        if self.nF:
            rest -= ca.mtimes(ca.DM(self.Bf), Uf)
        dyn, Vst, Acc = stage_residual(tab, h, self.Mff, Qm, q0, v0, rest)
        self._Vst_fun = ca.Function("stage_velocities", [w], [Vst])
        rows = [ca.vec(dyn)]
        if nc:
            rows += [ca.vec(SV - ca.mtimes(sv0, R1) - h * ca.mtimes(Ua, Abig)),
                     ca.vec(SP - ca.mtimes(s0, R1) - h * ca.mtimes(SV, Abig))]
        q_end, v_end = interval_end(tab, h, q0, v0, Qm, Vst, Acc)
        if not tab.stiffly_accurate:  # (Radau: the last stage is the next start, no row)
            rows.append(ca.vec(q1 - q_end))
        rows.append(ca.vec(v1 - v_end))
        if nc:
            rows += [ca.vec(s1 - s0 - h * ca.mtimes(SV, Bk)), ca.vec(sv1 - sv0 - h * ca.mtimes(Ua, Bk))]
        n_dyn = sum(r.shape[0] for r in rows)
        # terminal: the scene at rest at its end equilibrium on the chosen modes
        self._end_rows = 0
        if self.end_rest:
            nm = self.end_mode_count()
            PM = ca.DM(self.modes[1][:, :nm].T @ self.Mff.toarray())
            rows += [ca.mtimes(PM, w[I["q"][K].tolist()] - ca.DM(self.q_end)), ca.mtimes(PM, w[I["v"][K].tolist()])]
            self._end_rows = 2 * nm
            self.n_end_modes = nm
        else:
            self.n_end_modes = 0
        Ed = _dm(self.part.E)
        Xp = ca.mtimes(Ed, Qm) + ca.repmat(ca.DM(self.part.c), 1, Pp)
        Vp = ca.mtimes(Ed, Vst)
        if nc:
            Xp += ca.mtimes(ca.DM(self.B), SP)
            Vp += ca.mtimes(ca.DM(self.B), SV)
        # path constraints at the collocation points, terminal constraints at T
        path_rows, lb_path, ub_path = self._path_rows(w, I, Ed, Xp, Vp, SP, SV, U)
        rows += path_rows
        g_poly = ca.vertcat(*rows)
        ng = g_poly.shape[0]
        self.ng = ng
        n_eq = n_dyn + self._end_rows
        self.lbg = np.r_[np.zeros(n_eq), *(lb_path or [np.zeros(0)])]
        self.ubg = np.r_[np.zeros(n_eq), *(ub_path or [np.zeros(0)])]
        self._g_rows = {"dynamics": (0, nf * Pp), "collocation": (0, n_dyn), "end": (n_dyn, n_eq),
                        "path": (n_eq, ng)}  # path: path and terminal constraints
        f = self._cost(T, h, U, Vst, SV, Ed)
        # -- kernels at all points: g, Jacobian, Hessian of the Lagrangian ----------------------------------------
        Xv = ca.vec(Xp)
        lam_g, lam_f = ca.MX.sym("lam_g", ng), ca.MX.sym("lam_f")
        iQf, iSPf = I["Q"].reshape(Pp, nf), I["SP"].reshape(Pp, nc)
        g_parts, jac_rows, jac_cols, jac_keep = [], [], [], []
        hess_rows, hess_cols, hess_keep, dh_vals = [], [], [], []
        self._kernel_calls = []
        n_jac = 0
        for mk in self.nonlinear:
            t = mk.term
            N, nd = mk.N, mk.nd
            M = Pp * N
            idx_all = (t.idx[None, :, :] + n * np.arange(Pp)[:, None, None]).reshape(M, nd)
            coord = np.tile(t.idx, (Pp, 1))  # (M, nd) scene coordinate of each element entry
            pnt = np.repeat(np.arange(Pp), N)  # collocation point of each mapped column
            Xe = ca.reshape(Xv[idx_all.ravel().tolist()], nd, M)
            Pm = ca.DM(np.tile(mk.P, (Pp, 1)).T)
            main = mk.kernel.map(M)
            efun = kernels.load_energy(t.element, t.effect, t.gauss)
            Xs = ca.MX.sym("Xe", nd, M)
            gfun = ca.Function(f"grad_{t.element}_{t.effect}", [Xs],
                               [ca.gradient(ca.sum2(efun.map(M)(Xs, Pm)), Xs)])
            hvp = kernels.load_hvp(t.element, t.effect).map(M)
            self._kernel_calls.append((main, gfun, hvp, idx_all, Pm))
            pos_c = self.pos[coord]
            a_row = np.where(pos_c >= 0, pnt[:, None] * nf + np.maximum(pos_c, 0), -1)  # dynamics row
            a_var = np.full(coord.shape, -1, dtype=np.int64)  # decision variable
            a_var[pos_c >= 0] = iQf[np.broadcast_to(pnt[:, None], coord.shape)[pos_c >= 0], pos_c[pos_c >= 0]]
            for k2, cd in enumerate(self._chan_coord):
                hit = coord == cd
                a_var[hit] = iSPf[np.broadcast_to(pnt[:, None], coord.shape)[hit], k2]
            r_flat = a_row.ravel()  # vec(G) entry col * nd + a: its dynamics row (-1: none)
            g_parts.append((r_flat, gfun, main, Xe, Pm))
            # Jacobian: vec(H) entry (col * nd + a) * nd + b -> (row of b, variable of a)
            rb = np.broadcast_to(a_row[:, None, :], (M, nd, nd)).ravel()
            va = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
            keep = np.flatnonzero((rb >= 0) & (va >= 0))
            jac_rows.append(rb[keep])
            jac_cols.append(va[keep])
            jac_keep.append(keep + n_jac)
            # Hessian: v = the dynamics multipliers at each element coordinate; d(H v)/dq (symmetric) -> upper
            vmat = ca.reshape(ca.vertcat(lam_g, ca.MX.zeros(1))[np.where(r_flat >= 0, r_flat, ng).tolist()], nd, M)
            hr = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
            hc = np.broadcast_to(a_var[:, None, :], (M, nd, nd)).ravel()
            keep = np.flatnonzero((hr >= 0) & (hc >= 0) & (hr <= hc))
            hess_rows.append(hr[keep])
            hess_cols.append(hc[keep])
            hess_keep.append(keep + n_jac)
            dh_vals.append(ca.vec(hvp(Xe, Pm, vmat)[1]))
            n_jac += M * nd * nd
        rows_of_g = np.concatenate([r for r, *_ in g_parts]) if g_parts else np.zeros(0, np.int64)
        # g for IPOPT's function evaluations: gradients from the energy kernels' reverse companions (cheaper)
        g_kernel = gather_sum([ca.vec(gf(Xe)) for _, gf, _, Xe, _ in g_parts], rows_of_g, ng)
        # g and its Jacobian from the full kernels (one call gives both)
        outs = [main(Xe, Pm) for _, _, main, Xe, Pm in g_parts]
        g_kernel_full = gather_sum([ca.vec(o[1]) for o in outs], rows_of_g, ng)
        if outs:
            J_kernel = scatter([ca.vec(o[2]) for o in outs], np.concatenate(jac_rows), np.concatenate(jac_cols), ng,
                               np.concatenate(jac_keep), n_jac, n_cols=nw)
            H_kernel = scatter(dh_vals, np.concatenate(hess_rows), np.concatenate(hess_cols), nw,
                               np.concatenate(hess_keep), n_jac)
        else:
            J_kernel, H_kernel = ca.MX(ng, nw), ca.MX(nw, nw)
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
        self._lbx, self._ubx = self._variable_bounds()

    def pack(self, Z: np.ndarray, U: np.ndarray, T: float | None = None) -> np.ndarray:
        """Decision vector from node states Z (Nn x [q, v, s, s']) at the node times (interval starts and the
        collocation points, then the end) and the controls U (Pp x nu) at the collocation points."""
        I, K, s, nf, nc = self.idx, self.K, self.s, self.nf, self.nc
        Z = np.asarray(Z, float).reshape(self.Nn, self.nz)
        w = np.zeros(self.nw)
        starts = np.r_[np.arange(K) * (s + 1), self.Nn - 1]
        stages = (np.arange(K)[:, None] * (s + 1) + np.arange(1, s + 1)[None, :]).ravel()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            w[I[key][:-1].ravel()] = Z[starts[:-1], sl].ravel()
        for key, sl in (("Q", slice(0, nf)), ("SP", slice(2 * nf, 2 * nf + nc)), ("SV", slice(2 * nf + nc, None))):
            w[I[key].reshape(-1)] = Z[stages, sl].ravel()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            if key != "q" or not self.tab.stiffly_accurate:
                w[I[key][-1]] = Z[-1, sl]
        w[I["U"].reshape(-1)] = np.asarray(U, float).ravel()
        if self.free_time:
            w[self.iT] = T if T is not None else self.T_guess
        return w

    def unpack(self, w: np.ndarray):
        """(Z, U, T): node states Z (Nn x [q, v, s, s']) with the stage velocities from the Runge-Kutta
        relations, controls U (Pp x nu) at the collocation points, horizon T."""
        I, K, s, nf = self.idx, self.K, self.s, self.nf
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
        U = w[I["U"].reshape(-1)].reshape(self.Pp, self.nu)
        T = float(w[self.iT]) if self.free_time else self.T_guess
        return Z, U, T

    def node_times(self, T: float) -> np.ndarray:
        h = T / self.K
        t = (np.arange(self.K)[:, None] + self.tau[None, :]).ravel() * h
        return np.r_[t, T]

    def point_times(self, T: float) -> np.ndarray:
        h = T / self.K
        return (np.arange(self.K)[:, None] + self.tab.c[None, :]).ravel() * h

    def kernel_times(self, w: np.ndarray, repeat: int = 5) -> dict:
        """Seconds per call of the mapped kernels at all collocation points (one pass each): gradient (energy
        reverse companion), full (energy, gradient, Hessian) and third-derivative (hvp) kernels, at the state w."""
        Z, U, T = self.unpack(w)
        stages = (np.arange(self.K)[:, None] * (self.s + 1) + np.arange(1, self.s + 1)[None, :]).ravel()
        Zc = Z[stages]
        X = self.part.E @ Zc[:, :self.nf].T + self.part.c[:, None]
        if self.nc:
            X = X + self.B @ Zc[:, 2 * self.nf:2 * self.nf + self.nc].T
        Xflat = X.T.ravel()  # point after point
        out = {"gradient": 0.0, "full": 0.0, "hvp": 0.0}
        for main, gfun, hvp, idx_all, Pm in self._kernel_calls:
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
