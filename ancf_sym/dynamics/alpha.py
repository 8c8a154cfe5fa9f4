"""Newmark / HHT / generalized-alpha time steps on a StepSystem (ancf_sym.dynamics.schemes: Arnold-Bruels form,
index-3 constraints): the integrator the time loop drives, one step at a time (`attempt` / `accept`, with step
rejection and error control) or many fixed steps per compiled call (`run_chunk`).

A step is one compiled graph (ancf_sym.dynamics.alpha_step); `run_chunk` maps it over many steps (mapaccum; on
large states a loop calling it once per step) so that a whole stretch of the time loop is one call, ending at the
first step the graph cannot accept (ancf_sym.dynamics.chunks). Steps the graph flags as unconverged are redone by
the Python full-Newton loop (ancf_sym.dynamics.newton, absolute tolerances, max_iter) from the graph's last iterate.
newton.modified true without the in-graph factor (multipliers, strain-rate damping) runs modified Newton in Python
with a SuperLU factorisation reused across iterations and steps.
"""
from __future__ import annotations

import math

import numpy as np

from ancf_sym.util.casadi_buffers import bind
from ancf_sym.dynamics import chunks
from ancf_sym.dynamics.alpha_step import AlphaStepGraphs
from ancf_sym.dynamics.stiffness_damping import StiffnessDamping
from ancf_sym.system.graph_cache import ALPHA_GRAPHS, pooled_buffer
from ancf_sym.dynamics.integrator import StepOutcome, initial_acceleration
from ancf_sym.dynamics.newton import Counters, Factor, NewtonOptions, newton
from ancf_sym.dynamics.schemes import Scheme
from ancf_sym.system.step_system import StepSystem

# the Python Newton continues from the compiled graph's last iterate only where that iterate cut the predictor's
# scaled residual by this factor (it was converging); else it starts again from the predictor
RESTART_GAIN = 1e-2


