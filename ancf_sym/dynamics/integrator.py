"""What the time loop asks of an integrator (the Integrator protocol), the outcome of a step, and the consistent
initial acceleration every integrator starts from."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.util import setup_cache
from ancf_sym.util.casadi_buffers import bind
from ancf_sym.system.damping import timed
from ancf_sym.system.step_system import StepSystem


@dataclass
class StepOutcome:
    converged: bool
    iterations: int
    reason: str = ""
    fast: bool = False  # converged within the compiled step graph


class Integrator(Protocol):
    """A one-step method on a StepSystem's unknowns, as the time loop (ancf_sym.dynamics.time_loop) drives it.

    q, v, a, lam: the accepted state (a: acceleration, for the residual's force scale; lam: true multipliers);
    `new` holds the candidate of the last successful `attempt` ("q", "v"), committed by `accept`. tol_q: the force
    tolerance [N], set by the run once the force scale is known. order: of the local error estimate (step-size
    control exponent 1/(order + 1)). `chunkable` true: the integrator is a ChunkedIntegrator too, and the loop runs
    stretches of fixed steps through it."""
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    new: dict
    tol_q: float
    order: int

    def initialize(self, q0: np.ndarray, v0: np.ndarray, Q0: np.ndarray, t0: float = 0.0) -> None: ...

    def attempt(self, t: float, h: float, loads: Callable[[float], np.ndarray] | None = None) -> StepOutcome: ...

    def error_estimate(self, h: float) -> np.ndarray: ...

    def accept(self) -> None: ...

    @property
    def chunkable(self) -> bool: ...


class ChunkedIntegrator(Integrator, Protocol):
    """An integrator that also runs many fixed steps in one call."""

    def prepare_chunks(self, n: int) -> None:
        """Build what a chunk of n steps needs (set-up, before the timed loop)."""

    def run_chunk(self, h: float, ploads: np.ndarray) -> tuple[np.ndarray, int]:
        """Up to n = ploads.shape[1] steps of size h (ploads: per step, minus the constant and time-dependent
        generalized forces). Returns the states after the accepted steps (q in [:nf], v in [nf:2 nf] of each
        row) and their number n_ok: the steps before the first one the chunk could not accept (left to
        `attempt`); the integrator's state is advanced to the last of them."""


def initial_acceleration(S: StepSystem, q0: np.ndarray, v0: np.ndarray, Q0: np.ndarray,
                         C: sp.spmatrix | None = None, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Consistent initial acceleration and multipliers: [M J^T; J 0][a; lam] = [f - C v - g; -gamma] (gamma:
    StepSystem.phi_vv; drives and torques at time t0)."""
    # (the gradient output of the force graph the system built, evaluated in place: no conversion to and from DM,
    # at 1000 elements 0.1-0.3 ms against 0.9 ms for a call on numpy arrays; the gradient-only graph would be
    # built for this call alone. Its kernels' gradients are the companions' own.)
    g = np.zeros(S.nf)
    buf, evaluate = bind(S.gradient_source, [np.ascontiguousarray(q0, dtype=float), S.par], [g])  # (buf: alive)
    evaluate()
    f = S.f_lin + Q0 - g
    if S.drives is not None:
        f = f + S.reduce_force(S.drives.torque_force(S.full(q0), S.w(t0)))
    if C is not None:
        f = f - C @ v0
    if S.damp_f is not None:  # (lines in water under waves: the water's forces at t0)
        f = f - np.asarray(S.damp_f(*((q0, v0, t0) if timed(S) else (q0, v0)))[0]).ravel()
    if not S.nf:
        return np.zeros(0), np.zeros(S.mc)
    if S.mc:
        J = S.jac_phi(q0, t0)
        A = sp.bmat([[S.M, J.T], [J, None]], format="csc")
        z = spla.spsolve(A, np.r_[f, -S.phi_vv(v0, q0, t0)])
        return z[:S.nf], z[S.nf:]
    return mass_factor(S.M).solve(f), np.zeros(0)


def mass_factor(M: sp.spmatrix) -> spla.SuperLU:
    """The sparse LU of the reduced mass matrix, kept with it when M comes from ancf_sym.util.setup_cache (a second run of
    the same structure solves for its initial acceleration without factorising again: ~0.2 ms of a ~1.2 ms set-up
    on 32 elements)."""
    key = setup_cache.key_of(M)
    factor = lambda: spla.splu(sp.csc_matrix(M))
    return factor() if key is None else setup_cache.cached("mass_factor", key, factor)

