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

Scope: fixed steps; no damping, time-dependent loads, drives or multiplier rows (rigid joints, bodies' joints):
refused by name before any step.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.run import make_integrator
from ancf_sym.dynamics.sensors import Sensor, SensorEval
from ancf_sym.system.step_system import StepSystem
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity.model_derivative import check_model_paths, model_derivative, read_document


LINEAR_SENSORS = ("position", "displacement", "velocity", "coordinates", "strain")  # (strain: by the chain rule)


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

    def sensor(self, path: str, name: str) -> np.ndarray:
        """d(sensor record)/dp per step, (steps + 1, k): the sensor's kinds that are linear in the state
        (position, displacement, velocity, coordinates) map dx, dv as they map x, v; strain |r_x| - 1 by the
        chain rule (r_x . dr_x / |r_x|). Curvature and body sensors: not differentiated here."""
        ev = next((e for e in self.sensors if e.sensor.name == name), None)
        if ev is None:
            raise KeyError(f"sensor {name!r}: no such sensor; sensors: {[e.sensor.name for e in self.sensors]}")
        kind = ev.sensor.kind
        dx, dv = self.dx[path], self.dv[path]
        if kind in ("position", "displacement"):
            return np.array([ev.probe.r(d) for d in dx])
        if kind == "velocity":
            return np.array([ev.probe.r(d) for d in dv])
        if kind == "coordinates":
            return dx[:, ev.dofs]
        if kind == "strain":
            out = []
            for x, d in zip(self.x, dx):
                rx = ev.probe.rx(x)
                out.append([float(rx @ ev.probe.rx(d)) / float(np.linalg.norm(rx))])
            return np.array(out)
        raise ValueError(f"sensor {name!r}: a {kind} sensor is not differentiated here (kinds: {LINEAR_SENSORS})")

    def nodes(self, path: str, member: str) -> np.ndarray:
        """d(node positions)/dp of a member over time: (steps + 1, nodes, dim)."""
        asm = self.assembly
        mm = asm.mesh.members[member]
        d = self.dx[path][:, mm.offset:mm.offset + mm.x0.size].reshape(len(self.t), mm.n_nodes, mm.node_size)
        return d[:, mm.public_nodes, :asm.scene.dim]


def _check(S: StepSystem, opts: DynamicOptions, integ) -> None:
    why = []
    if opts.integrator not in ("newmark", "hht", "generalized_alpha"):
        why.append(f"integrator {opts.integrator!r} (alpha schemes only)")
    if opts.adaptive:
        why.append("adaptive steps")
    if S.mc:
        why.append("constraint rows with multipliers (rigid joints, bodies' joints)")
    if S.damped or S.damp_f is not None or integ.kdamp.active:
        why.append("damping")
    if opts.loads or S.drives is not None:
        why.append("time-dependent loads or drives")
    if opts.release or opts.from_result or opts.initial or opts.q0 is not None or opts.v0 is not None:
        why.append("a start other than the reference or the static equilibrium at rest")
    if why:
        raise SceneError("dynamic sensitivities: not available with " + ", ".join(why))


def check_dynamic(scene: Scene, options: DynamicOptions) -> None:
    """Refuse, before any step, a run whose sensitivities this module cannot propagate (SceneError naming why)."""
    from ancf_sym.dynamics.newton import Counters
    from ancf_sym.statics.problem import problem_for

    S = StepSystem.for_scene(problem_for(scene).asm)
    _check(S, options, make_integrator(S, options, Counters(), 0.0, options.newton.xtol * S.length_scale))


def dynamic_sensitivity(doc: dict | str, paths: list[str], options: DynamicOptions) -> DynamicSensitivity:
    """Run the scene of `doc` with `options` (fixed steps of an alpha scheme) and propagate d(state)/dp for every
    path alongside (see the module docstring)."""
    from ancf_sym.dynamics.newton import Counters
    from ancf_sym.statics.problem import problem_for

    d = read_document(doc)
    scene, _ = scene_from_dict(d)
    paths = list(paths)
    check_model_paths(scene, d, paths)
    asm = problem_for(scene).asm
    S = StepSystem.for_scene(asm)
    L = S.length_scale
    integ = make_integrator(S, options, Counters(), 0.0, options.newton.xtol * L)
    _check(S, options, integ)
    E = S.E.tocsc()
    EtE = (E.T @ E).tocsc()
    P = len(paths)
    derivs = [model_derivative(asm, d, p) for p in paths]
    # start: the reference, or the equilibrium with its sensitivity
    if options.start == "static":
        res = problem_for(scene).solve()
        if not res.success:
            raise SceneError(f"dynamic sensitivities: the static start failed ({res.status})")
        q0 = res.x
        from ancf_sym.sensitivity.static import StaticSensitivity
        st = StaticSensitivity(scene, res, d)
        dq0 = np.column_stack([st.dx(p) for p in paths]) if P else np.zeros((asm.n, 0))
    else:
        q0, dq0 = asm.x0.copy(), np.zeros((asm.n, P))
    Sq = spla.spsolve(EtE, E.T @ dq0).reshape(-1, P) if P else np.zeros((S.nf, 0))
    integ.initialize(S.reduce(q0), np.zeros(S.nf), np.zeros(S.nf), options.t_start)
    integ.tol_q = options.newton.tol * max(float(np.max(np.abs(S.f_lin))), float(np.max(np.abs(S.M @ integ.a))),
                                           1e-300)
    M = S.M.tocsc()
    sch = options.scheme()
    am, af, beta, gamma = sch.alpha_m, sch.alpha_f, sch.beta, sch.gamma
    dM = [E.T @ md.dM @ E if md.dM is not None else None for md in derivs]

    def step_matrix(q: np.ndarray, cm: float) -> sp.csc_matrix:
        """cm M + K(q) on the reduced coordinates: the step system's own compiled tangent (a copy: the system
        writes it in place)."""
        S.x[:] = q
        S.p[:] = -S.f_lin
        S.cm[:], S.cc[:], S.kc[:] = cm, 0.0, 1.0
        return S.jacobian().copy()

    fixed: dict = {}

    def forcing(x_full: np.ndarray, a: np.ndarray) -> np.ndarray:
        """dR/dp + dM/dp a per parameter (nf, P)."""
        F = np.zeros((S.nf, P))
        for k, md in enumerate(derivs):
            if md.constant_residual:  # (loads, gravity: evaluated once)
                if k not in fixed:
                    fixed[k] = E.T @ md.residual(x_full)[1]
                F[:, k] = fixed[k]
            else:
                F[:, k] = E.T @ md.residual(x_full)[1]
            if dM[k] is not None:
                F[:, k] += dM[k] @ a
        return F

    x = S.full(integ.q)
    F, K = forcing(x, integ.a), step_matrix(integ.q, 0.0)
    lu_M = spla.splu(M)
    Sa = -lu_M.solve(K @ Sq + F) if P else np.zeros((S.nf, 0))
    Sab, Sv = Sa.copy(), np.zeros_like(Sq)
    h = options.dt
    n_steps = int(round((options.t_end - options.t_start) / h))
    ts, xs, vs, dxs, dvs = [options.t_start], [x], [S.full_v(integ.v)], [E @ Sq], [E @ Sv]
    cm = sch.cm(h)
    t = options.t_start
    for _ in range(n_steps):
        out = integ.attempt(t, h)
        if not out.converged:
            raise SceneError(f"dynamic sensitivities: the step at t = {t:.6g} s did not converge ({out.reason})")
        integ.accept()
        t += h
        x = S.full(integ.q)
        F = forcing(x, integ.a)
        # d a_{n+1} = cm dq_{n+1} + B (B from the previous state)
        B = (1 - am) / (1 - af) * (-(Sq + h * Sv + h * h * (0.5 - beta) * Sab) / (h * h * beta)) + \
            (am * Sab - af * Sa) / (1 - af)
        Sq_new = spla.splu(step_matrix(integ.q, cm)).solve(-(M @ B + F)) if P else Sq
        Sab_new = (Sq_new - Sq - h * Sv - h * h * (0.5 - beta) * Sab) / (h * h * beta)
        Sa_new = ((1 - am) * Sab_new + am * Sab - af * Sa) / (1 - af)
        Sv = Sv + h * (1 - gamma) * Sab + h * gamma * Sab_new
        Sq, Sab, Sa = Sq_new, Sab_new, Sa_new
        ts.append(t)
        xs.append(x)
        vs.append(S.full_v(integ.v))
        dxs.append(E @ Sq)
        dvs.append(E @ Sv)
    dx, dv = np.stack(dxs), np.stack(dvs)  # (steps + 1, n, P)
    sensors = [SensorEval(Sensor.from_dict(sn, i), asm, i) for i, sn in enumerate(options.sensors)]
    return DynamicSensitivity(np.array(ts), np.stack(xs), np.stack(vs), {p: dx[:, :, k] for k, p in enumerate(paths)},
                              {p: dv[:, :, k] for k, p in enumerate(paths)}, asm, sensors)
