"""The condensed collocation equations in their one home (ancf_sym.dynamics.collocation), shared by the collocation
integrator, the optimal-control transcription and its warm start.

Collocation with s stages is exact on polynomials of degree <= s: the stage velocities V = (Q - q_n) W^T / h are the
derivatives of the polynomial through q_n and the stage positions, the accelerations likewise from v_n and V, and the
end point's quadrature (order >= s) integrates V and a exactly. So on a random polynomial trajectory of degree s
every relation holds to round-off of an s x s inverse with entries O(1): the tolerances are 1e-9 relative."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import scipy.sparse as sp

from ancf_sym.dynamics.collocation import interval_end, lagrange_basis, stage_rates, stage_residual, stage_tangent, tableau

CASES = [("radau", 1), ("radau", 2), ("radau", 3), ("gauss", 1), ("gauss", 2), ("gauss", 3)]


def polynomial(s: int, n: int, seed: int):
    """Coefficients (degree s, n components) and q, q', q'' as functions of t."""
    C = np.random.default_rng(seed).normal(size=(s + 1, n))
    P = np.polynomial.polynomial
    return (lambda t: P.polyval(t, C), lambda t: P.polyval(t, P.polyder(C)),
            lambda t: P.polyval(t, P.polyder(C, 2)))


@pytest.mark.parametrize("kind,s", CASES)
def test_stage_rates_and_end_are_exact_on_polynomials(kind, s):
    tab = tableau(kind, s)
    n, h, K = 3, 0.37, 4
    q, dq, ddq = polynomial(s, n, seed=s)
    t0 = 0.2 + h * np.arange(K)  # K intervals at once (the transcription's form)
    Q = np.column_stack([q(tk + tab.c * h) for tk in t0])  # n x K s, interval after interval
    V, A = stage_rates(tab, Q, q(t0), dq(t0), h)
    scale = np.max(np.abs(Q))
    ts = (t0[:, None] + tab.c[None, :] * h).ravel()
    np.testing.assert_allclose(V, dq(ts), atol=1e-9 * scale / h)
    np.testing.assert_allclose(A, ddq(ts), atol=1e-9 * scale / h**2)
    q_end, v_end = interval_end(tab, h, q(t0), dq(t0), Q, V, A)
    np.testing.assert_allclose(q_end, q(t0 + h), atol=1e-9 * scale)
    np.testing.assert_allclose(v_end, dq(t0 + h), atol=1e-9 * scale / h)
    # the interval's polynomial through q_n and the stages, at any local time (extrapolation included)
    tau = np.array([0.3, 1.0, 1.5])
    np.testing.assert_allclose(tab.extrapolate(q(t0[0]), Q[:, :s], tau), q(t0[0] + tau * h), atol=1e-9 * scale)
    np.testing.assert_allclose(lagrange_basis(np.r_[0.0, tab.c], tau).sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("kind,s", [("radau", 3), ("gauss", 2)])
def test_casadi_and_numpy_forms_and_the_tangent_agree(kind, s):
    """One code path for both: the CasADi expression (integrator, transcription) gives the NumPy values (warm
    start), and stage_tangent is the exact derivative of stage_residual for linear forces K q (+ D v)."""
    tab = tableau(kind, s)
    n, h = 4, 0.05
    rng = np.random.default_rng(7)
    M = sp.csc_matrix(np.diag(rng.uniform(1, 2, n)))
    Kq = rng.normal(size=(n, n))
    D = rng.normal(size=(n, n))
    qn, vn, Q = rng.normal(size=n), rng.normal(size=n), rng.normal(size=(n, s))
    R_np = stage_residual(tab, h, M, Q, qn, vn, lambda V: Kq @ Q + D @ V)[0]
    Qs = ca.MX.sym("Q", n, s)
    R_mx = stage_residual(tab, h, M, Qs, ca.DM(qn), ca.DM(vn),
                          lambda V: ca.mtimes(ca.DM(Kq), Qs) + ca.mtimes(ca.DM(D), V))[0]
    f = ca.Function("f", [Qs], [ca.vec(R_mx), ca.jacobian(ca.vec(R_mx), ca.vec(Qs))])
    R_ca, J_ca = (np.asarray(x) for x in f(Q))
    np.testing.assert_allclose(R_ca.ravel(), R_np.ravel(order="F"), rtol=1e-12, atol=1e-9 * np.abs(R_np).max())
    J = sp.bmat(stage_tangent(tab, h, M, [sp.csc_matrix(Kq)] * s, [sp.csc_matrix(D)] * s)).toarray()
    np.testing.assert_allclose(J, J_ca, rtol=1e-12, atol=1e-9 * np.abs(J).max())
