"""Discrete adjoint of a dynamic run of the alpha schemes (Newmark / HHT / generalized-alpha, fixed steps): the
gradient of one output with respect to many parameters, exact to the integrator's own arithmetic (the derivative
of the discrete solution, as ancf_sym.sensitivity.dynamics's forward sensitivities, whose recursion it transposes).

The step n -> n+1 (Arnold-Bruels form, ancf_sym.dynamics.schemes) on the reduced coordinates, with Rayleigh mass
damping C = alpha_R M:

    D     = -(q_n + h v_n + h^2 (1/2 - beta) abar_n) / (h^2 beta)
    abar' = q' / (h^2 beta) + D,   a' = cm q' + c1 D + (alpha_m abar_n - alpha_f a_n) / (1 - alpha_f),
    v'    = cc q' + v_n + h (1 - gamma) abar_n + h gamma D,
    M a' + C v' + R(q', p) = 0        (R: the potential's gradient less the dead loads)

Differentiated, J' dq' = -(M B + C Bv + F'), J' = cm M + cc C + K(q'): the converged Newton tangent, and
F' = dR/dp(q') + dM/dp a' + dC/dp v'. The adjoint runs backward over the stored states: per step one solve with
J'^T (= J', symmetric), mu' = J'^-1 s', and the gradient is -sum_n mu_n . F_n (plus the static start's term by
the statics' adjoint, the initial acceleration's M a_0 = -R(q_0) by one solve with M). The backward sweep is one
CasADi mapaccum over the steps (the step's tangent from the system's compiled force graph, a sparse LDL^T solve
in the graph); the parameter terms sum_n mu_n . dR/dp(q_n) are one mapped kernel call over all steps' elements
per distinct derivative piece (ancf_sym.sensitivity.model_derivative), the dead loads' and the mass's sums one
product each: 100 parameters cost a few mapped calls, not 100 runs.

Outputs: functions of the sensor records or of a constraint row's multiplier (a reaction: MultiplierOutput) (their
sum, time integral, end value, or the least-squares misfit to a data record) and the kinetic, potential or total
energy at the end. Parameters: the TOML paths of model_derivative, and the scene's Rayleigh coefficients
dampings[i].alpha | beta. Scope as the forward sensitivities (refused by name before any step,
ancf_sym.sensitivity.alpha_run) (applied torques: their skew tangent in J', solved transposed);
stiffness-proportional Rayleigh damping C_n = alpha M + beta K_el(q_n) enters J' through C_n and the earlier state's
adjoint through -T_n' mu (T_n = beta d(K_el(q) v_{n+1})/dq at q_n, the kernels' Hessian-vector companions); with
multiplier rows or drives the step is a KKT system and the adjoint solves its transpose with [s; kc wl] (mu: the
coordinates' part);
strain-rate damping, contact damping and friction (one dissipation force f_d(q, v)) add their tangents df/dq +
cc df/dv to J' and df/dv to the velocity's adjoint, their coefficients' terms -sum_n mu_n . df_d/dp (contacts[i].mu |
damping | stiffness | hertz: ancf_sym.sensitivity.contact_dissipation); time loads are
applied as the run applies them. Penalty contacts: the steps where one opens or closes are
named in the notes (the law's kink: one-sided derivatives there).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ancf_sym import kernels
from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.sensors import Sensor, SensorEval
from ancf_sym.sensitivity.sensor_jacobian import sensor_jacobian
from ancf_sym.sensitivity.alpha_run import contact_notes, damping_index, damping_matrices, forcing, \
    run_for_sensitivity, step_inputs, step_matrix, stiffness_damped, stiffness_damping_forcing
from ancf_sym.sensitivity.contact_dissipation import dissipation_forcing, dissipation_index
from ancf_sym.sensitivity.collocation_run import COLLOCATION, collocation_adjoint, collocation_run
from ancf_sym.sensitivity.length_derivative import LengthPiece
from ancf_sym.sensitivity.kernel_direction import DirectionPiece
from ancf_sym.sensitivity.run_start import velocity_map
from ancf_sym.sensitivity.step_sequence import step_notes
from ancf_sym.sensitivity.start_derivative import own_start, start_tangents, static_start_gradient
from ancf_sym.sensitivity.model_derivative import STIFFNESS_COLUMNS, ModelDerivative, model_derivative, \
    read_document
from ancf_sym.sensitivity.static_start import StartSystem
from ancf_sym.system.step_system import StepSystem
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.util.sparsity import dm

REDUCTIONS = ("integral", "sum", "end", "least_squares")


@dataclass
class SensorOutput:
    """One number from a sensor's record y_n (component `component`) over the steps n = 0..N: "integral" (the
    trapezoid rule in time), "sum", "end" (y_N), or "least_squares" 1/2 sum_n (y_n - data_n)^2 (data: N + 1
    values at the step times)."""
    sensor: str
    component: int = 0
    reduce: str = "integral"
    data: np.ndarray | None = None


ENERGIES = ("kinetic", "potential", "total")


@dataclass
class EnergyOutput:
    """An energy at the end of the run: "kinetic" 1/2 v' M v, "potential" (strain energies, gravity, dead loads:
    the run's potential), or "total" (their sum)."""
    which: str = "total"


