"""The derivative of a dynamic run's start (ancf_sym.sensitivity.run_start) with respect to the scene's parameters:
dq_0/dp of a static start (the statics sensitivity; with released supports, the held scene's), dv_0/dp of a rotation
of it, and the initial acceleration's M da_0 = -(K_q dq_0 + K_v dv_0 + F_0), with the adjoint of each."""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.sensitivity.alpha_run import damping_index, damping_matrices, damping_tangents, forcing, start_tangent
from ancf_sym.sensitivity.contact_dissipation import dissipation_index
from ancf_sym.sensitivity.run_start import velocity_map
from ancf_sym.sensitivity.static import StaticSensitivity


def damping_path(doc: dict, path: str) -> bool:
    """A damping or contact-dissipation coefficient: it changes no equilibrium."""
    return damping_index(doc, path) is not None or dissipation_index(doc, path) is not None


_TANGENTS: dict = {}


def start_tangents(run) -> tuple[sp.csc_matrix, sp.csc_matrix | None]:
    """(K_q, K_v) of the initial acceleration's equation at (q_0, v_0) on the reduced coordinates (module
    docstring); K_v None where v_0 = 0 and no parameter moves it (then K_q = K(q_0): the damping forces and their
    q-derivatives vanish at rest)."""
    S = run.S
    q0, v0 = run.Q[0], run.V[0]
    moving = np.any(v0 != 0.0) or (run.start is not None and velocity_map(run.start, S) is not None)
    if not moving:
        return start_tangent(run), None
    K0 = sp.csc_matrix(S.forces(q0)[1])
    key = (S.graph_key, run.alpha_r, S.par.tobytes())
    if key not in _TANGENTS:
        x, v = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
        C, T = damping_matrices(S, run.alpha_r, x, v)
        dfx, dfv = damping_tangents(S, x, v)
        Kq = T if T is not None else ca.MX(S.nf, S.nf)
        Kv = C
        if dfx is not None:
            Kq, Kv = Kq + dfx, Kv + dfv
        _TANGENTS[key] = ca.Function("start_tangents", [x, v], [ca.densify(Kq), ca.densify(Kv)])
    Kq, Kv = _TANGENTS[key](q0, v0)
    return sp.csc_matrix(K0 + np.asarray(Kq)), sp.csc_matrix(np.asarray(Kv))


def own_start(run) -> bool:
    """The start is a static equilibrium whose derivative this module gives beyond the run's own static start: its
    supports released for the run, or a rotation of it (v_0 reads q_0)."""
    st = run.start
    return st is not None and st.static is not None and (st.released or velocity_map(st, run.S) is not None)


def static_start_columns(run, paths: list[str]) -> np.ndarray:
    """dq_0/dp (nf, P) on the run's reduced coordinates: zero unless the start is the static equilibrium; without
    release the statics on the run's coordinates, -K(q_0)^-1 E' dR/dp(x_0); with release the held scene's static
    sensitivity (its supports in place), its full dx/dp read on the run's unknowns. Damping and contact-dissipation
    paths change no equilibrium."""
    S = run.S
    out = np.zeros((S.nf, len(paths)))
    st = run.start
    if st is None or st.static is None or not paths:
        return out
    model = [k for k, p in enumerate(paths) if not damping_path(run.doc, p)]
    if not model:
        return out
    if not st.released:
        K0 = sp.csc_matrix(S.forces(run.Q[0])[1])
        F = np.column_stack([forcing(run, paths[k], statics=True)[0] for k in model])
        out[:, model] = -spla.splu(K0).solve(F)
        return out
    sens = held_sensitivity(run)
    for k in model:
        out[:, k] = S.reduce(sens.dx(paths[k]))
    return out


def held_sensitivity(run):
    """The static sensitivity of the held scene's equilibrium that starts a run with released supports."""
    st = run.start
    return StaticSensitivity(st.held, st.static, run.doc, what="dynamic sensitivities (the static start)")


def static_start_gradient(run, paths: list[str], g_q: np.ndarray) -> np.ndarray:
    """sum g_q . dq_0/dp per path (P,): the adjoint of static_start_columns (g_q: d output / dq_0 on the run's
    reduced coordinates, every path through the start's coordinates)."""
    S = run.S
    out = np.zeros(len(paths))
    st = run.start
    if st is None or st.static is None:
        return out
    model = [k for k, p in enumerate(paths) if not damping_path(run.doc, p)]
    if not st.released:
        K0 = sp.csc_matrix(S.forces(run.Q[0])[1])
        xi = spla.splu(K0).solve(g_q)  # (K symmetric)
        for k in model:
            out[k] = -float(xi @ forcing(run, paths[k], statics=True)[0])
        return out
    dJdx = np.zeros(S.asm.n)
    dJdx[S.part.roots] = g_q  # (q_0 = x_0[roots]: the run's unknowns read from the held equilibrium)
    if model:
        out[model] = held_sensitivity(run).gradient(dJdx, [paths[k] for k in model])
    return out
