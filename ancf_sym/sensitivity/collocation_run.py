"""Forward sensitivities of a dynamic run of the collocation integrators (Radau IIA, Gauss-Legendre), exact for the
discrete scheme (ancf_sym.dynamics.collocation).

A step solves the condensed stage equations for the stage positions Q_1..Q_s; with W = A^-1 of the Butcher matrix
and w = W 1, the stage velocities and accelerations are V_j = (sum_m W_jm Q_m - w_j q_n) / h and A_j = (sum_m W_jm
V_m - w_j v_n) / h, and stage i reads

    R_i = M A_i + grad U(Q_i, p) + C V_i + f_d(Q_i, V_i, p) - F_i = 0          (C = alpha M)

then q_{n+1} = Q_s (Radau IIA, stiffly accurate) or q_n + h sum b_j V_j (Gauss), v_{n+1} = v_n + h sum b_j A_j.
Differentiated with respect to p: J_Z dQ = -(R_q dq_n + R_v dv_n + F_p), J_Z the stage system's exact tangent (the
integrator's own, ancf_sym.dynamics.collocation.stage_function), R_q = -(W w)_i / h^2 M - w_i / h (C + df_d/dv(Q_i,
V_i)), R_v = -w_i / h M per stage, F_p the parameters' forcing at the stage states (ancf_sym.sensitivity.alpha_run
.forcing: dR/dp(Q_i) + dM/dp (A_i + alpha V_i) + the dampings' d f_d/dp); the end values are linear in dQ, dq_n,
dv_n. The start's acceleration only guesses the first stages (no equation of the run holds it), so the start
enters through dq_0, dv_0 alone (ancf_sym.sensitivity.start_derivative). One sparse LU of J_Z per step serves every
parameter. Steps: fixed (a shorter last one as the run takes it) or the adaptive run's accepted steps held
(ancf_sym.sensitivity.step_sequence). Refused by name: constraint rows with multipliers, stiffness-proportional
Rayleigh damping (alpha_run.refuse_unsupported), the adjoint (forward only).
"""
from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.contact import laws as contact
from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.initial import released_scene
from ancf_sym.dynamics.newton import Counters
from ancf_sym.dynamics.run import make_integrator
from ancf_sym.dynamics.time_loads import LoadSum
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.model.assembly import Assembly
from ancf_sym.sensitivity.alpha_run import AlphaRun, check_dynamic_paths, dynamic_assembly, forcing, \
    refuse_unsupported
from ancf_sym.sensitivity.model_derivative import read_document
from ancf_sym.sensitivity.run_start import run_start, velocity_map
from ancf_sym.sensitivity.start_derivative import static_start_columns
from ancf_sym.sensitivity.step_sequence import adaptive_steps, held_steps
from ancf_sym.system.step_system import StepSystem

COLLOCATION = ("radau", "gauss")


def collocation_run(doc: dict | str, paths: list[str], options: DynamicOptions, steps: np.ndarray | None = None
                    ) -> tuple[AlphaRun, np.ndarray, object]:
    """(run, stages, integrator): the run kept for differentiation (step ends Q, V; A zero: the collocation state
    has no acceleration), the stage positions of each step (steps + 1, nf, s; row 0 unused) and the integrator;
    steps: step sizes [s] held as given (else fixed steps of dt, or the adaptive run's)."""
    d = read_document(doc)
    given, _ = scene_from_dict(d)
    scene = released_scene(given, options.release) if options.release else given
    asm = Assembly(scene) if options.release else dynamic_assembly(scene)
    check_dynamic_paths(scene, d, list(paths), asm)
    contact.check_dynamics(asm)
    S = StepSystem.for_scene(asm)
    integ = make_integrator(S, options, Counters(), 0.0, options.newton.xtol * S.length_scale)
    refuse_unsupported(S, options, integ)
    nf, s = S.nf, integ.tab.s
    start = run_start(given, asm, options)
    loads = LoadSum(options.loads, asm, S.E) if options.loads else None
    Q0 = loads(options.t_start) if loads else np.zeros(nf)
    integ.initialize(S.reduce(start.q0), S.reduce(start.v0), Q0, options.t_start)
    integ.tol_q = options.newton.tol * max(float(np.max(np.abs(S.f_lin))), float(np.max(np.abs(S.M @ integ.a))),
                                           float(np.max(np.abs(Q0))), 1e-300)

    def row() -> np.ndarray:  # (the step's end state and its stage positions, stage after stage)
        return np.r_[integ.q, integ.v, integ.N.x]
    if steps is not None:
        H = np.asarray(steps, float).ravel()
        rows = held_steps(integ, options.t_start, H, loads, row)
    elif options.adaptive:
        rows, H = adaptive_steps(S, integ, options, loads, row)
    else:
        last = options.t_end - (options.t_start + options.n_grid * options.dt)
        H = np.r_[np.full(options.n_grid, options.dt), [last] if last > 1e-9 * options.dt else []]
        rows = held_steps(integ, options.t_start, H, loads, row)
    R = np.array(rows)
    t = options.t_start + np.r_[0.0, np.cumsum(H)]
    stages = R[:, 2 * nf:].reshape(len(R), s, nf).transpose(0, 2, 1)
    run = AlphaRun(d, scene, asm, S, options, R[:, :nf], R[:, nf:2 * nf], np.zeros((len(R), nf)), t,
                   S.rayleigh.alpha if S.rayleigh is not None else 0.0, np.zeros((len(R), 0)),
                   np.zeros((len(R), 0)), start, H)
    return run, stages, integ