@dataclass
class KineticEnergyOutput(EnergyOutput):
    """The kinetic energy 1/2 v' M v at the end of the run."""
    which: str = "kinetic"


@dataclass
class MultiplierOutput:
    """One number from the multiplier of a constraint row over the steps (a joint's or a drive's reaction: the row
    `row` of the kept exact rows, then the drives' rows, as DynamicSensitivity.lam), reduced as SensorOutput's."""
    row: int
    reduce: str = "integral"
    data: np.ndarray | None = None


def _reduction(reduce: str, y: np.ndarray, t: np.ndarray, data) -> tuple[float, np.ndarray]:
    """(value, d value / d y_n) of a record y_n over the steps (see SensorOutput)."""
    N1 = len(t)
    if reduce == "sum":
        return float(y.sum()), np.ones(N1)
    if reduce == "end":
        w = np.zeros(N1)
        w[-1] = 1.0
        return float(y[-1]), w
    if reduce == "integral":
        dt = np.diff(t)
        w = np.zeros(N1)
        w[:-1] += dt / 2
        w[1:] += dt / 2
        return float(w @ y), w
    d = np.asarray(data, float).ravel()
    if d.shape != y.shape:
        raise ValueError(f"output data: {d.size} values for {y.size} step times")
    return 0.5 * float((y - d) @ (y - d)), y - d


@dataclass
class DynamicGradient:
    """value: the output; gradient[path]: d(output)/dp; t, x, v: the step times and full states of the run it
    differentiates (steps + 1 rows); notes: what the derivative does not cover."""
    value: float
    gradient: dict
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    notes: list = field(default_factory=list)


# -- the backward sweep as one CasADi graph ------------------------------------------------------------------------
_SWEEPS: dict = {}


