"""Forward sensitivities of a dynamic run of the alpha schemes (Newmark / HHT / generalized-alpha), exact for the
discrete scheme.

The run is the package's own integrator (ancf_sym.dynamics.alpha, one step at a time through its protocol); after
each accepted step the sensitivity of its state follows from the step's equations in the Arnold-Bruels form
(ancf_sym.dynamics.schemes), differentiated with respect to p on the reduced coordinates:

    abar_{n+1} = (q_{n+1} - q_n - h v_n - h^2 (1/2 - beta) abar_n) / (h^2 beta)
    a_{n+1}    = ((1 - alpha_m) abar_{n+1} + alpha_m abar_n - alpha_f a_n) / (1 - alpha_f)
    v_{n+1}    = v_n + h (1 - gamma) abar_n + h gamma abar_{n+1}
    M a_{n+1} + R(q_{n+1}, p) = 0          (R: the potential's gradient less the dead loads)

so (cm M + K(q_{n+1})) S_{n+1} = -(M B_n + dM/dp a_{n+1} + dR/dp(q_{n+1})), cm = Scheme.cm(h), B_n the part of
d a_{n+1}/dp from the previous state: one sparse factorisation of the step's exact tangent per step serves every
parameter. The start: q_0 fixed (the reference) or the static equilibrium (its sensitivity), v_0 fixed, and the
consistent initial acceleration M a_0 = -R(q_0, p) differentiated. The derivative is that of the discrete
solution; the integrator's states differ from it by its Newton tolerance (newton.xtol, lte_fraction).

Rayleigh mass damping C = alpha_R M adds cc C to the tangent and C Bv + dC/dp v_{n+1} to the right-hand side
(Bv: the part of d v_{n+1}/dp from the previous state); dampings[i].alpha is a parameter. The run is the
integrator's compiled chunks with every state kept (ancf_sym.sensitivity.alpha_run); the recursion over the steps
is one CasADi mapaccum (the step's tangent from the system's compiled force graph, a sparse LDL^T solve with every
parameter's column as right-hand sides), the forcing dR/dp at every step one mapped kernel call per derivative
piece.

Strain-rate damping f_d(q, v) adds df/dq + cc df/dv to the tangent (sparse QR: unsymmetric) and df/dv Bv to the
right-hand side; dampings[i].axial | bending are parameters. Constraint rows with multipliers (rigid joints, bodies'
rows) and drives (rows with time-dependent coefficients): M a' + ... + J(q')' lam' = 0, Phi(q', t') = 0 give the KKT
solve [[J' + H(lam'), J(q')'], [J(q'), 0]] [S'; dlam'/dp] = -[rhs; 0] (H: the rows' curvature weighted by the
multipliers; no parameter enters a row), and the start's [M J'; J 0] [a_0; lam_0] differentiated alike.
Stiffness-proportional Rayleigh damping (C_n = alpha M + beta K_el(q_n)) adds cc C_n to the tangent and
C_n Bv + beta d(K_el(q) v_{n+1})/dq|_{q_n} S_n to the right-hand side (S_n: the previous state's sensitivity; the
kernels' compiled Hessian-vector companions). Scope (refused by name before any step,
ancf_sym.sensitivity.alpha_run): fixed steps (applied torques: their skew tangent in the step's matrix); a static
start with multiplier rows differentiates the equilibrium's KKT system (ancf_sym.sensitivity.static_start);
contact damping and friction enter as the strain-rate damping does (their tangents are in the same dissipation
force), their coefficients' forcing from ancf_sym.sensitivity.contact_dissipation; time loads (analysis.loads) are
applied as the run applies them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.run import make_integrator
from ancf_sym.dynamics.sensors import Sensor, SensorEval
from ancf_sym.system.step_system import StepSystem
from ancf_sym.scene.builder import Scene
from ancf_sym.sensitivity.alpha_run import contact_notes, dynamic_assembly, forcing, refuse_unsupported, \
    damping_matrices, run_for_sensitivity, step_inputs, step_matrix, stiffness_damped
from ancf_sym.sensitivity.collocation_run import COLLOCATION, collocation_sensitivity
from ancf_sym.sensitivity.run_start import velocity_map
from ancf_sym.sensitivity.sensor_jacobian import sensor_jacobian
from ancf_sym.sensitivity.static_start import StartSystem
from ancf_sym.sensitivity.step_sequence import step_notes
from ancf_sym.sensitivity.start_derivative import own_start, start_tangents, static_start_columns
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.util.sparsity import dm




@dataclass
class DynamicSensitivity:
    """t (steps + 1,) [s]; x, v (steps + 1, n): the full coordinates and velocities; dx[path], dv[path]: their
    derivatives per step."""
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    dx: dict
    dv: dict
    assembly: object
    sensors: list = field(default_factory=list)  # SensorEval of the options' sensors
    notes: list = field(default_factory=list)  # what the derivative does not cover (contact events)
    lam: np.ndarray | None = None  # (steps + 1, mc): the true multipliers of the constraint rows and drives
    dlam: dict = field(default_factory=dict)  # dlam[path]: their derivatives per step (the reactions')

    def sensor(self, path: str, name: str) -> np.ndarray:
        """d(sensor record)/dp per step, (steps + 1, k), for every sensor kind: dy = dy/dx dx + dy/dv dv with the
        record's exact Jacobians (ancf_sym.sensitivity.sensor_jacobian: the linear kinds map dx, dv as they map
        x, v; strain, curvature and the body sensors by the chain rule)."""
        ev = next((e for e in self.sensors if e.sensor.name == name), None)
        if ev is None:
            raise KeyError(f"sensor {name!r}: no such sensor; sensors: {[e.sensor.name for e in self.sensors]}")
        out = []
        for x, v, dx, dv in zip(self.x, self.v, self.dx[path], self.dv[path]):
            Jx, Jv = sensor_jacobian(ev, x, v)
            out.append(Jx @ dx + Jv @ dv)
        return np.array(out)

    def nodes(self, path: str, member: str) -> np.ndarray:
        """d(node positions)/dp of a member over time: (steps + 1, nodes, dim)."""
        asm = self.assembly
        mm = asm.mesh.members[member]
        d = self.dx[path][:, mm.offset:mm.offset + mm.x0.size].reshape(len(self.t), mm.n_nodes, mm.node_size)
        return d[:, mm.public_nodes, :asm.scene.dim]


def check_dynamic(scene: Scene, options: DynamicOptions) -> None:
    """Refuse, before any step, a run whose sensitivities this module cannot propagate (SceneError naming why)."""
    from ancf_sym.dynamics.newton import Counters

    S = StepSystem.for_scene(dynamic_assembly(scene))
    refuse_unsupported(S, options, make_integrator(S, options, Counters(), 0.0, options.newton.xtol * S.length_scale))


_SWEEPS: dict = {}


def forward_sweep(S: StepSystem, opts: DynamicOptions, alpha_r: float, n: int, P: int, variable: bool = False
                  ) -> ca.Function:
    """sweep(z0, X, V, F[, Y]) -> (Z[, L]): n steps of the sensitivity recursion (module docstring) for P parameters;
    z = [Sq; Sv; Sa; Sab] (4 nf x P), X, V (nf x n): q_{n+1}, v_{n+1} per step, F (nf x n P): the forcing per step,
    Y ((mc + nw) x n): the true multipliers and the drives' time inputs per step (only with constraint rows); Z (4 nf
    x n P): z after each step, L (mc x n P): d lam_{n+1}/dp; with Rayleigh beta one more input XP (nf x n): q_n;
    variable: the step sizes (1 x n) as the last input (the scheme's coefficients per step), else h = dt."""
    sch = opts.scheme()
    h = ca.MX.sym("h") if variable else opts.dt
    key = (S.graph_key, sch, None if variable else h, alpha_r, S.rayleigh.beta if S.rayleigh is not None else 0.0, n, P, S.par.tobytes())
    if key in _SWEEPS:
        return _SWEEPS[key]
    nf, mc = S.nf, S.mc
    am, af, beta, gamma = sch.alpha_m, sch.alpha_f, sch.beta, sch.gamma
    cm, cc = sch.cm(h), sch.cc(h)
    c1 = (1 - am) / (1 - af)
    M = dm(S.M)
    z, x, v, F = ca.MX.sym("z", 4 * nf, P), ca.MX.sym("x", nf), ca.MX.sym("v", nf), ca.MX.sym("F", nf, P)
    y = ca.MX.sym("y", step_inputs(S)) if step_inputs(S) else None
    xp = ca.MX.sym("xp", nf) if stiffness_damped(S) else None  # (q_n: where the run took K_el of the step)
    C, T = damping_matrices(S, alpha_r, xp, v)
    J, dfv, solver = step_matrix(S, cm, cc, C, x, v, y)
    Sq, Sv, Sa, Sab = (z[i * nf:(i + 1) * nf, :] for i in range(4))
    D = -(Sq + h * Sv + h * h * (0.5 - beta) * Sab) / (h * h * beta)
    B = c1 * D + (am * Sab - af * Sa) / (1 - af)
    Bv = Sv + h * (1 - gamma) * Sab + h * gamma * D
    rhs = ca.mtimes(M, B) + ca.mtimes(C, Bv) + F
    if T is not None:  # (beta K_el(q_n) v_{n+1}: its change with q_n)
        rhs = rhs + ca.mtimes(T, Sq)
    if dfv is not None:
        rhs = rhs + ca.mtimes(dfv, Bv)
    if mc:  # (the constraint rows: J dq' = 0, Phi reads no parameter)
        sol = ca.solve(J, -ca.vertcat(rhs, ca.MX(mc, P)), solver)
        Sq1, outs = sol[:nf, :], [cm * S.stiffness_scale() * sol[nf:, :]]  # (dlam = kc times the scaled part)
    else:
        Sq1, outs = ca.solve(J, -rhs, solver), []
    step = ca.Function("sensitivity_step", [z, x, v, F] + ([y] if y is not None else []) +
                       ([xp] if xp is not None else []) + ([h] if variable else []),
                       [ca.vertcat(Sq1, cc * Sq1 + Bv, cm * Sq1 + B, Sq1 / (h * h * beta) + D)] + outs)
    _SWEEPS[key] = f = step.mapaccum("sensitivity_sweep", n)
    return f


def dynamic_sensitivity(doc: dict | str, paths: list[str], options: DynamicOptions) -> DynamicSensitivity:
    """Run the scene of `doc` with `options` (an alpha scheme or collocation, fixed or adaptive steps) and propagate
    d(state)/dp for every path alongside (see the module docstring)."""
    paths = list(paths)
    if options.integrator in COLLOCATION:  # (Radau IIA, Gauss: ancf_sym.sensitivity.collocation_run)
        run, dq, dv = collocation_sensitivity(doc, paths, options)
        return answer(run, paths, dq, dv, np.zeros((len(dq), 0, len(paths))))
    run = run_for_sensitivity(doc, paths, options)
    S, asm, nf, P = run.S, run.asm, run.S.nf, len(paths)
    N = len(run.Q) - 1
    # start: the reference, or the equilibrium with its sensitivity (with its rows' multipliers); M a_0 = -R(q_0, p)
    # (with rows: [M J'; J 0] [a_0; lam_0]) differentiated (ancf_sym.sensitivity.static_start); a released or
    # rotating static start: dq_0, dv_0 = L dq_0 and the acceleration's K_q dq_0 + K_v dv_0
    # (ancf_sym.sensitivity.start_derivative)
    Fs = np.stack([forcing(run, p) for p in paths], axis=2) if P else np.zeros((N + 1, nf, 0))  # (N + 1, nf, P)
    own = own_start(run)
    static = run.start is not None and run.start.static is not None and not own
    F0s = np.column_stack([forcing(run, p, statics=True)[0] for p in paths]) if static and P else None
    Sv = np.zeros((nf, P))
    F0 = Fs[0]
    if own:
        Sq0 = static_start_columns(run, paths)
        Lv = velocity_map(run.start, S)
        Sv = Lv @ Sq0 if Lv is not None else Sv
        Kq, Kv = start_tangents(run)
        F0 = F0 + Kq @ Sq0 + (Kv @ Sv if Kv is not None else 0.0)
    Sq, Sa, dl0 = StartSystem(run, static).forward(F0s, F0)
    if own:
        Sq = Sq0
    z0 = np.vstack([Sq, Sv, Sa, Sa])
    dq, dv = np.zeros((N + 1, nf, P)), np.zeros((N + 1, nf, P))
    mc = S.mc
    dl = np.zeros((N + 1, mc, P))
    dq[0], dv[0] = Sq, Sv
    if mc:
        dl[0] = dl0
    if N and P:
        f = forward_sweep(S, options, run.alpha_r, N, P, run.H is not None)
        Z = np.zeros(4 * nf * P * N)
        L = np.zeros(mc * P * N)
        # (column-major inputs: X's column j is q_{j+1}; F's columns j P .. j P + P - 1 step j + 1's parameters)
        Fin = np.ascontiguousarray(Fs[1:].transpose(0, 2, 1)).ravel()
        ins = [np.ascontiguousarray(z0.T).ravel(), np.ascontiguousarray(run.Q[1:]).ravel(),
               np.ascontiguousarray(run.V[1:]).ravel(), Fin]
        if step_inputs(S):
            ins.append(np.ascontiguousarray(np.hstack([run.Lam[1:], run.W[1:]])).ravel())
        if stiffness_damped(S):
            ins.append(np.ascontiguousarray(run.Q[:-1]).ravel())
        if run.H is not None:  # (the accepted step sizes, held)
            ins.append(np.ascontiguousarray(run.H))
        _, evaluate = bind(f, ins, [Z] + ([L] if mc else []))
        evaluate()
        Zs = Z.reshape(N, P, 4 * nf)
        dq[1:] = Zs[:, :, :nf].transpose(0, 2, 1)
        dv[1:] = Zs[:, :, nf:2 * nf].transpose(0, 2, 1)
        dl[1:] = L.reshape(N, P, mc).transpose(0, 2, 1)
    return answer(run, paths, dq, dv, dl)


def answer(run, paths: list[str], dq: np.ndarray, dv: np.ndarray, dl: np.ndarray) -> DynamicSensitivity:
    """The DynamicSensitivity of a kept run (alpha_run.AlphaRun) from the reduced derivatives per step (steps + 1,
    nf | mc, P)."""
    S, asm, nf, P = run.S, run.asm, run.S.nf, len(paths)
    N = len(dq) - 1
    options = run.options

    def full(d: np.ndarray) -> np.ndarray:  # (E d per step and parameter, as one gather)
        rows = S.full_v_rows(d.transpose(0, 2, 1).reshape(-1, nf))
        return rows.reshape(N + 1, P, -1).transpose(0, 2, 1)
    dx, dvf = (full(dq), full(dv)) if P else (np.zeros((N + 1, asm.n, 0)), np.zeros((N + 1, asm.n, 0)))
    sensors = [SensorEval(Sensor.from_dict(sn, i), asm, i) for i, sn in enumerate(options.sensors)]
    return DynamicSensitivity(run.t, run.X, run.V_full, {p: dx[:, :, k] for k, p in enumerate(paths)},
                              {p: dvf[:, :, k] for k, p in enumerate(paths)}, asm, sensors,
                              contact_notes(run) + step_notes(run),
                              run.Lam, {p: dl[:, :, k] for k, p in enumerate(paths)})