def collocation_sensitivity(doc: dict | str, paths: list[str], options: DynamicOptions,
                            steps: np.ndarray | None = None) -> tuple[AlphaRun, np.ndarray, np.ndarray]:
    """(run, dq, dv): the run and the derivatives of its step-end states (steps + 1, nf, P) on the reduced
    coordinates (module docstring); steps as collocation_run's."""
    paths = list(paths)
    run, stages, integ = collocation_run(doc, paths, options, steps)
    S, tab = run.S, integ.tab
    nf, s, P, N = S.nf, tab.s, len(paths), len(run.Q) - 1
    W = tab.W
    w = W.sum(axis=1)
    Ww = W @ w
    M = sp.csc_matrix(S.M)
    alpha = run.alpha_r
    dq, dv = np.zeros((N + 1, nf, P)), np.zeros((N + 1, nf, P))
    Sq = static_start_columns(run, paths)
    Lv = velocity_map(run.start, S)
    dq[0], dv[0] = Sq, (Lv @ Sq if Lv is not None else np.zeros((nf, P)))
    if not (N and P):
        return run, dq, dv
    # the stage states of every step (rows: step n + 1's stage j at n s + j) and the parameters' forcing there
    Qs = stages[1:].transpose(0, 2, 1).reshape(N * s, nf)
    qn, vn = np.repeat(run.Q[:-1], s, axis=0), np.repeat(run.V[:-1], s, axis=0)
    hs = np.repeat(run.H, s)[:, None]
    Wrep = np.tile(W, (N, 1))  # (row n s + j: W[j, :])
    Qb = stages[1:].transpose(0, 2, 1)  # (N, s, nf)
    Vs = (np.einsum("njm,nmk->njk", Wrep.reshape(N, s, s), Qb).reshape(N * s, nf) - w[np.tile(np.arange(s), N),
                                                                                       None] * qn) / hs
    As = (np.einsum("njm,nmk->njk", Wrep.reshape(N, s, s), Vs.reshape(N, s, nf)).reshape(N * s, nf) -
          w[np.tile(np.arange(s), N), None] * vn) / hs
    staged = replace(run, Q=Qs, V=Vs, A=As)
    Fp = np.stack([forcing(staged, p) for p in paths], axis=2).reshape(N, s, nf, P)
    spj = integ.fns["sparsity"]
    jac = integ.fns["jacobian"]
    kc = 1.0
    F = np.tile(S.f_lin[:, None], (1, s))
    for n in range(N):
        h = run.H[n]
        args = [stages[n + 1], ca.DM(0, s), run.Q[n], run.V[n], h, F, kc] + \
            ([S.kel] if S.kel is not None else [])
        nz = np.asarray(jac(*args)[2]).ravel()
        Jz = sp.csc_matrix((nz, spj.row(), spj.colind()), shape=(spj.size1(), spj.size2()))
        rhs = np.empty((s, nf, P))
        for i in range(s):
            Vi = Vs[n * s + i]
            Cv = alpha * M
            if S.damp_f is not None:
                Cv = Cv + S.damp_f(stages[n + 1][:, i], Vi)[2].sparse()
            rhs[i] = -(-(Ww[i] / h ** 2) * (M @ dq[n]) - (w[i] / h) * (Cv @ dq[n]) - (w[i] / h) * (M @ dv[n])
                       + Fp[n, i])
        dQ = spla.splu(Jz).solve(rhs.reshape(s * nf, P)).reshape(s, nf, P)
        dV = (np.einsum("jm,mkp->jkp", W, dQ) - w[:, None, None] * dq[n]) / h
        dA = (np.einsum("jm,mkp->jkp", W, dV) - w[:, None, None] * dv[n]) / h
        dq[n + 1] = dQ[-1] if tab.stiffly_accurate else dq[n] + h * np.einsum("j,jkp->kp", tab.b, dV)
        dv[n + 1] = dv[n] + h * np.einsum("j,jkp->kp", tab.b, dA)
    return run, dq, dv