class AlphaIntegrator:
    """Newmark / HHT / generalized-alpha on a StepSystem (see the module docstring and alpha_step's).

    State: q, v (true velocity), a (true acceleration), ab (algorithmic acceleration), a_prev (acceleration of the
    previous step), lam (true multipliers), the controls of the step graph, and (modified Newton in the graph) the
    kept factor's values D, U, U^T."""
    order = 2  # of the local error estimate (step-size control exponent 1/(order + 1))
    info_size = AlphaStepGraphs.info_size
    extra_iterations = AlphaStepGraphs.extra_iterations

    def __init__(self, system: StepSystem, scheme: Scheme, newton_opts: NewtonOptions, tol_q: float,
                 tol_x: float, counters: Counters):
        self.S, self.scheme, self.opts = system, scheme, newton_opts
        self.tol_q, self.tol_x = tol_q, tol_x
        self.counters = counters
        self.factor = Factor()
        nf, mc = system.nf, system.mc
        # in-graph modified Newton where the step graph can hold the factor; full Newton on request
        ldl = system.ensure_factor() if newton_opts.modified else None
        self.modified_graph = ldl is not None
        self.nctl = 10 if self.modified_graph else 2
        self.fac_sizes = ldl.size if self.modified_graph else ()
        # the state is one array (the step graph's input and output), q, v, a, ab, a_prev, lam, ctl views of it:
        # a chunk's last state is taken over in one copy
        self.state = np.zeros(self.state_size)
        self.q, self.v, self.a, self.ab, self.a_prev = (self.state[i * nf:(i + 1) * nf] for i in range(5))
        self.lam = self.state[5 * nf:5 * nf + mc]
        self.ctl = self.state[5 * nf + mc:]
        self.fac = [np.zeros(k) for k in self.fac_sizes]  # D, U, U^T of the kept factor (modified)
        self._reset_controls()
        self.h_prev = None
        self.new = dict(q=np.zeros(nf), v=np.zeros(nf), a=np.zeros(nf), ab=np.zeros(nf), lam=np.zeros(mc))
        self._new_ctl = self.ctl.copy()
        self._new_fac = [f.copy() for f in self.fac]
        self.kdamp = StiffnessDamping(system, counters)
        # the compiled step and chunk functions, shared by the integrators of one structure and settings
        key = (system.graph_key, scheme, tuple(sorted(vars(newton_opts).items())), self.modified_graph,
               self.extra_iterations)
        self._graphs = ALPHA_GRAPHS.setdefault(key, {"chunks": {}})
        self._builder = AlphaStepGraphs(system, scheme, newton_opts, ldl)
        if "step" not in self._graphs:
            # full Newton: the further iterations (3-6) in the step graph on large states; small states build them
            # only for guarded chunks (after a hard transient showed up): ~2.5 ms of set-up for a rare need
            self._graphs["step"] = self._builder.build_modified() if self.modified_graph else \
                self._builder.build_full(self.extra_iterations if self.state_size >= chunks.LARGE_STATE else 0)
        self.step_f = self._graphs["step"]
        self._setup_step_buffers()
        self._chunks: dict = {}  # this integrator's buffers of the chunk functions
        self.guard_on = False
        self._step_more = None  # (the step with iterations 3-6 bound to the step buffers: _step_call)
        # (full Newton: guarded chunks hold iterations 3-6; a kept factor's guarded chunk is the same step)
        self._contact = not self.modified_graph and bool(getattr(system.asm.scene, "contacts", ()))

    # -- the state ---------------------------------------------------------------------------------------------
    @property
    def state_size(self) -> int:
        return 5 * self.S.nf + self.S.mc + self.nctl

    @property
    def n_accum(self) -> int:
        """Accumulated inputs of the step function: the state, and the factor's D, U, U^T (modified)."""
        return 1 + len(self.fac_sizes)

    def _reset_controls(self) -> None:
        self.ctl[:] = 0.0
        if self.modified_graph:
            self.ctl[2] = -1.0  # contraction rate unknown; ctl[4] = 0: no factor

    def unpack(self, s: np.ndarray) -> dict:
        nf, mc = self.S.nf, self.S.mc
        out = {k: s[i * nf:(i + 1) * nf] for i, k in enumerate(("q", "v", "a", "ab", "a_prev"))}
        out["lam"] = s[5 * nf:5 * nf + mc]
        out["ctl"] = s[5 * nf + mc:]
        return out

    def _setup_step_buffers(self) -> None:
        S, nfac = self.S, len(self.fac_sizes)
        lay = self._layout = AlphaStepGraphs.column_layout(S)
        be = pooled_buffer(self._graphs, "step", self.step_f, self)
        kept = getattr(be[0], "bound_arrays", None)
        if kept is not None:  # a finished integrator's arrays (zeroed: as new ones); its factor arrays not
            self._s_in, self._col = kept[0][0], kept[0][-1]
            self._s_out, *outs = kept[1]
            self._f_out, self._info = outs[:nfac], outs[nfac]
            for a in [self._s_in, self._col, self._s_out, self._info] + self._f_out:
                a[:] = 0.0
        else:
            self._s_in, self._s_out, self._info = np.zeros(self.state_size), np.zeros(self.state_size), \
                np.zeros(self.info_size)
            self._f_out = [np.zeros(k) for k in self.fac_sizes]
            self._col = np.zeros(lay["size"])  # the step's inputs h, h_prev, tols, pload, kel, par (views below)
        self._h, self._hp, self._tols, self._pload = (self._col[lay[k]] for k in ("h", "hp", "tols", "pload"))
        args = [self._s_in] + self.fac + [self._col]
        outs = [self._s_out] + self._f_out + [self._info]
        buf, ev = bind(self.step_f, args, outs, be)
        self._step = (buf, ev, args, outs)

    def initialize(self, q0: np.ndarray, v0: np.ndarray, Q0: np.ndarray, t0: float = 0.0) -> None:
        self.q[:] = q0
        self.v[:] = v0
        self.kdamp.update(self.q)
        a, lam = initial_acceleration(self.S, q0, v0, Q0, self.kdamp.matrix(), t0)
        self.a[:], self.lam[:] = a, lam
        self.ab[:] = self.a
        self.a_prev[:] = self.a
        self.h_prev = None
        self._reset_controls()

    @property
    def chunkable(self) -> bool:
        """The whole step is in the graph (no Python per step): no stiffness damping update, and not the Python
        modified-Newton loop."""
        return (self.modified_graph or not self.opts.modified) and not self.kdamp.active

    # -- one step ---------------------------------------------------------------------------------------------
    def attempt(self, t: float, h: float, loads=None) -> StepOutcome:
        """Try the step t -> t + h (loads(t): time-dependent generalized force on the unknowns, or None).
        The candidate is in self.new; accept() commits it."""
        S = self.S
        pload = -S.f_lin if loads is None else -(S.f_lin + loads(t + h))
        if S.nw:
            pload = np.r_[pload, S.w(t + h)]
        self._h_try = h
        python_newton = self.opts
        if self.modified_graph or not self.opts.modified:
            self._s_in[:] = self.state
            self._h[0] = h
            self._hp[0] = self.h_prev if self.h_prev else 0.0
            self._pload[:] = pload
            self._tols[:] = self.tol_q, self.tol_x
            self._system_inputs(self._col)
            try:
                self._step_call()
            except RuntimeError:  # (an exactly singular step matrix: the sparse LU refuses it) -> the Python loop
                self._info[:] = 0.0
                self._s_out[:] = np.nan
            info = self._info
            k = self._count(info[1], info[2])
            finite = np.all(np.isfinite(self._s_out))
            if info[0] == 1 and finite and all(np.all(np.isfinite(f)) for f in self._f_out):
                u = self.unpack(self._s_out)
                for key in ("q", "v", "a", "ab", "lam"):
                    self.new[key][:] = u[key]
                self._new_ctl[:] = u["ctl"]
                for dst, src in zip(self._new_fac, self._f_out):
                    dst[:] = src
                return StepOutcome(True, k, "", True)
            # the graph did not converge: full Newton in Python, from the graph's last iterate if finite
            python_newton = NewtonOptions(**{**self.opts.__dict__, "modified": False})
            kc = self.scheme.cm(h) * S.stiffness_scale()
            xp, lp, S.p[:] = self._predict(h, pload, kc)
            it0 = 0
            if finite:
                u = self.unpack(self._s_out)
                xg, lg = u["q"], u["lam"] / kc
                it0 = k
                # the graph's last iterate only where it cut the predictor's residual (RESTART_GAIN): full updates through
                # a kink of a contact law can diverge (residual 3e7 N on the capstan's first step), and Newton
                # continued from there reached a distant root of the step equations (a rope 47 mm deep in the
                # drum, accepted as converged)
                if self._merit(h, kc, xg, lg) < RESTART_GAIN * self._merit(h, kc, xp, lp):
                    xp, lp = xg, lg
            S.x[:], S.lam[:] = xp, lp
        else:
            S.x[:], S.lam[:], S.p[:] = self._predict(h, pload, self.scheme.cm(h) * S.stiffness_scale())
            it0 = 0
        sc = self.scheme
        kc = sc.cm(h) * S.stiffness_scale()
        S.cm[0], S.cc[0], S.kc[0] = sc.cm(h), sc.cc(h), kc
        out = newton(S, self.factor, (h, kc), python_newton, self.counters, self.tol_q, self.tol_x, it0)
        if not out.converged:
            return StepOutcome(False, out.iterations, out.reason)
        self._correct(h, S.x, S.lam * kc)
        # controls after a Python step: estimates to be re-measured; the kept factor (modified) one step older.
        # omega unknown (0): the graph's omega is that of its last two-iteration step, which may be many steps and
        # a different Newton regime ago (a spinning bending-free cable: 2e-3 kept over 14 Python steps whose
        # iterations showed 1-800, and the steps after them accepted after one iteration on it created 15 % of the
        # energy); the next graph step runs two iterations and measures it
        self._new_ctl[:] = self.ctl
        self._new_ctl[0] = 0.0
        self._new_ctl[1] = 0.0
        if self.modified_graph:
            self._new_ctl[3] += 1  # factor age
            self._new_ctl[6] = 0.0  # |dz0| of this step unknown: no one-iteration acceptance next
        for dst, src in zip(self._new_fac, self.fac):
            dst[:] = src
        return StepOutcome(True, out.iterations)

    def _merit(self, h: float, kc: float, x: np.ndarray, lam: np.ndarray) -> float:
        """The Newton loop's scaled residual max(|r_q| / tol_q, |Phi| / tol_x) of the step at (x, lam) (inf if not
        finite); the step's inputs p, vc as set by _predict."""
        S, sc = self.S, self.scheme
        S.cm[0], S.cc[0], S.kc[0] = sc.cm(h), sc.cc(h), kc
        S.x[:], S.lam[:] = x, lam
        S.residual()
        self.counters.residuals += 1
        rq, rc = S.norms[0], S.norms[1]
        m = max(rq / max(self.tol_q, 2.0 * S.floor), rc / self.tol_x)
        return m if math.isfinite(m) else math.inf

    def _system_inputs(self, cols: np.ndarray) -> None:
        """The system's kel (updated along damped runs) and par into the step input column(s) (rows of cols)."""
        S, lay = self.S, self._layout
        if S.kel is not None:
            cols[..., lay["kel"]] = S.kel
        cols[..., lay["par"]] = S.par

    def _count(self, iterations: float, factorizations: float) -> int:
        """Book a step's (or chunk's) Newton iterations and factorisations from its info (0 if not finite)."""
        c = self.counters
        k = int(iterations) if math.isfinite(iterations) else 0
        f = int(factorizations) if math.isfinite(factorizations) else 0
        c.residuals += k
        c.jacobians += f
        c.factorizations += f
        c.newton_iterations += k
        return k

    def _predict(self, h, pload, kc):
        sc, S = self.scheme, self.S
        b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
        qh = self.q + h * self.v + h * h * (0.5 - b) * self.ab
        vh = self.v + h * (1 - g) * self.ab
        cm, cc = sc.cm(h), sc.cc(h)
        p = pload.copy()
        y = (am * self.ab - af * self.a) / (1 - af) - cm * qh
        if S.inertia_input:  # (an inertia that is not M times the acceleration: the graph takes y itself)
            S.y[:] = y
        else:
            p[:S.nf] += S.M @ y
        C = self.kdamp.matrix()
        if C is not None:
            p[:S.nf] += C @ (vh - cc * qh)
        # constant-acceleration predictor: extrapolating a linearly from the last two steps doubles the
        # predictor's error where the acceleration alternates step to step (high-frequency content: 476 vs 415
        # iterations on the 1000-element pendulum), and gains nothing on smooth motion
        x = qh + b * h * h * (self.a - am * self.ab) / (1 - am)
        S.vc[:] = vh - cc * qh
        return x, self.lam / kc, p

    def _correct(self, h, x, lam_true):
        sc = self.scheme
        b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
        qh = self.q + h * self.v + h * h * (0.5 - b) * self.ab
        vh = self.v + h * (1 - g) * self.ab
        ab1 = (x - qh) / (b * h * h)
        self.new["q"][:] = x
        self.new["lam"][:] = lam_true
        self.new["ab"][:] = ab1
        self.new["a"][:] = ((1 - am) * ab1 + am * self.ab - af * self.a) / (1 - af)
        self.new["v"][:] = vh + h * g * ab1

    def error_estimate(self, h: float) -> np.ndarray:
        """Local displacement error of the candidate, |beta - 1/6| h^2 (a_{n+1} - a_n) (Zienkiewicz-Xie)."""
        return self.scheme.error_constant() * h * h * (self.new["a"] - self.a)

    def accept(self) -> None:
        self.a_prev[:] = self.a
        for k in ("q", "v", "a", "ab", "lam"):
            getattr(self, k)[:] = self.new[k]
        self.ctl[:] = self._new_ctl
        for dst, src in zip(self.fac, self._new_fac):
            dst[:] = src
        self.h_prev = self._h_try
        self.kdamp.update(self.q)

    def _step_call(self) -> None:
        """One step graph call on the step buffers: where chunks are guarded and their step with the further
        iterations 3-6 was built (small states after a hard transient, contact scenes), that step, on the same
        buffers, so a step taken one by one (after a failed chunk, the grid's last steps that fill no chunk)
        converges in the graph where a guarded chunk's would, not in the Python loop (belt drive: 51 of its last
        59 steps did, 1-2 iterations each after the graph's two, on the absolute update tolerance)."""
        more = self._graphs.get("step_more") if self.guard else None
        if more is None:
            self._step[1]()
            return
        if self._step_more is None:
            _, _, args, outs = self._step
            self._step_more = bind(more, args, outs, pooled_buffer(self._graphs, "step_more", more, self))
        self._step_more[1]()

    # -- many steps in one call -------------------------------------------------------------------------------
    def guarded_step(self):
        """The step with the 'failed' flag of ancf_sym.dynamics.chunks.guarded (full Newton on small states: the
        step with the further iterations 3-6, built on first use)."""
        f = self.step_f
        if not self.modified_graph and self.state_size < chunks.LARGE_STATE:  # (the step with iterations 3-6)
            f = self._graphs.setdefault("step_more", None) or self._builder.build_full(self.extra_iterations)
            self._graphs["step_more"] = f
        return chunks.guarded(f, self.state_size, self.n_accum, self.info_size)

    @property
    def guard(self) -> bool:
        """Chunks with the no-op guard after a failed step: on large states (the guard's switch costs nothing
        against a step there), and on any state after a chunk has failed early (a hard transient: the steps after
        a failure would be thrown away). Small states start without: the switch costs ~5 % of a 130-unknown step;
        contact scenes on full Newton start with it (a touchdown is a hard transient: the belt drive's first chunk
        failed at its first step and threw 60 steps away, 7 % of the run's iterations)."""
        return self.guard_on or self.state_size >= chunks.LARGE_STATE or self._contact

    def chunk_function(self, n: int, guard: bool | None = None):
        guard = self.guard if guard is None else guard
        if (n, guard) not in self._chunks:
            g = self._graphs
            if guard and "guarded" not in g:
                g["guarded"] = self.guarded_step()
            if (n, guard) not in g["chunks"]:  # (without the guard: the step itself over the steps)
                g["chunks"][n, guard] = chunks.map_steps(g["guarded"] if guard else self.step_f, n, self.n_accum)
            f = g["chunks"][n, guard]
            ns = self.state_size + guard
            lay = self._layout
            be = pooled_buffer(g, (n, guard), f, self)
            bufs = getattr(be[0], "chunk_arrays", None)
            if bufs is not None:  # a finished integrator's arrays and views (zeroed, forgotten inputs: as new ones)
                for a in [bufs[k] for k in ("s", "cols", "out", "info")] + bufs["fac_out"]:
                    a[:] = 0.0
                bufs["last"], bufs["pload_from"] = None, None
            else:
                cols = np.zeros((n, lay["size"]))  # (column j: step j's inputs, as the step graph's)
                bufs = dict(s=np.zeros(ns), cols=cols, out=np.zeros(ns * n), info=np.zeros(self.info_size * n),
                            fac_out=[np.zeros(k * n) for k in self.fac_sizes], guard=guard,
                            ones=np.ones(ns - guard), h=cols[:, lay["h"]], hp=cols[:, lay["hp"]],
                            tols=cols[:, lay["tols"]], pload=cols[:, lay["pload"]], last=None, flat=cols.reshape(-1))
                bufs["states"] = bufs["out"].reshape(n, ns)[:, :ns - guard]
                be[0].chunk_arrays = bufs  # (with the buffer in the pool, for the next integrator)
            self._system_inputs(bufs["cols"])
            args = [bufs["s"]] + self.fac + [bufs["flat"]]
            outs = [bufs["out"]] + bufs["fac_out"] + [bufs["info"]]
            buf, ev = bind(f, args, outs, be)
            self._chunks[n, guard] = (buf, ev, bufs)
        return self._chunks[n, guard]

    @property
    def stepwise(self) -> bool:
        """Large states run a chunk as one call of the step graph per step from a tight loop (the loop's ~5 us per
        step is nothing against a step there, and no chunk graph is built: an unrolled 50-step chunk took
        0.1-0.15 s to build at 1000 elements); small states as one compiled call (mapaccum)."""
        return self.state_size >= chunks.LARGE_STATE

    def prepare_chunks(self, n: int) -> None:
        """Build (or take from the cache) the chunk function of n steps and its buffers: set-up, before the loop."""
        if not self.stepwise:
            self.chunk_function(n)

    def run_chunk(self, h: float, ploads: np.ndarray) -> tuple[np.ndarray, int]:
        """Up to n = ploads.shape[1] steps of size h in one call (no time-dependent C). Returns the states after
        each accepted step (n_ok x state_size) and n_ok: the steps before the first one the graph could not
        converge (that step is then left to `attempt`). The integrator's state is advanced to the last of them."""
        if self.stepwise:
            return self._run_steps(h, ploads)
        n = ploads.shape[1]
        buf, ev, b = self.chunk_function(n)
        ns = self.state_size
        b["s"][:ns] = self.state
        if b["guard"]:
            b["s"][-1] = 0.0  # not failed
        hp0 = self.h_prev if self.h_prev else 0.0
        if b["last"] != (h, hp0, self.tol_q, self.tol_x):  # (mapaccum maps every input but the state over the steps)
            b["h"][:] = h
            b["hp"][:] = h
            b["hp"][0] = hp0
            b["tols"][:] = self.tol_q, self.tol_x
            b["last"] = (h, hp0, self.tol_q, self.tol_x)
        if ploads is not b.get("pload_from"):  # (a constant load array is copied in once)
            b["pload"][:] = ploads.T
            b["pload_from"] = ploads if not ploads.flags.writeable else None
        try:
            ev()
        except RuntimeError:  # (an exactly singular step matrix, sparse LU): no step kept, the first is `attempt`'s
            self.guard_on = True
            return b["states"][:0], 0
        # (the checks on Python lists: right after the compiled call a numpy call costs ~5-10 us, a list method
        # ~1 us; the same tests and sums as on the arrays)
        states, isz = b["states"], self.info_size
        info = b["info"].tolist()
        ok = info[0::isz]  # (guarded: the failed flag, set at the first unconverged or non-finite step)
        fin = None if b["guard"] else (states @ b["ones"]).tolist()  # (a sum is finite only if every entry is)
        if ok.count(1.0) == n and (fin is None or all(map(math.isfinite, fin))):
            n_ok = n
        else:
            n_ok = next(j for j in range(n) if ok[j] != 1 or (fin is not None and not math.isfinite(fin[j])))
        # the failing step's work was spent too (and without the guard, the later steps' work)
        m = min(n_ok + 1, n) if b["guard"] else n
        self._count(sum(info[1:m * isz:isz]), sum(info[2:m * isz:isz]))
        if n_ok < n - 1:
            self.guard_on = True  # a hard transient: the next chunks stop at their failing step
        if n_ok:
            self.state[:] = states[n_ok - 1]  # (its a_prev: the acceleration of the step before)
            for dst, src, k in zip(self.fac, b["fac_out"], self.fac_sizes):
                dst[:] = src[(n_ok - 1) * k:n_ok * k]
            self.h_prev = h
        return states[:n_ok], n_ok

    def _run_steps(self, h: float, ploads: np.ndarray) -> tuple[np.ndarray, int]:
        """run_chunk of large states: the step graph (with its further iterations) called once per step, ending at
        the first step it cannot accept (not converged, or a non-finite state): the steps a guarded chunk takes,
        with the same compiled step. Each step reads the row the step before wrote (no copies)."""
        n = ploads.shape[1]
        ns = self.state_size
        st = self._chunks.get("states")
        if st is None or st[0].shape[0] < n + 1:
            rows = np.empty((n + 1, ns))
            st = self._chunks["states"] = (rows, [memoryview(r) for r in rows])
        rows, views = st
        buf, ev, _, _ = self._step
        info, f_out = self._info, self._f_out
        rows[0] = self.state
        self._h[0] = h
        self._hp[0] = self.h_prev if self.h_prev else 0.0
        self._tols[:] = self.tol_q, self.tol_x
        self._system_inputs(self._col)
        n_ok = 0
        try:
            for j in range(n):
                self._pload[:] = ploads[:, j]
                buf.set_arg(0, views[j])
                buf.set_res(0, views[j + 1])
                try:
                    ev()
                except RuntimeError:  # (an exactly singular step matrix, sparse LU): ends the run of steps here
                    break
                self._count(info[1], info[2])
                # (a sum is finite only if every entry is)
                if info[0] != 1 or not np.isfinite(rows[j + 1].sum()) or not all(np.isfinite(f.sum()) for f in f_out):
                    break
                for dst, src in zip(self.fac, f_out):  # (bound as the step's inputs: the next step's factor)
                    dst[:] = src
                self._hp[0] = h
                n_ok += 1
        finally:
            buf.set_arg(0, memoryview(self._s_in))
            buf.set_res(0, memoryview(self._s_out))
        if n_ok:
            self.state[:] = rows[n_ok]
            self.h_prev = h
        return rows[1:n_ok + 1], n_ok
