"""Forward sensitivities and the discrete adjoint of a dynamic run of the collocation integrators (Radau IIA,
Gauss-Legendre), exact for the discrete scheme (ancf_sym.dynamics.collocation).

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
(ancf_sym.sensitivity.step_sequence). The adjoint (collocation_adjoint) runs the transposed recursion backward:
one transposed solve with J_Z per step, the parameters' terms -sum mu . F_p over the stages. Refused by name:
constraint rows with multipliers, stiffness-proportional Rayleigh damping (alpha_run.refuse_unsupported).
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
from ancf_sym.sensitivity.start_derivative import static_start_columns, static_start_gradient
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
    dq, dv = np.zeros((N + 1, nf, P)), np.zeros((N + 1, nf, P))
    Sq = static_start_columns(run, paths)
    Lv = velocity_map(run.start, S)
    dq[0], dv[0] = Sq, (Lv @ Sq if Lv is not None else np.zeros((nf, P)))
    if not (N and P):
        return run, dq, dv
    Vs, Fp = stage_forcing(run, stages, tab, paths)
    for n in range(N):
        h = run.H[n]
        lu, Cv = step_pieces(run, stages, integ, Vs, n)
        rhs = np.empty((s, nf, P))
        for i in range(s):
            rhs[i] = (Ww[i] / h ** 2) * (M @ dq[n]) + (w[i] / h) * (Cv[i] @ dq[n]) + (w[i] / h) * (M @ dv[n]) \
                - Fp[n, i]
        dQ = lu.solve(rhs.reshape(s * nf, P)).reshape(s, nf, P)
        dV = (np.einsum("jm,mkp->jkp", W, dQ) - w[:, None, None] * dq[n]) / h
        dA = (np.einsum("jm,mkp->jkp", W, dV) - w[:, None, None] * dv[n]) / h
        dq[n + 1] = dQ[-1] if tab.stiffly_accurate else dq[n] + h * np.einsum("j,jkp->kp", tab.b, dV)
        dv[n + 1] = dv[n] + h * np.einsum("j,jkp->kp", tab.b, dA)
    return run, dq, dv


def stage_forcing(run: AlphaRun, stages: np.ndarray, tab, paths: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(V, F_p): the stage velocities of every step (rows n s + j: step n + 1's stage j) and the parameters'
    forcing at the stage states (steps, s, nf, P)."""
    S = run.S
    nf, s, N, P = S.nf, tab.s, len(run.Q) - 1, len(paths)
    W, w = tab.W, tab.W.sum(axis=1)
    Qb = stages[1:].transpose(0, 2, 1)  # (N, s, nf)
    hs = run.H[:, None, None]
    Vb = (np.einsum("jm,nmk->njk", W, Qb) - w[None, :, None] * run.Q[:-1, None, :]) / hs
    Ab = (np.einsum("jm,nmk->njk", W, Vb) - w[None, :, None] * run.V[:-1, None, :]) / hs
    staged = replace(run, Q=Qb.reshape(N * s, nf), V=Vb.reshape(N * s, nf), A=Ab.reshape(N * s, nf))
    Fp = np.stack([forcing(staged, p) for p in paths], axis=2).reshape(N, s, nf, P) if P else \
        np.zeros((N, s, nf, 0))
    return Vb.reshape(N * s, nf), Fp


def step_pieces(run: AlphaRun, stages: np.ndarray, integ, Vs: np.ndarray, n: int) -> tuple:
    """(LU of the stage tangent J_Z, [C + df_d/dv at each stage]) of step n + 1 (the integrator's own tangent)."""
    S, s = run.S, integ.tab.s
    spj = integ.fns["sparsity"]
    F = np.tile(S.f_lin[:, None], (1, s))  # (the forces enter R, not its tangent)
    args = [stages[n + 1], ca.DM(0, s), run.Q[n], run.V[n], run.H[n], F, 1.0] + \
        ([S.kel] if S.kel is not None else [])
    nz = np.asarray(integ.fns["jacobian"](*args)[2]).ravel()
    Jz = sp.csc_matrix((nz, spj.row(), spj.colind()), shape=(spj.size1(), spj.size2()))
    Cv = []
    for i in range(s):
        C = run.alpha_r * sp.csc_matrix(S.M)
        if S.damp_f is not None:
            C = C + S.damp_f(stages[n + 1][:, i], Vs[n * s + i])[2].sparse()
        Cv.append(C)
    return spla.splu(Jz), Cv


def collocation_adjoint(run: AlphaRun, stages: np.ndarray, integ, paths: list[str], WQ: np.ndarray,
                        WV: np.ndarray) -> np.ndarray:
    """d output / dp (P,) for an output with d/dq_n = WQ[n], d/dv_n = WV[n] (reduced, rows n = 0..N): the
    transpose of collocation_sensitivity's recursion, backward over the steps (one transposed solve with J_Z per
    step), then the start's (a static start's statics adjoint, a rotation's dv_0 = L dq_0)."""
    S, tab = run.S, integ.tab
    nf, s, P, N = S.nf, tab.s, len(paths), len(run.Q) - 1
    W, b = tab.W, tab.b
    w = W.sum(axis=1)
    Ww, bW, bW2, bWw, bw = W @ w, b @ W, b @ W @ W, b @ W @ w, b @ w
    M = sp.csc_matrix(S.M)
    Vs, Fp = stage_forcing(run, stages, tab, paths)
    grad = np.zeros(P)
    gq, gv = WQ[N].copy(), WV[N].copy()
    for n in range(N - 1, -1, -1):
        h = run.H[n]
        lu, Cv = step_pieces(run, stages, integ, Vs, n)
        # (q_{n+1}, v_{n+1}) from dQ, dq_n, dv_n (collocation_sensitivity), transposed
        gQ = np.outer(bW2 / h, gv)
        if tab.stiffly_accurate:
            gQ[-1] += gq
            gq_n = -(bWw / h) * gv
        else:
            gQ += np.outer(bW, gq)
            gq_n = (1 - bw) * gq - (bWw / h) * gv
        gv_n = (1 - bw) * gv
        mu = lu.solve(gQ.ravel(), trans="T").reshape(s, nf)  # (J_Z' mu = gQ)
        for i in range(s):
            gq_n = gq_n + (Ww[i] / h ** 2) * (M.T @ mu[i]) + (w[i] / h) * (Cv[i].T @ mu[i])
            gv_n = gv_n + (w[i] / h) * (M.T @ mu[i])
        grad -= np.einsum("ik,ikp->p", mu, Fp[n])
        gq, gv = gq_n + WQ[n], gv_n + WV[n]
    Lv = velocity_map(run.start, S)
    g0 = gq + (Lv.T @ gv if Lv is not None else 0.0)
    return grad + static_start_gradient(run, paths, g0)
