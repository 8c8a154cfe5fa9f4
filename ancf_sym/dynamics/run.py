"""A dynamic run from a scene and options: checks of the initial state, the step system, the integrator, the time
loop, the result."""
from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from ancf_sym.contact import laws as contact
from ancf_sym.dynamics import initial as initial_state
from ancf_sym.model.assembly import Assembly
from ancf_sym.model.mesh import check_stretch
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.dynamics.alpha import AlphaIntegrator
from ancf_sym.dynamics.collocation import CollocationIntegrator
from ancf_sym.dynamics.diagnosis import compressed_strings
from ancf_sym.dynamics.integrator import Integrator
from ancf_sym.dynamics.newton import Counters, resolve_kinks
from ancf_sym.dynamics.options import DynamicOptions, options_from_dict
from ancf_sym.dynamics.recording import DEFAULT_OUTPUTS, Recorder, output_grid
from ancf_sym.dynamics.result import DynamicResult
from ancf_sym.dynamics.sensors import SensorEval
from ancf_sym.system.step_system import StepSystem
from ancf_sym.dynamics.time_loads import LoadSum
from ancf_sym.dynamics.time_loop import TimeLoop, chunk_size
from ancf_sym.dynamics.reach import FreeChunks


def _velocity_form(cons, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """J(q) v of constraints A x + sum coef x_i x_j - d, without assembling J (a sparse matrix per run)."""
    return cons.A @ v + np.bincount(cons.qrow, cons.qcoef * (q[cons.qj] * v[cons.qi] + q[cons.qi] * v[cons.qj]),
                                    minlength=cons.m)


def _position_source(opts: DynamicOptions) -> str:
    """The field that gave the initial coordinates, as the user wrote it."""
    if opts.from_result is not None:
        return "analysis.from_result (its coordinates)"
    if opts.start == "static":
        return "analysis.start = 'static' (the static equilibrium)"
    return "q0" if opts.q0 is not None else "the reference state (the members as given)"


def _velocity_source(asm: Assembly, opts: DynamicOptions, coords: np.ndarray) -> str:
    """The field that gave the initial velocity of these coordinates: `analysis.initial[i]` (naming its member or
    body) when [[analysis.initial]] tables gave it, else `v0` (the Python API's full vector)."""
    if not opts.initial:
        return "analysis.from_result (its velocities)" if opts.from_result is not None else "v0"
    owners = {name for name, mm in asm.mesh.members.items()
              if np.any((coords >= mm.offset) & (coords < mm.offset + mm.x0.size))}
    owners |= {name for name, o in asm.mesh.bodies.items()
               if np.any((coords >= o) & (coords < o + len(asm.scene.bodies[name].q0)))}
    for i, spec in enumerate(opts.initial):
        if spec["member"] in owners:
            return f"analysis.initial[{i}] (member {spec['member']!r})"
    return "analysis.initial"


def make_integrator(system: StepSystem, opts: DynamicOptions, counters: Counters, tol_q: float,
                    tol_x: float) -> Integrator:
    """The integrator the options name: an alpha scheme or collocation (Radau IIA, Gauss-Legendre)."""
    # a linear-law contact's tangent jumps where a point touches down: the automatic line search for such scenes
    newton = resolve_kinks(opts.newton, any(getattr(c, "stiffness", 0.0) > 0 for c in system.asm.scene.contacts))
    if opts.integrator in ("radau", "gauss"):
        stages = opts.stages or (3 if opts.integrator == "radau" else 2)
        return CollocationIntegrator(system, opts.integrator, stages, newton, tol_q, tol_x, counters)
    return AlphaIntegrator(system, opts.scheme(), newton, tol_q, tol_x, counters)


def simulate(scene: Scene | Assembly, options: DynamicOptions, progress: Callable[[float, float], Any] | None = None,
             system: StepSystem | None = None) -> DynamicResult:
    """Integrate a scene from options.t_start to options.t_end (see ancf_sym.dynamics)."""
    opts = options
    held = None  # with release: the scene whose statics starts the run (the run's scene lacks those supports)
    if opts.release:
        if system is not None:
            raise SceneError("analysis.release: give the scene (not a prepared step system) to release supports")
        held = scene.scene if isinstance(scene, Assembly) else scene
        scene = initial_state.released_scene(held, opts.release)
    asm = scene if isinstance(scene, Assembly) else Assembly(scene)
    scene = asm.scene
    if not scene.members and not scene.bodies:
        raise SceneError("scene has no members or bodies")
    contact.check_dynamics(asm)
    from ancf_sym.system.water import check_integrator

    check_integrator(scene, opts.integrator)  # (lines in water: the collocation schemes take a constant mass)
    if getattr(scene, "drives", None) and opts.integrator in ("radau", "gauss"):
        raise SceneError(f"integrator={opts.integrator!r}: drives and torques (time-dependent constraints and "
                         "forces) run with the alpha schemes (newmark, hht, generalized_alpha), not collocation")
    sensors = [SensorEval(s, asm, i) for i, s in enumerate(opts.sensors)]
    # initial state
    q0 = asm.x0.copy() if opts.q0 is None else np.asarray(opts.q0, dtype=float).ravel()
    if opts.start == "static":
        q0 = initial_state.static_start(held or scene)
    v0 = np.zeros(asm.n) if opts.v0 is None else np.asarray(opts.v0, dtype=float).ravel()
    if opts.from_result is not None:
        q0, v_read = initial_state.read_result(opts.from_result, asm.n)
        if v_read is not None:
            v0 = v_read
    if opts.initial:
        v0 = initial_state.from_specs(asm, q0, opts.initial)
    for name, arr in (("q0", q0), ("v0", v0)):
        if arr.shape != (asm.n,):
            raise SceneError(f"{name} must have {asm.n} entries (the scene's coordinates), got {arr.size}")
        if not np.all(np.isfinite(arr)):
            raise SceneError(f"{name} must be finite")
    if opts.q0 is not None or opts.from_result is not None:
        check_stretch(asm.mesh, q0, "q0" if opts.from_result is None else "analysis.from_result")
    if system is None:
        if getattr(scene, "water", None) is not None:
            asm.added_mass_state = q0  # (lines in water: the added mass's tangents frozen at the start state)
        system = StepSystem.for_scene(asm, linsol="auto_lu")  # (time steps: sparse LU where QR would serve)
    S = system
    loads = LoadSum(opts.loads, asm, S.E) if opts.loads else None
    L = S.length_scale
    tol_x = opts.newton.xtol * L
    cons_tol = max(1e-8 * L, 10 * tol_x)
    if asm.exact.m:
        viol = np.abs(asm.exact.value(q0))
        if viol.max() > cons_tol:
            k = int(np.argmax(viol))
            raise SceneError(f"{_position_source(opts)} violates constraint {asm.exact.labels[k]!r} by "
                             f"{viol[k]:.3g} m (tolerance {cons_tol:.3g} m)")
        vv = np.abs(_velocity_form(asm.exact, q0, v0))
        if vv.max() > 1e-8 * max(1.0, float(np.abs(v0).max())):
            k = int(np.argmax(vv))
            what = f"violates the velocity form of constraint {asm.exact.labels[k]!r} by {vv[k]:.3g}"
            raise SceneError(f"{_velocity_source(asm, opts, asm.exact.jacobian(q0).getrow(k).indices)}: {what}"
                             " (give a velocity the supports and joints allow, e.g. a rotation about a pin)")
    check_drives_at_start(S, asm, q0, v0, opts, cons_tol)
    outputs = output_grid(opts)
    every = opts.output_every
    if every is None and outputs is None:  # default: about DEFAULT_OUTPUTS intervals
        if opts.adaptive:
            n_out = DEFAULT_OUTPUTS
            outputs = opts.t_start + (opts.t_end - opts.t_start) * np.arange(n_out + 1) / n_out
        else:
            every = max(1, int(round((opts.t_end - opts.t_start) / opts.dt / DEFAULT_OUTPUTS)))
    dt_min = opts.dt_min or opts.dt * 2.0 ** -12
    dt_max = opts.dt_max or (opts.dt * 100 if opts.adaptive else opts.dt)
    err_tol = opts.tol or 1e-6 * L

    t_setup = time.perf_counter()
    counters = Counters()
    integ = make_integrator(S, opts, counters, 0.0, tol_x)
    if integ.chunkable and not opts.adaptive and chunk_size(opts.n_grid):
        integ.prepare_chunks(chunk_size(opts.n_grid))  # compiled-call set-up, like the step graph itself
    # contact scenes: chunks on the contact-free graph while no element is in reach (ancf_sym.dynamics.reach)
    free = FreeChunks.build(S, integ, opts) if integ.chunkable and chunk_size(opts.n_grid) else None
    if free is not None:
        free.prepare(chunk_size(opts.n_grid))
    setup = time.perf_counter() - t_setup
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    qf, vf = S.reduce(q0), S.reduce(v0)
    Q0 = loads(opts.t_start) if loads else np.zeros(S.nf)
    integ.initialize(qf, vf, Q0, opts.t_start)
    # force scale of the residual tolerance: constant loads (gravity, dead loads), inertia at t0, time loads
    fscale = max(float(np.max(np.abs(S.f_lin))), float(np.max(np.abs(S.M @ integ.a))),
                 float(np.max(np.abs(Q0)))) if S.nf else 0.0
    integ.tol_q = opts.newton.tol * max(fscale, 1e-300)

    rec = Recorder(S, sensors, opts.energies, opts.record_states)
    rec.E0 = rec.energy(integ.q, integ.v)[2] if opts.energies else None
    run = TimeLoop(S, integ, opts, loads, rec, outputs, every, progress, dt_min, dt_max, err_tol)
    run.free = free
    run.go()
    # (the loop's time includes its outputs: the sensors and violations of chunked records are made here)
    sens = {name: np.array(vals) for name, vals in rec.data.items()}
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    t, status, message, steps, rejected = run.t, run.status, run.message, run.steps, run.rejected
    h_used = [run.h_min, run.h_max] if steps else []
    if status in ("newton_failed", "step_size_underflow", "energy_blowup"):
        why = compressed_strings(asm, S.full(integ.q))
        message = f"{message}; {why}" if why and message else (why or message)
    ener = {k: np.array(v) for k, v in rec.energies.items()}
    res = DynamicResult(status, status == "completed", message, opts.integrator, np.array(rec.t), sens, ener,
                        np.array(rec.viol), float(t), steps, rejected, counters.as_dict(), wall,
                        S.full(integ.q), S.full_v(integ.v), opts, asm,
                        float(min(h_used)) if h_used else float("nan"), float(max(h_used)) if h_used else float("nan"),
                        setup, cpu, {k: np.array(v) for k, v in rec.reactions.items()})
    res.states = rec.states
    if run.gaps is not None:  # penalty contact: the smallest true gaps over every accepted step
        res.contact_gaps = run.gaps.record()
    if free is not None:
        res.steps_out_of_reach = free.steps
    return res


def check_drives_at_start(S: StepSystem, asm: Assembly, q0: np.ndarray, v0: np.ndarray, opts: DynamicOptions,
                          cons_tol: float) -> None:
    """Refuse (SceneError, before any step) a start state that the drives do not allow at t_start: the position
    off a drive's value by more than cons_tol [m], or the velocity off its rate (a drive that starts moving with a
    velocity jump while the start is at rest). The run and the dynamic sensitivities both check here."""
    drv = S.drives
    if drv is None or not drv.m:
        return
    w0 = drv.w(opts.t_start)
    viol = np.abs(drv.value(q0, w0))
    vv = np.abs(drv.jacobian(q0, w0) @ v0 + drv.time_terms(q0, v0, opts.t_start)[0])
    for what, arr, tol in (("q0", viol, cons_tol), ("v0 (velocity form)", vv, 1e-8 * max(1.0, float(np.abs(v0).max())))):
        if arr.max() > tol:
            k = int(np.argmax(arr))
            if what == "q0":
                what = _position_source(opts)
            elif opts.initial or opts.from_result is not None:
                what = f"{_velocity_source(asm, opts, drv.jacobian(q0, w0).getrow(k).indices)} (velocity form)"
            raise SceneError(f"{what} violates drive {drv.labels[k]!r} at t_start = {opts.t_start:g} s by "
                             f"{arr[k]:.3g} (start the body or node where and as fast as the drive prescribes, "
                             "e.g. a motion that starts from rest)")


def run_dynamics(scene: Scene | Assembly, analysis: dict | DynamicOptions,
                 progress: Callable[[float, float], Any] | None = None) -> DynamicResult:
    """Run a dynamic analysis: `analysis` is the [analysis] table (type "dynamics") or DynamicOptions.

    progress(t, t_end) is called at every output time. Bad input raises SceneError before any step."""
    opts = analysis if isinstance(analysis, DynamicOptions) else options_from_dict(analysis)
    return simulate(scene, opts, progress)
