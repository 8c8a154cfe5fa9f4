"""The compiled step of the alpha schemes (Newmark / HHT / generalized-alpha, ancf_sym.dynamics.schemes): one CasADi
graph per step with the predictor, the Newton iterations chosen in-graph by switches that evaluate only the branch
taken, and the corrector. AlphaIntegrator (ancf_sym.dynamics.alpha) runs it, one step or many per call.

Two step graphs:

- full Newton (default): every iteration is a full Newton iteration with CasADi's sparse LDL^T (or QR:
  multipliers, strain-rate damping); one or two iterations in the graph, accepted after one when Newton's own
  estimate 2 omega |dz0|^2 (omega = |dz1| / |dz0|^2 measured on two-iteration steps) is below the update
  tolerance. omega is re-measured at least every `refresh_every` steps, up to 8x less often when the
  estimate is below a tenth of the tolerance; up to `extra_iterations` more iterations behind one switch.
- modified Newton (newton.modified true, symmetric step matrix: no multipliers, no strain-rate damping). The
  LDL^T factor of the step matrix (values D, U, U^T, ancf_sym.system.ldl) is carried from step to step as
  accumulated inputs of the step function and kept across iterations and steps while the iteration contracts. An
  iteration on the kept factor costs the gradient-only kernels and two triangular solves; a refactorisation is a
  full Newton iteration (energy, gradient, Hessian kernels, assembly, LDL^T) that stores its factor. An iteration
  on the kept factor is accepted only after the next one measured its contraction theta = |dz_k+1| / |dz_k|
  (error theta / (1 - theta) |dz_k+1|); predicting theta from earlier steps to accept after one iteration was
  tried and let errors far above the tolerance through (a chaotic double pendulum ended 9 mm off). After a
  refactorisation the step may end after one iteration on omega as above. The contraction per step of factor
  age (rate = theta / age, rising at once, decaying slowly) predicts how many iterations the kept factor will
  need; a step starts with a refactorisation when the step size changed, when rate x age reaches
  newton.contraction, or when those iterations cost more than a refactorisation's cycle costs per step so far
  (renewal rule, a refactorisation counted as `refactor_cost` iterations); within a step it refactorises when a
  measured theta exceeds newton.contraction. The step's scalar logic is a few SX functions between the
  iterations (hundreds of scalar MX nodes cost more than the logic itself).

The update tolerance is max(xtol L, lte_fraction x the step's local truncation error |beta - 1/6| h^2
|a_n+1 - a_n|, the latter capped by the work its residual may do, update_tolerance): Newton's error stays a small
fraction of the time-discretization error, so the accuracy is the scheme's. State: q, v (true velocity), a (true acceleration), ab (algorithmic acceleration), a_prev (acceleration
of the previous step), lam (true multipliers) and the controls (omega, steps since a measurement; modified:
contraction rate, factor age, step size of the factor, largest step-matrix entry, the last |dz0|, update
tolerance and truncation error, the cost of the factor's cycle); modified: the factor.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ancf_sym.system.damping import rayleigh_mx
from ancf_sym.system.graph_cache import SCHEME_FUNCTIONS
from ancf_sym.system.ldl import LDLFactor
from ancf_sym.util.mx_ops import add as _add, div as _div, mul as _mul, sub as _sub  # (the step's vector algebra)
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.dynamics.schemes import Scheme
from ancf_sym.system.step_system import StepSystem


# The work the residual of an accepted Newton error may do over a step, as a fraction of the scene's force scale
# times its span (update_tolerance). Measured (docs/hard_cases.md): 1e-3 keeps every spinning bending-free cable
# run stable and its energy decaying, at 1-10 % more Newton iterations on stiff pendulums.
NEWTON_WORK_FRACTION = 1e-3


def update_tolerance(o: NewtonOptions, tols, lte, work, span):
    """The step's update tolerance [m] (SX): max(xtol L, lte_fraction x the truncation error), the truncation-error
    part capped where an update error e of that size along the stiffest direction would leave a residual force
    whose work over the step's motion, e x work (work_scale), exceeds NEWTON_WORK_FRACTION x the force scale F
    (tols[0] / newton.tol) x the scene's span. The truncation-error estimate h^2 |a_n+1 - a_n| grows with the
    accelerations of modes the step does not resolve (axial, omega h >> 1), which an update error left along them
    drives: without the cap that loop fed a spinning bending-free cable energy until it blew up
    (docs/hard_cases.md); the cap does not grow with their state."""
    cap = NEWTON_WORK_FRACTION * tols[0] / o.tol * span / work
    return ca.fmax(tols[1], ca.fmin(o.lte_fraction * lte, cap))


def work_scale(kmax, dq):
    """The work per unit update error of update_tolerance (SX): the stiffest entry kmax [N/m] times the step's
    largest motion dq [m]. Given per kind of unknown (positions, and the gradients and axis vectors: [kmax_pos,
    kmax_rest], [dq_pos, dq_rest]) the larger of the two products: a stiffness meets the motion of its own kind (a
    belt's contact penalty on positions that move 2 mm a step, not the 0.02 a step of its turning gradients and
    pulleys' axis vectors); never above kmax x dq over all unknowns."""
    if not isinstance(kmax, (list, tuple)):
        return ca.fmax(kmax, 1e-300) * ca.fmax(dq, 1e-300)
    return ca.fmax(*[ca.fmax(k, 1e-300) * ca.fmax(d, 1e-300) for k, d in zip(kmax, dq)])


class AlphaStepGraphs:
    """Builds the step function of one step system, scheme and Newton options:
    step(state[, D, U, UT], step_inputs) -> (next state[, D, U, UT], info), step_inputs = [h, h_prev, tols, pload,
    kel, par] (column_layout)."""
    refresh_every = 8  # one-iteration steps between two-iteration steps that re-measure omega / the contraction
    max_slots = 5  # modified Newton: iterations (refactorisations included) the step graph tries per step
    refactor_cost = 3.5  # modified Newton: a refactorisation's cost in iterations on a kept factor
    info_size = 7  # ok, iterations, factorisations, |dz0|, |dz1|, truncation error, max |KKT|
    extra_iterations = 4  # full Newton: iterations the step graph tries after the second one

    def __init__(self, system: StepSystem, scheme: Scheme, opts: NewtonOptions, factor: LDLFactor | None):
        """factor: the in-graph factorisation for modified Newton (None: full Newton)."""
        self.S, self.scheme, self.opts, self.factor = system, scheme, opts, factor
        self.modified = factor is not None
        self.nctl = 10 if self.modified else 2
        self.state_size = 5 * system.nf + system.mc + self.nctl

    @staticmethod
    def column_layout(S: StepSystem) -> dict:
        """Where each per-step input sits in the step's input column `step_inputs`: h, h_prev, tols (force [N],
        update [m]), pload (-(f_lin + Q(t_n+1)), then the drives' inputs w(t_n+1)), kel (Rayleigh K_el values,
        if any), par (StepSystem.par); "size": its length. One input instead of six: a chunk (mapaccum, unrolled)
        slices one column per step instead of six (~3 us of set-up per node: 0.6 of 1.3 ms on a 32-element rope)."""
        n_load, n_kel = S.nf + S.nw, (S.kel.size if S.kel is not None else 0)
        sizes = dict(h=1, hp=1, tols=2, pload=n_load, kel=n_kel, par=S.par.size)
        lay, o = {}, 0
        for k, m in sizes.items():
            lay[k] = slice(o, o + m)
            o += m
        lay["size"] = o
        return lay

    def step_inputs(self):
        S, nf, mc = self.S, self.S.nf, self.S.mc
        st = ca.MX.sym("state", self.state_size)
        q, v, a, ab, ap = (st[i * nf:(i + 1) * nf] for i in range(5))
        lam = st[5 * nf:5 * nf + mc]
        ctl = st[5 * nf + mc:]
        lay = self.column_layout(S)
        col = ca.MX.sym("step_inputs", lay["size"])
        h, hp = col[lay["h"]], col[lay["hp"]]  # (h_prev: unused by the constant-acceleration predictor)
        tols, pload, par = col[lay["tols"]], col[lay["pload"]], col[lay["par"]]
        kel = col[lay["kel"]] if S.kel is not None else None
        return st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par, col

    def _coefficient_function(self) -> ca.Function:
        """The step's scalar coefficients of h (and of the multiplier scale's stiffness scale) as one SX function
        (one call instead of dozens of scalar MX nodes, each a virtual-machine instruction): built once per scheme
        in the process (SCHEME_FUNCTIONS: the scale is an input, no scene is baked in)."""
        sc = self.scheme
        key = ("alpha_coefficients", sc)
        if key not in SCHEME_FUNCTIONS:
            b, g, am, af = sc.beta, sc.gamma, sc.alpha_m, sc.alpha_f
            h, scale = ca.SX.sym("h"), ca.SX.sym("scale")
            hh = h * h
            bhh = b * hh
            cm = ((1 - am) / (1 - af)) / bhh
            c5 = bhh / (1 - am)
            # qh = q + hv v + c_ab ab (hv = h), vh = v + c_vh ab, x0 = qh + c5 (a - am ab) (the constant-acceleration
            # predictor, AlphaIntegrator._predict), k0 = k_ab ab + k_a a, and the step's Newton and corrector scalars
            # (the same operations in the same order as the scalar MX nodes they replace: the same numbers)
            outs = dict(hv=h, c_ab=(0.5 - b) * hh, c_vh=h * (1 - g), c5=c5, am=am + 0 * h,
                        k_ab=am / (1 - af) + 0 * h, k_a=-af / (1 - af) + 0 * h, cm=cm, cc=g / (b * h), kc=cm * scale,
                        bhh=bhh, hg=h * g, lte=sc.error_constant() * hh)
            SCHEME_FUNCTIONS[key] = ca.Function("alpha_coefficients", [h, scale], list(outs.values()), ["h", "scale"],
                                                list(outs))
        return SCHEME_FUNCTIONS[key]

    def step_common(self, q, v, a, ab, ap, h, hp, pload, kel):
        """Predictor, constant part of the residual and the corrector of a step (MX). Each MX node is a
        virtual-machine instruction (~30-50 ns on a short vector, one pass over memory on a long one): the scalar
        coefficients come from one SX call, and every vector is a linear combination built term by term."""
        S = self.S
        nf = S.nf
        coef = self._coefficient_function()
        k = dict(zip(coef.name_out(), coef(h, ca.MX(S.stiffness_scale()))))
        cm, kc = k["cm"], k["kc"]
        qh = _add(_add(q, _mul(k["hv"], v)), _mul(k["c_ab"], ab))
        vh = _add(v, _mul(k["c_vh"], ab))
        x0 = _add(qh, _mul(k["c5"], _sub(a, _mul(k["am"], ab))))
        # a_n+1 = ((1 - am) ab_n+1 + am ab - af a) / (1 - af) = cm (x - qh) + k0: the residual's inertia is
        # M (cm x + y), y = k0 - cm qh, no product with M here (the corrector keeps cm (x - qh) + k0: cm x and y
        # are ~1/h^2 larger than their sum)
        k0 = _add(_mul(k["k_ab"], ab), _mul(k["k_a"], a))
        y = _sub(k0, _mul(cm, qh))
        damped = S.rayleigh is not None or S.damp_f is not None
        vc = _sub(vh, _mul(k["cc"], qh)) if damped else vh  # (v_n+1 = vc + cc x: used by damping only)
        Cvh, _ = rayleigh_mx(S, vc, kel)
        if S.rayleigh is not None:
            pload = ca.vertcat(Cvh + pload[:nf], pload[nf:]) if S.nw else Cvh + pload

        def lte(x):
            return _mul(k["lte"], ca.norm_inf(_sub(_add(_mul(cm, _sub(x, qh)), k0), a)))

        def block(x):  # q, v, a, ab of the new state and a_prev (parts of the state's one concatenation)
            d = _sub(x, qh)
            ab1 = _div(d, k["bhh"])
            return [x, _add(vh, _mul(k["hg"], ab1)), _add(_mul(cm, d), k0), ab1, a]

        return dict(x0=x0, p=pload, y=y, cm=cm, cc=k["cc"], kc=kc, vc=vc, lte=lte, block=block)

    def _full_control_functions(self) -> tuple[ca.Function, ca.Function]:
        """The full-Newton step's scalar logic as two SX functions (after the first iteration, and after the second
        one if it ran); the first takes the scene's coordinate span (round-off floor) as an input: they depend on
        the Newton options only, and are built once per process (SCHEME_FUNCTIONS)."""
        o = self.opts
        key = ("full_controls", o.single, o.lte_fraction, o.tol, self.refresh_every, NEWTON_WORK_FRACTION)
        if key not in SCHEME_FUNCTIONS:
            SCHEME_FUNCTIONS[key] = self._build_full_control_functions()
        return SCHEME_FUNCTIONS[key]

    def _build_full_control_functions(self) -> tuple[ca.Function, ca.Function]:
        o, tiny = self.opts, 1e-300
        sx = ca.SX.sym
        C, N0, L, T, span, dq = sx("ctl", 2), sx("n0", 7), sx("lte"), sx("tols", 2), sx("span"), sx("dq", 2)
        om, since = C[0], C[1]
        d0 = ca.fmax(N0[2], N0[3])
        tolx = update_tolerance(o, T, L, work_scale([N0[5], N0[6]], [dq[0], dq[1]]), span)
        tq = ca.fmax(T[0], 2 * np.finfo(float).eps * N0[4] * span)
        conv0 = ca.logic_and(N0[0] <= tq, N0[1] <= T[1])
        est1 = 2 * om * d0 * d0
        # omega is re-measured (second iteration) at least every refresh_every steps, up to 8x less often when the
        # estimate has a wide margin
        fresh = since < self.refresh_every * ca.fmin(8, ca.fmax(1, 0.1 * tolx / ca.fmax(est1, tiny)))
        conv1 = ca.logic_and(ca.logic_and(om > 0, fresh), est1 <= tolx)
        accept1 = ca.logic_or(conv0, conv1) if o.single else ca.SX(0)
        flag = ca.if_else(accept1, 0, 1)  # (an output of its own: the switch reads it with no extraction node)
        # and the controls and info of a step accepted now (what `final` gives then), passed on by the switch's
        # keep branch: a one-iteration step calls no SX function after the switch
        first = ca.Function("after_first", [C, N0, L, T, span, dq],
                            [flag, ca.vertcat(flag, tq, tolx, d0), ca.vertcat(om, since + 1),
                             ca.vertcat(1, 1, 1, d0, 0, L, N0[4])])
        A, N1 = sx("a", 4), sx("n1", 7)
        second, tq, tolx, d0 = A[0], A[1], A[2], A[3]
        accept1 = second == 0
        d1 = ca.fmax(N1[2], N1[3])
        th = d1 / ca.fmax(d0, tiny)
        conv2 = ca.logic_or(ca.logic_and(N1[0] <= tq, N1[1] <= T[1]), d1 <= 0.1 * tolx)
        conv2 = ca.logic_or(conv2, ca.logic_and(th < 0.5, th / (1 - th) * d1 <= tolx))
        ok = ca.if_else(accept1, 1, conv2)
        om_new = ca.if_else(accept1, om, ca.if_else(d0 > 0, ca.fmax(d1 / ca.fmax(d0 * d0, tiny), 0.5 * om), om))
        since_new = ca.if_else(accept1, since + 1, 0)
        iters = ca.if_else(accept1, 1, 2)
        final = ca.Function("controls", [C, N0, A, N1, L, T],
                            [ca.vertcat(om_new, since_new), ca.vertcat(ok, iters, iters, d0, d1, L, N0[4])])
        return first, final

    @staticmethod
    def _later_control_function() -> ca.Function:
        """Convergence after a third or later full Newton iteration (the criteria of `newton`, on the step's update
        tolerance): (ok, iterations, last |dz|) updated by the norms of the iteration (zeros if skipped).
        Independent of the scene and options: built once per process."""
        if "later_controls" not in SCHEME_FUNCTIONS:
            SCHEME_FUNCTIONS["later_controls"] = AlphaStepGraphs._build_later_control_function()
        return SCHEME_FUNCTIONS["later_controls"]

    @staticmethod
    def _build_later_control_function() -> ca.Function:
        sx, tiny = ca.SX.sym, 1e-300
        V, N, A, T = sx("lv", 3), sx("n", 7), sx("a", 4), sx("tols", 2)
        ok, iters, d_prev = V[0], V[1], V[2]
        # (the step's update tolerance, as after the second iteration: the absolute one, which the Python loop
        # uses, made steps that missed the second iteration's acceptance converge to 1e-10 L, 1-2 iterations
        # more: belt drive 3.16 -> 2.80 Newton iterations per step with the Hertz law, 4.32 -> 3.67 linear; the
        # HHT cases that once needed it ran before the truncation-error part was capped by update_tolerance)
        tq, tolx = A[1], A[2]
        ran = ok == 0
        d = ca.fmax(N[2], N[3])
        th = d / ca.fmax(d_prev, tiny)
        conv = ca.logic_or(ca.logic_or(ca.logic_and(N[0] <= tq, N[1] <= T[1]), d <= 0.1 * tolx),
                           ca.logic_and(th < 0.5, th / (1 - th) * d <= tolx))
        return ca.Function("after_later", [V, N, A, T], [ca.vertcat(ca.logic_or(ok, ca.logic_and(ran, conv)),
                                                                    iters + ran, ca.if_else(ran, d, d_prev))])

    def _motion_by_kind(self, d: ca.MX) -> ca.MX:
        """[max |d| over the position unknowns, over the others] (work_scale; 0 for a kind without unknowns)."""
        pos = self.S.is_position
        return ca.vertcat(*[ca.norm_inf(d[list(map(int, i))]) if len(i) else ca.MX(0)
                            for i in (np.flatnonzero(pos), np.flatnonzero(~pos))])

    def build_full(self, extra_iterations: int) -> ca.Function:
        """Full Newton: one iteration, then (in-graph switch) either acceptance or a second iteration, and up to
        extra_iterations more while not converged."""
        S = self.S
        nf, mc = S.nf, S.mc
        st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par, col = self.step_inputs()
        c = self.step_common(q, v, a, ab, ap, h, hp, pload, kel)
        x0, p, cm, cc, kc, vc, y = c["x0"], c["p"], c["cm"], c["cc"], c["kc"], c["vc"], c["y"]
        l0 = _div(lam, kc) if mc else lam
        extra = [kel] if kel is not None else []
        it = S.iteration_f  # (no multipliers: without its empty multiplier input, and no empty inputs below)
        lm = [l0] if mc else []
        # (the first iteration, which every step runs, inlined: ~1 us a step less than a call node; the second, in
        # a branch most steps skip, stays a call)
        dz, n0 = it.call([x0, *lm, p, cm, cc, kc, vc, *extra, y, par], True, False)
        x1 = _add(x0, dz[:nf] if mc else dz)
        l1 = _add(l0, dz[nf:]) if mc else l0
        lte = c["lte"](x1)
        first, final = self._full_control_functions()
        second, a1, ctl1, info1 = first(ctl, n0, lte, tols, self.S.span, self._motion_by_kind(_sub(x1, q)))
        # the second iteration and the controls after it, evaluated only when needed (a switch whose keep branch
        # passes x1, l1 and the controls of a step accepted after one iteration on)
        xb, pb = ca.MX.sym("xb", nf), ca.MX.sym("pb", nf + S.nw)
        lb = ca.MX.sym("lb", mc) if mc else ca.MX(0, 1)  # (no empty inputs: StepSystem._with_multiplier_input)
        cb, ccb, kb, vb = ca.MX.sym("cmb"), ca.MX.sym("ccb"), ca.MX.sym("kcb"), ca.MX.sym("vcb", nf)
        eb = [ca.MX.sym("kelb", S.kel.size)] if kel is not None else []
        yb, parb = ca.MX.sym("yb", nf), ca.MX.sym("parb", S.par.size)
        cb_, n0b, a1b, lteb, tb = ca.MX.sym("ctl", 2), ca.MX.sym("n0", 7), ca.MX.sym("a1", 4), ca.MX.sym("lte"), \
            ca.MX.sym("tols", 2)
        ctl1b, info1b = ca.MX.sym("ctl1", 2), ca.MX.sym("info1", self.info_size)
        iter_ins = [xb] + ([lb] if mc else []) + [pb, cb, ccb, kb, vb] + eb + [yb, parb]
        dzb, n1b = it(*iter_ins)
        x2b, l2b = _add(xb, dzb[:nf] if mc else dzb), _add(lb, dzb[nf:]) if mc else lb
        ctl2b, info2b = final(cb_, n0b, a1b, n1b, lteb, tb)
        # further iterations while not converged after the second (hard transients: the step stays in the graph,
        # and a chunk goes on): a switch inside the second iteration's branch, so that the steps accepted after one
        # iteration (most of them) pay nothing for it
        n_more = max(0, min(extra_iterations, self.opts.max_iter - 2))
        if n_more:
            later = self._later_control_function()
            lvb = ca.MX.sym("lv", 3)
            # one further iteration on z = (x, lam, (ok, iterations, last |dz|)), folded n_more times (one graph
            # to build, not n_more)
            f_iter = ca.Function("iteration", iter_ins, [x2b, l2b, n1b])
            f_keep = ca.Function("keep", iter_ins, [xb, lb, ca.DM.zeros(7)])
            xk, lk, nk = ca.Function.conditional("next_iteration", [f_keep], f_iter)(lvb[0] == 0, *iter_ins)
            zb = ca.vertcat(xb, lb, lvb)
            others = [a1b, tb, pb, cb, ccb, kb, vb] + eb + [yb, parb]
            one = ca.Function("further_iteration", [zb] + others, [ca.vertcat(xk, lk, later(lvb, nk, a1b, tb))])
            zin = ca.MX.sym("z", zb.numel())
            # (folded as an unrolled mapaccum's last column: 1.2 ms to build at 1000 elements, Function.fold 5 ms)
            folded = one.mapaccum("further_iterations_unrolled", n_more, 1, {"base": -1})(
                zin, *[ca.repmat(o, 1, n_more) for o in others])[:, -1]
            more = ca.Function.conditional("further_iterations", [ca.Function("done", [zin] + others, [zin])],
                                           ca.Function("more", [zin] + others, [folded]))
            lv2 = ca.vertcat(info2b[0], info2b[1], ca.fmax(n1b[2], n1b[3]))
            z3 = more(lv2[0] == 0, ca.vertcat(x2b, l2b, lv2), *others)
            x2b, l2b, lv3 = z3[:nf], z3[nf:nf + mc], z3[nf + mc:]
            # (ok, iterations) of the further iterations where they ran
            ran = lv2[0] == 0
            ok, iters = ca.if_else(ran, lv3[0], info2b[0]), ca.if_else(ran, lv3[1], info2b[1])
            info2b = ca.vertcat(ok, iters, iters, info2b[3:])
        br_ins = iter_ins + [cb_, n0b, a1b, lteb, tb, ctl1b, info1b]
        f_keep = ca.Function("keep", br_ins, [xb, lb, ctl1b, info1b])
        f_second = ca.Function("second", br_ins, [x2b, l2b, ctl2b, info2b])
        x2, l2, ctl_new, info = ca.Function.conditional("second_iteration", [f_keep], f_second)(
            second, x1, *([l1] if mc else []), p, cm, cc, kc, vc, *extra, y, par, ctl, n0, a1, lte, tols, ctl1,
            info1)
        new_state = ca.vertcat(*c["block"](x2), _mul(l2, kc) if mc else l2, ctl_new)
        return self.make_step_f([st], col, [new_state], info)

    # carried control vector of the modified step (SX functions between the iterations)
    _CV = ("conv", "tolx", "tq", "kmax", "iters", "nfull", "since_full", "d_prev", "last_full", "th", "mode",
           "d1", "th1", "conv0", "refac0", "d0", "th0", "lte1")

    def _control_functions(self) -> dict:
        """The modified step's scalar logic as SX functions (a few calls instead of hundreds of MX nodes)."""
        o = self.opts
        KEEP, MOD, FULL = 0, 1, 2
        cmax, R, tiny = o.contraction, self.refactor_cost, 1e-300
        sx = ca.SX.sym
        C, hs, T = sx("ctl", self.nctl), sx("h"), sx("tols", 2)
        om, since, rate, age, fh, kmax, d0p, tolxp, ltep, cyc = (C[k] for k in range(self.nctl))
        fresh = since < self.refresh_every
        known = rate >= 0
        idx = {k: i for i, k in enumerate(self._CV)}
        # before the first iteration: on the kept factor, or refactorise (no factor for this step size, contraction
        # too slow, or the iterations predicted on the kept factor cost more than a refactorisation's cycle does
        # per step: renewal rule, m0 > cyc / age)
        th0 = ca.fmax(rate, 0) * age
        # (an iteration on the kept factor is accepted only after the next one measured its contraction)
        m0 = 1 + ca.fmax(1, ca.ceil(ca.log(ca.fmax(tolxp * (1 - th0), tiny) / ca.fmax(d0p, tiny)) /
                                    ca.log(ca.fmin(ca.fmax(th0, tiny), 0.999))))
        costly = ca.logic_and(ca.logic_and(known, d0p > 0), m0 * age > cyc)
        refac0 = ca.logic_or(ca.logic_not(ca.logic_and(fh > 0, ca.fabs(fh - hs) <= 1e-9 * hs)),
                             ca.logic_and(known, ca.logic_or(th0 >= cmax, costly)))
        decide = ca.Function("decide", [C, hs], [ca.vertcat(ca.if_else(refac0, FULL, MOD), th0)])
        # after the first iteration
        N, L1, M0, TH0, DQ = sx("n", 3), sx("lte1"), sx("mode0"), sx("th0"), sx("dq")
        rq0, d0 = N[0], N[1]
        ref0 = M0 == FULL
        kmax1 = ca.if_else(ref0, N[2], kmax)
        lte_use = ca.if_else(ltep > 0, ca.fmin(L1, 2 * ltep), L1)  # x1 may be off by the tolerance
        tolx = update_tolerance(o, T, lte_use, work_scale(kmax1, DQ), self.S.span)
        tq = ca.fmax(T[0], 2 * np.finfo(float).eps * kmax1 * self.S.span)
        ok_full = ca.logic_and(ref0, ca.logic_or(d0 <= 0.1 * tolx, ca.logic_and(ca.logic_and(om > 0, fresh),
                                                                                2 * om * d0 * d0 <= tolx)))
        conv = ca.logic_or(rq0 <= tq, ok_full) if o.single else ca.SX(0)
        vals = dict(conv=conv, tolx=tolx, tq=tq, kmax=kmax1, iters=1, nfull=ref0, since_full=0, d_prev=d0,
                    last_full=ref0, th=0, mode=ca.if_else(conv, KEEP, MOD), d1=0, th1=0, conv0=conv, refac0=ref0,
                    d0=d0, th0=TH0, lte1=L1)
        first = ca.Function("after_first", [C, N, L1, T, M0, TH0, DQ], [ca.vertcat(*[vals[k] for k in self._CV])])
        # after a further iteration: keep when converged; after a refactorisation the new factor; else refactorise
        # when the kept factor contracted too slowly (theta measured in this step)
        CV, Nk = sx("cv", len(self._CV)), sx("n", 3)
        cv = {k: CV[i] for k, i in idx.items()}
        ran, is_full = cv["mode"] != KEEP, cv["mode"] == FULL
        rq, d = Nk[0], Nk[1]
        th = ca.if_else(ran, d / ca.fmax(cv["d_prev"], tiny), 0)
        conv_k = ca.logic_or(ca.logic_or(rq <= cv["tq"], d <= 0.1 * cv["tolx"]),
                             ca.logic_and(th < 0.5, th / (1 - th) * d <= cv["tolx"]))
        new = dict(cv)
        new["conv"] = ca.logic_or(cv["conv"], ca.logic_and(ran, conv_k))
        new["iters"] = cv["iters"] + ran
        new["nfull"] = cv["nfull"] + is_full
        new["since_full"] = ca.if_else(is_full, 0, cv["since_full"] + ran)
        new["kmax"] = ca.if_else(is_full, Nk[2], cv["kmax"])
        new["d_prev"] = ca.if_else(ran, d, cv["d_prev"])
        new["last_full"] = ca.if_else(ran, is_full, cv["last_full"])
        new["th"] = th
        bad = ca.logic_and(ca.logic_not(new["last_full"]), th > cmax)
        new["mode"] = ca.if_else(new["conv"], KEEP, ca.if_else(bad, FULL, MOD))
        later = ca.Function("after_later", [CV, Nk], [ca.vertcat(*[new[k] for k in self._CV])])
        new1 = dict(new, d1=d, th1=th)
        second = ca.Function("after_second", [CV, Nk], [ca.vertcat(*[new1[k] for k in self._CV])])
        # controls for the next step
        L2 = sx("lte")
        two = ca.logic_not(cv["conv0"])  # a second iteration ran: the estimates were measured
        # contraction per step of factor age, measured when the step started on the kept factor (age >= 1);
        # it rises at once and decays slowly (one lucky measurement must not make the next steps optimistic)
        meas = cv["th1"] / ca.fmax(age, 1)
        rate_new = ca.if_else(ca.logic_and(two, ca.logic_not(cv["refac0"])),
                              ca.if_else(known, ca.fmax(meas, 0.7 * rate), meas), rate)
        om_new = ca.if_else(ca.logic_and(two, cv["refac0"]),
                            ca.if_else(cv["d0"] > 0, ca.fmax(cv["d1"] / ca.fmax(cv["d0"] ** 2, tiny), 0.5 * om), om),
                            om)
        any_full = cv["nfull"] > 0
        ctl_new = ca.vertcat(om_new, ca.if_else(two, 0, since + 1), rate_new, ca.if_else(any_full, 1, age + 1),
                             ca.if_else(any_full, hs, fh), cv["kmax"], cv["d0"], cv["tolx"], L2,
                             ca.if_else(any_full, R + cv["since_full"], cyc + cv["iters"]))
        info = ca.vertcat(cv["conv"], cv["iters"], cv["nfull"], cv["d0"], cv["d1"], cv["lte1"], cv["kmax"])
        final = ca.Function("controls", [C, CV, L2, hs], [ctl_new, info])
        return dict(decide=decide, first=first, second=second, later=later, final=final, mode=idx["mode"])

    def build_modified(self) -> ca.Function:
        """Modified Newton with the LDL^T factor as accumulated inputs (see the class docstring)."""
        S = self.S
        nf = S.nf
        fac = self.factor
        nD, nU, nUT = fac.size
        st, (q, v, a, ab, ap, lam, ctl), h, hp, tols, pload, kel, par, col = self.step_inputs()
        D0, U0, UT0 = ca.MX.sym("D", nD), ca.MX.sym("U", nU), ca.MX.sym("UT", nUT)
        c = self.step_common(q, v, a, ab, ap, h, hp, pload, kel)
        x0, p, cm, cc, vc, y = c["x0"], c["p"], c["cm"], c["cc"], c["vc"], c["y"]
        extra = [kel] if kel is not None else []
        # one Newton iteration of each kind, with the same signature: keep (converged), kept factor, refactorise
        xs, Ds, Us, UTs = ca.MX.sym("x", nf), ca.MX.sym("D", nD), ca.MX.sym("U", nU), ca.MX.sym("UT", nUT)
        ps, cms, ccs, vcs = ca.MX.sym("p", nf + S.nw), ca.MX.sym("cm"), ca.MX.sym("cc"), ca.MX.sym("vc", nf)
        ks = [ca.MX.sym("kel", S.kel.size)] if kel is not None else []
        ys, pars = ca.MX.sym("y", nf), ca.MX.sym("par", S.par.size)
        args = [xs, Ds, Us, UTs, ps, cms, ccs, vcs] + ks + [ys, pars]
        res_f, jac_f = S.residual_f, S.jacobian_f  # (no multipliers here: no multiplier input)
        r, nr = res_f(xs, ps, cms, ccs, 1.0, vcs, *ks, ys, pars)
        dz = -fac.solve_mx(Ds, Us, UTs, r)
        f_mod = ca.Function("kept_factor", args, [xs + dz, Ds, Us, UTs, ca.vertcat(nr[0], ca.mmax(ca.fabs(dz)), 0)])
        r, nj, knz = jac_f(xs, ps, cms, ccs, 1.0, vcs, *ks, ys, pars)
        D2, U2, UT2 = fac.fact_f(knz)
        dz = -fac.solve_mx(D2, U2, UT2, r)
        f_full = ca.Function("refactorise", args,
                             [xs + dz, D2, U2, UT2, ca.vertcat(nj[0], ca.mmax(ca.fabs(dz)), nj[2])])
        f_keep = ca.Function("keep", args, [xs, Ds, Us, UTs, ca.DM.zeros(3)])
        slot = ca.Function.conditional("newton_iteration", [f_keep, f_mod], f_full)  # 0 keep, 1 kept, 2 refactorise
        cf = self._control_functions()
        dm = cf["decide"](ctl, h)
        mode0, th0 = dm[0], dm[1]
        x, Dk, Uk, UTk, n = slot(mode0, x0, D0, U0, UT0, p, cm, cc, vc, *extra, y, par)
        cv = cf["first"](ctl, n, c["lte"](x), tols, mode0, th0, ca.norm_inf(_sub(x, q)))
        for k in range(1, self.max_slots):
            x, Dk, Uk, UTk, n = slot(cv[cf["mode"]], x, Dk, Uk, UTk, p, cm, cc, vc, *extra, y, par)
            cv = (cf["second"] if k == 1 else cf["later"])(cv, n)
        ctl_new, info = cf["final"](ctl, cv, c["lte"](x), h)
        new_state = ca.vertcat(*c["block"](x), lam, ctl_new)
        return self.make_step_f([st, D0, U0, UT0], col, [new_state, Dk, Uk, UTk], info)

    def make_step_f(self, accum_in, col, accum_out, info) -> ca.Function:
        names = ["state", "D", "U", "UT"][:len(accum_in)] + ["step_inputs"]
        return ca.Function("alpha_step", accum_in + [col], accum_out + [info], names,
                           ["next_" + nm for nm in names[:len(accum_out)]] + ["info"])