def backward_sweep(S: StepSystem, opts: DynamicOptions, alpha_r: float, n: int, variable: bool = False
                   ) -> ca.Function:
    """sweep(acc0, U) -> (acc, MU), U = [X; V; WQ; WV[; Lam; W][; X_prev]]: n backward steps (columns: steps N, N-1,
    .., 1) of the adjoint recursion (see the module docstring); acc = the adjoints flowing into (q, v, a, abar) of the
    earlier state; Lam, W: the multipliers and drives' time inputs, X_prev: q_n (Rayleigh beta); variable: the step
    sizes as U's last row (the scheme's coefficients per step), else h = dt."""
    sch = opts.scheme()
    h = ca.MX.sym("h") if variable else opts.dt
    key = (S.graph_key, sch, None if variable else h, alpha_r, S.rayleigh.beta if S.rayleigh is not None else 0.0, n, S.par.tobytes())
    if key in _SWEEPS:
        return _SWEEPS[key]
    nf = S.nf
    am, af, beta, gamma = sch.alpha_m, sch.alpha_f, sch.beta, sch.gamma
    cm, cc = sch.cm(h), sch.cc(h)
    c1 = (1 - am) / (1 - af)
    M = dm(S.M)
    mc = S.mc
    acc = ca.MX.sym("acc", 4 * nf)
    x, v, wq, wv = ca.MX.sym("x", nf), ca.MX.sym("v", nf), ca.MX.sym("wq", nf), ca.MX.sym("wv", nf)
    y = ca.MX.sym("y", step_inputs(S)) if step_inputs(S) else None  # (the true multipliers, the drives' inputs)
    xp = ca.MX.sym("xp", nf) if stiffness_damped(S) else None  # (q_n: where the run took K_el of the step)
    C, T = damping_matrices(S, alpha_r, xp, v)
    J, dfv, solver = step_matrix(S, cm, cc, C, x, v, y)
    qb, vb, abar, abb = (acc[i * nf:(i + 1) * nf] for i in range(4))
    qb, vb = qb + wq, vb + wv
    s = qb + abb / (h * h * beta) + cm * abar + cc * vb
    wl = ca.MX.sym("wl", mc)  # (d output / d lam_{n+1}: a multiplier output's weights)
    if mc:  # (the KKT step: its transpose with [s; kc wl], mu the coordinates' part; lam = kc times the solution's)
        mu = ca.solve(J.T, ca.vertcat(s, cm * S.stiffness_scale() * wl), solver)[:nf]
    else:
        mu = ca.solve(J, s, "ldl") if solver == "ldl" else ca.solve(J.T, s, solver)  # (J' mu = s)
    Mmu = ca.mtimes(M, mu)
    Bb = abar - Mmu
    Bvb = vb - ca.mtimes(C.T, mu)
    if dfv is not None:
        Bvb = Bvb - ca.mtimes(dfv.T, mu)
    Db = abb + h * gamma * Bvb + c1 * Bb
    Sq = -Db / (h * h * beta)
    if T is not None:  # (beta K_el(q_n) v_{n+1}: its change with q_n)
        Sq = Sq - ca.mtimes(T.T, mu)
    Sv = Bvb - Db / (h * beta)
    Sa = -af / (1 - af) * Bb
    Sab = h * (1 - gamma) * Bvb + am / (1 - af) * Bb - (0.5 - beta) / beta * Db
    u = ca.vertcat(x, v, wq, wv, *([y] if y is not None else []), *([xp] if xp is not None else []),
                   *([wl] if mc else []), *([h] if variable else []))
    step = ca.Function("adjoint_step", [acc, u], [ca.vertcat(Sq, Sv, Sa, Sab), mu])
    sweep = step.mapaccum("adjoint_steps", n)
    a0, U = ca.MX.sym("acc0", 4 * nf), ca.MX.sym("U", u.size1(), n)
    ACC, MU = sweep(a0, U)
    # (only the last accumulated adjoint leaves the graph: no 4 nf x n output to copy)
    f = ca.Function("adjoint_sweep", [a0, U], [ACC[:, n - 1], MU])
    _SWEEPS[key] = f
    return f


