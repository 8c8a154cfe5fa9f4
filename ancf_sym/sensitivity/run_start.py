"""The start of a dynamic run kept for differentiation, as ancf_sym.dynamics.run.simulate builds it, and its
derivative with respect to the scene's parameters.

The start (q_0, v_0) is the reference or given coordinates `q0`, the static equilibrium (`start = "static"`; with
`release`, the equilibrium of the scene with the released supports, the run's scene without them), or a result.json
of an earlier run (`from_result`, its coordinates and velocities); the velocities are zero, given (`v0`, or read
from the result) or set per member by `initial` tables (a uniform velocity, or a rigid rotation omega x (r - c) that
reads the start's coordinates). What depends on the parameters: q_0 only through the static equilibrium (dq_0/dp its
statics sensitivity, ancf_sym.sensitivity.static, on the held scene with release), v_0 only through a rotation of
that equilibrium (dv_0/dp = omega x dr_0: the linear part of the rotation, applied to dq_0); given coordinates and
velocities and a read result depend on none. The initial acceleration always does: the run solves

    M a_0 + R(q_0, p) + C(q_0, p) v_0 + f_d(q_0, v_0, p) [+ J' lam_0] = Q(t_0)        (C = alpha M + beta K_el(q_0))

so M da_0 = -(K_q dq_0 + K_v dv_0 + F_0), K_q = K(q_0) + beta d(K_el(q) v_0)/dq + df_d/dq, K_v = C_0 + df_d/dv,
F_0 the parameters' forcing at the start (ancf_sym.sensitivity.alpha_run.forcing, row 0): that derivative is
ancf_sym.sensitivity.start_derivative's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics import initial as initial_state
from ancf_sym.scene.builder import SceneError
from ancf_sym.statics.problem import problem_for
from ancf_sym.system.step_system import StepSystem


@dataclass
class RunStart:
    """The run's start: the run's scene (without the released supports), the scene whose statics starts the run
    (held: with release; else the given one), full q0 and v0, the static result (start = "static" and not overridden by
    a result.json: q0 then depends on the parameters), and the [[initial]] rotations (omega tables) whose velocities
    read q0."""
    scene: object
    held: object
    q0: np.ndarray
    v0: np.ndarray
    static: object | None
    rotations: list
    released: bool  # (supports of the static start released for the run)


def run_start(scene, asm, opts: DynamicOptions, static_result=None) -> RunStart:
    """The start as simulate builds it (asm: the run's assembly, of the released scene with `release`; scene: the
    scene as given, whose statics starts the run; static_result: its static equilibrium, solved here if None)."""
    q0 = asm.x0.copy() if opts.q0 is None else np.asarray(opts.q0, dtype=float).ravel()
    static = None
    if opts.start == "static":
        if static_result is None:
            static_result = problem_for(scene).solve()
        if not static_result.success:
            raise SceneError(f"dynamic sensitivities: the static start failed ({static_result.status})")
        static, q0 = static_result, np.asarray(static_result.x, float).copy()
    v0 = np.zeros(asm.n) if opts.v0 is None else np.asarray(opts.v0, dtype=float).ravel()
    if opts.from_result is not None:
        q0, v_read = initial_state.read_result(opts.from_result, asm.n)
        static = None  # (the coordinates read: no parameter changes them)
        if v_read is not None:
            v0 = v_read
    if opts.initial:
        v0 = initial_state.from_specs(asm, q0, opts.initial)
    for name, arr in (("q0", q0), ("v0", v0)):
        if arr.shape != (asm.n,) or not np.all(np.isfinite(arr)):
            raise SceneError(f"{name} must be {asm.n} finite numbers (the scene's coordinates), got {arr.size}")
    rotations = [s for s in (opts.initial or []) if "omega" in s]
    return RunStart(asm.scene, scene, q0, v0, static, rotations, bool(opts.release))


def velocity_of_coordinates(start: RunStart, asm, dq: np.ndarray) -> np.ndarray:
    """dv_0 (full) for a change dq (full) of the start's coordinates: the rotations' omega x dr (their centres are
    fixed points; a uniform velocity does not read the coordinates)."""
    if not start.rotations:
        return np.zeros(asm.n)
    d = asm.scene.dim
    lin = [{"member": s["member"], "omega": s["omega"], "centre": [0.0] * d} for s in start.rotations]
    return initial_state.from_specs(asm, dq, lin)


def velocity_map(start: RunStart, S: StepSystem) -> sp.csr_matrix | None:
    """L with dv_0 = L dq_0 on the reduced coordinates (None: v_0 reads no coordinate that a parameter moves)."""
    if start.static is None or not start.rotations:
        return None
    cols = [S.reduce(velocity_of_coordinates(start, S.asm, S.full_v(e))) for e in np.eye(S.nf)]
    return sp.csr_matrix(np.column_stack(cols)) if cols else None