# -- outputs -------------------------------------------------------------------------------------------------------
def output_weights(out, sensors: list[SensorEval], S: StepSystem, t: np.ndarray, X: np.ndarray,
                   V: np.ndarray, Vr: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(value, d value / dq_n, d value / dv_n) on the reduced coordinates, rows n = 0..N (X, V: full states,
    Vr: reduced velocities)."""
    N1 = len(t)
    E = S.E
    if isinstance(out, EnergyOutput):
        if out.which not in ENERGIES:
            raise ValueError(f"output energy {out.which!r}: one of {ENERGIES}")
        WQ, WV = np.zeros((N1, S.nf)), np.zeros((N1, S.nf))
        T, pots = S.energies_by_label(S.reduce(X[-1]), Vr[-1])
        val = 0.0
        if out.which in ("kinetic", "total"):
            WV[-1] = S.M @ Vr[-1]
            val += T
        if out.which in ("potential", "total"):  # d Pi / dq = g(q) - f_lin on the unknowns
            WQ[-1] = S.forces(S.reduce(X[-1]))[0] - S.f_lin
            val += float(sum(pots))
        return val, WQ, WV
    ev = next((e for e in sensors if e.sensor.name == out.sensor), None)
    if ev is None:
        raise KeyError(f"output sensor {out.sensor!r}: no such sensor; sensors: {[e.sensor.name for e in sensors]}")
    if out.reduce not in REDUCTIONS:
        raise ValueError(f"output reduce {out.reduce!r}: one of {REDUCTIONS}")
    y = np.array([ev(x, v) for x, v in zip(X, V)])[:, out.component]
    Js = [sensor_jacobian(ev, x, v) for x, v in zip(X, V)]  # (the record's exact Jacobians per step)
    G = np.array([Jx[out.component] for Jx, _ in Js])
    Gv = np.array([Jv[out.component] for _, Jv in Js])
    if out.reduce == "sum":
        w, val = np.ones(N1), float(y.sum())
    elif out.reduce == "end":
        w = np.zeros(N1)
        w[-1] = 1.0
        val = float(y[-1])
    elif out.reduce == "integral":
        dt = np.diff(t)
        w = np.zeros(N1)
        w[:-1] += dt / 2
        w[1:] += dt / 2
        val = float(w @ y)
    else:
        d = np.asarray(out.data, float).ravel()
        if d.shape != y.shape:
            raise ValueError(f"output data: {d.size} values for {y.size} step times")
        w, val = y - d, 0.5 * float((y - d) @ (y - d))
    # (E' maps a force on the full coordinates to the unknowns)
    return val, np.asarray((E.T @ (w[:, None] * G).T).T), np.asarray((E.T @ (w[:, None] * Gv).T).T)


# -- the parameter terms: sum over steps of mu_n . dR/dp(x_n) -----------------------------------------------------
_MAPPED: dict = {}
BLOCK = 200_000  # element states per mapped kernel call (bounds the memory of one call)


def _step_sum_function(element: str, effect: str, gauss, ne: int, k: int) -> ca.Function:
    """(x (nd, k ne), P (np, ne), lam (nd, k ne)) -> w (1, ne): w_e = sum over the k steps of lam_e . grad_e(x_e, P_e),
    the kernel's gradient mapped over the elements and summed over the steps inside one call."""
    key = (element, effect, gauss, ne, k)
    if key not in _MAPPED:
        g = kernels.load_grad(element, effect, gauss)
        x, P, lam = ca.MX.sym("x", g.size1_in(0)), ca.MX.sym("P", g.size1_in(1)), ca.MX.sym("lam", g.size1_in(0))
        dot = ca.Function("lam_grad", [x, P, lam], [ca.dot(lam, g(x, P)[1])])
        _MAPPED[key] = dot.map(ne).map(k, [False, True, False], [True])
    return _MAPPED[key]


def _step_sum(element: str, effect: str, gauss, idx: np.ndarray, P: np.ndarray, Lam: np.ndarray,
              X: np.ndarray) -> np.ndarray:
    """w_e = sum_n Lam_n[idx_e] . grad_e(x_n[idx_e]; P_e) per element e (the gravity kernel's gradient is constant
    in x: evaluated once, at x_0, with the sum of the Lam_n)."""
    ne, nd = idx.shape
    Pc = np.ascontiguousarray(P, dtype=float)
    if effect == "gravity":
        X, Lam = X[:1], Lam.sum(axis=0)[None, :]
    w = np.zeros(ne)
    steps = max(1, BLOCK // ne)
    for s0 in range(0, len(X), steps):
        Xb, Lb = X[s0:s0 + steps], Lam[s0:s0 + steps]
        out = np.zeros(ne)
        f = _step_sum_function(element, effect, gauss, ne, len(Xb))
        _, evaluate = bind(f, [np.ascontiguousarray(Xb[:, idx]).ravel(), Pc.ravel(),
                              np.ascontiguousarray(Lb[:, idx]).ravel()], [out])
        evaluate()
        w += out
    return w


def residual_sum(md: ModelDerivative, Lam: np.ndarray, X: np.ndarray, cache: dict) -> float:
    """sum_n Lam_n . dR/dp(x_n) (full coordinates; R = grad Pi: the pieces' gradients less the dead loads dQ).
    A kernel is linear in its coefficient group (model_derivative): per element and group column the sum is
    computed once with a unit coefficient (cache) and serves every parameter that scales that column (E and I
    share the bending term's)."""
    total = 0.0
    for pc in md.pieces:
        if isinstance(pc, (LengthPiece, DirectionPiece)):  # (a prestrain's length derivative, a kernel's companion:
            # the gradient's derivative at every state)
            total += float(np.sum(Lam * pc.gradients(X)))
            continue
        names = kernels.parameters(pc.element, pc.effect)
        group = STIFFNESS_COLUMNS.get(pc.effect, ("rhoA",) if pc.effect == "gravity" else ())
        cols = [names.index(c) for c in group if c in names]
        P = np.asarray(pc.P, float)
        if not cols:  # (load kernels: the piece itself)
            key = (pc.element, pc.effect, pc.gauss, pc.idx.tobytes(), P.tobytes())
            if key not in cache:
                cache[key] = _step_sum(pc.element, pc.effect, pc.gauss, pc.idx, P, Lam, X).sum()
            total += cache[key]
            continue
        base = P.copy()
        base[:, cols] = 0.0
        key = (pc.element, pc.effect, pc.gauss, pc.idx.tobytes(), base.tobytes())
        if key not in cache:
            W = []
            for c in cols:
                Pu = base.copy()
                Pu[:, c] = 1.0
                W.append(_step_sum(pc.element, pc.effect, pc.gauss, pc.idx, Pu, Lam, X))
            cache[key] = np.column_stack(W)
        total += float(np.sum(cache[key] * P[:, cols]))
    if md.dQ is not None:
        total -= float(Lam.sum(axis=0) @ md.dQ)
    return total


def energy_partial(output, asm, doc: dict, path: str, X: np.ndarray, V: np.ndarray) -> float:
    """An energy output's explicit derivative at the end state (the mass's in the kinetic energy, the energies' own
    in the potential); 0 for other outputs and for damping paths."""
    if not isinstance(output, EnergyOutput) or damping_index(doc, path) is not None or \
            dissipation_index(doc, path) is not None:
        return 0.0
    md = model_derivative(asm, doc, path)
    g = 0.0
    if md.dM is not None and output.which in ("kinetic", "total"):
        g += 0.5 * float(V[-1] @ (md.dM @ V[-1]))
    if output.which in ("potential", "total"):
        g += md.residual(X[-1])[0]
    return g


def dynamic_gradient(doc: dict | str, paths: list[str], options: DynamicOptions,
                     output: SensorOutput | EnergyOutput | MultiplierOutput) -> DynamicGradient:
    """Run the scene of `doc` with `options` (fixed steps of an alpha scheme) and return the output's value and
    its gradient with respect to every path by the discrete adjoint (see the module docstring)."""
    d = read_document(doc)
    if isinstance(output, SensorOutput):
        names = [s.get("name") if isinstance(s, dict) else s.name for s in options.sensors]
        if output.sensor not in names:
            raise KeyError(f"output sensor {output.sensor!r}: no such sensor in analysis.sensors (named: {names})")
    stages = None
    if options.integrator in COLLOCATION:  # (Radau IIA, Gauss: ancf_sym.sensitivity.collocation_run)
        run, stages, integ = collocation_run(d, paths, options)
    else:
        run = run_for_sensitivity(d, paths, options)
    S, asm, nf = run.S, run.asm, run.S.nf
    sensors = [SensorEval(Sensor.from_dict(sn, i), asm, i) for i, sn in enumerate(options.sensors)]
    Q, Vr, t = run.Q, run.V, run.t
    N = len(Q) - 1
    X, V, A = run.X, run.V_full, run.A_full
    WL = np.zeros((len(t), S.mc))
    if isinstance(output, MultiplierOutput):
        if not 0 <= output.row < S.mc:
            raise ValueError(f"output row {output.row}: the run has {S.mc} multiplier rows")
        if output.reduce not in REDUCTIONS:
            raise ValueError(f"output reduce {output.reduce!r}: one of {REDUCTIONS}")
        value, WL[:, output.row] = _reduction(output.reduce, run.Lam[:, output.row], t, output.data)
        WQ, WV = np.zeros((len(t), nf)), np.zeros((len(t), nf))
    else:
        value, WQ, WV = output_weights(output, sensors, S, t, X, V, Vr)
    if stages is not None:
        g = collocation_adjoint(run, stages, integ, list(paths), WQ, WV)
        grad = {p: float(g[k]) + energy_partial(output, asm, d, p, X, V) for k, p in enumerate(paths)}
        return DynamicGradient(value, grad, t, X, V, contact_notes(run) + step_notes(run))
    alpha_r = run.alpha_r
    # backward: steps N .. 1 in one compiled sweep, then the start (M a_0 = -R(q_0); the static start's adjoint)
    MU = np.zeros((N + 1, nf))
    acc = np.zeros(4 * nf)
    if N:
        f = backward_sweep(S, options, alpha_r, N, run.H is not None)
        cols = [Q[:0:-1], Vr[:0:-1], WQ[:0:-1], WV[:0:-1]] + \
            ([run.Lam[:0:-1], run.W[:0:-1]] if step_inputs(S) else []) + \
            ([Q[-2::-1]] if stiffness_damped(S) else []) + ([WL[:0:-1]] if S.mc else []) + \
            ([run.H[::-1, None]] if run.H is not None else [])  # (the accepted step sizes, held)
        U = np.ascontiguousarray(np.hstack(cols))  # (column j: step N - j)
        MUb = np.zeros((N, nf))
        _, evaluate = bind(f, [np.zeros(4 * nf), U], [acc, MUb])
        evaluate()
        MU[1:] = MUb[::-1]
    # the start (ancf_sym.sensitivity.static_start): a_0 = abar_0; lam_0: its weights; the static start's adjoint xi
    own = own_start(run)
    static = run.start is not None and run.start.static is not None and not own
    MU[0], xi = StartSystem(run, static).adjoint(acc[:nf] + WQ[0], acc[2 * nf:3 * nf] + acc[3 * nf:],
                                                 WL[0] if S.mc else None)
    Lam = S.full_v_rows(MU)
    LamR = Lam
    # a released or rotating static start (ancf_sym.sensitivity.start_derivative): the output's adjoint of q_0,
    # through a_0 and through a rotation's v_0 = L q_0, then the statics' adjoint
    start_grad = None
    if xi is not None:  # (dq_0/dp from the statics' dR/dp(x_0): its share of the gradient is -xi . dR_s/dp)
        LamR = Lam.copy()
        LamR[0] += S.full_v(xi)
    elif own:
        Kq, Kv = start_tangents(run)
        qb0 = acc[:nf] + WQ[0] - Kq.T @ MU[0]
        Lv = velocity_map(run.start, S)
        if Lv is not None:
            qb0 = qb0 + Lv.T @ (acc[nf:2 * nf] + WV[0] - Kv.T @ MU[0])
        start_grad = dict(zip(paths, static_start_gradient(run, list(paths), qb0)))
    grad, cache = {}, {}
    M = S.M
    for p in paths:
        if damping_index(d, p) is not None or dissipation_index(d, p) is not None:
            # (F_n = M v_n (Rayleigh alpha), d f_d / dc (strain rate, contact damping and friction))
            grad[p] = -float(np.sum(MU * forcing(run, p)))
            continue
        md = model_derivative(asm, d, p)
        g = -residual_sum(md, LamR, X, cache)
        if md.water is not None:  # (lines in water: the water's forces at every state; the static start's at rest)
            g -= float(np.sum(Lam * md.water.forcing(X, V, t, A)))
            if options.start == "static":
                g -= float((LamR[0] - Lam[0]) @ md.water.forcing(X[:1], None, None)[0])
        sd = stiffness_damping_forcing(run, p)  # (beta dK_el/dp (q_{n-1}) v_n)
        if sd is not None:
            g -= float(np.sum(MU * sd))
        fd = dissipation_forcing(run, p)  # (a contact's stiffness scales its friction force)
        if fd is not None:
            g -= float(np.sum(MU * fd))
        dM = md.dM
        if dM is not None:
            g -= float(np.sum(Lam * (dM @ (A + alpha_r * V).T).T))
        if isinstance(output, EnergyOutput):  # the output's own explicit dependence on p
            if dM is not None and output.which in ("kinetic", "total"):
                g += 0.5 * float(V[-1] @ (dM @ V[-1]))
            if output.which in ("potential", "total"):
                g += md.residual(X[-1])[0]
        grad[p] = g + (start_grad[p] if start_grad is not None else 0.0)
    return DynamicGradient(value, grad, t, X, V, contact_notes(run) + step_notes(run))
