"""The start of a differentiated dynamic run: the sensitivity of its state (q_0, a_0 and the multipliers lam_0) and
the adjoint of it, for the reference start, the static equilibrium at rest, and that equilibrium held by constraint
rows with multipliers (rigid joints, bodies' rows).

On the reduced coordinates, with J = dPhi/dq(q_0), H(l) = d2(l . Phi)/dq2 (the rows' curvature; nil for linear
rows) and K_0 the potential's Hessian at q_0:

    static start:   [K_0 + H(lam_s)  J'] [dq_0 ]   [-dR_s/dp]      (the implicit function theorem at the
                    [J               0 ] [dmu  ] = [    0    ]       equilibrium: R(q_0) + J' lam_s = 0, Phi = 0)
    acceleration:   [M  J'] [da_0   ]   [-(K_0 + H(lam_0)) dq_0 - F_0]   (M a_0 + R + J' lam_0 = Q, J a_0 = 0 at
                    [J  0 ] [dlam_0 ] = [-d(J(q) a_0)/dq dq_0        ]    v_0 = 0, differentiated)

dR_s/dp: the statics' parameter derivative E' dR/dp(x_0); F_0 the dynamics' forcing at the start (with dM/dp a_0).
Without time loads at the start a_0 = 0 and lam_0 = lam_s: then da_0 = 0 and dlam_0 = dmu, the equilibrium's
reactions differentiated. The adjoint transposes both systems (K_0 is unsymmetric for lines in a current).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.sensitivity.alpha_run import AlphaRun, start_tangent

_CURVATURE: dict = {}


def _curvature_function(S) -> ca.Function:
    """(x, l, a, w) -> (d2(l . Phi)/dx2, d(J(x) a)/dx) of the system's constraint rows on the reduced coordinates."""
    key = S.graph_key
    if key not in _CURVATURE:
        x, lam, a = ca.MX.sym("x", S.nf), ca.MX.sym("l", S.mc), ca.MX.sym("a", S.nf)
        w = ca.MX.sym("w", S.nw)
        phi = S.constraint_mx(x, w if S.nw else None)
        H = ca.hessian(ca.dot(lam, phi), x)[0]
        Ja = ca.jacobian(ca.jtimes(phi, x, a), x)
        _CURVATURE[key] = ca.Function("row_curvature", [x, lam, a, w], [H, Ja])
    return _CURVATURE[key]


def _rows(run: AlphaRun, lam: np.ndarray, a: np.ndarray) -> tuple[sp.csc_matrix, sp.csc_matrix]:
    """(H(lam), d(J(q) a)/dq) at the start."""
    S = run.S
    H, Ja = _curvature_function(S)(run.Q[0], lam, a, run.W[0])
    return sp.csc_matrix(H.sparse()), sp.csc_matrix(Ja.sparse())


class StartSystem:
    """The start's two symmetric systems (module docstring), factorised once."""

    def __init__(self, run: AlphaRun, static: bool | None = None):
        S = self.S = run.S
        # (static: q_0 is the run's static equilibrium, differentiated here; default the options' start)
        self.static = run.options.start == "static" if static is None else static
        self.K0 = start_tangent(run)
        self.nf, self.mc = S.nf, S.mc
        self.a0, self.lam0 = run.A[0], run.Lam[0]
        if not self.mc:
            self._mass = spla.splu(S.M.tocsc())
            if self.static:
                self._static = spla.splu(self.K0)
            return
        J = S.jac_phi(run.Q[0], run.t[0])
        self._mass = spla.splu(sp.bmat([[S.M, J.T], [J, None]], format="csc"))
        self.H0, self.Ja0 = _rows(run, self.lam0, self.a0)
        if self.static:
            # (the equilibrium's own multipliers: J' lam_s = -R(q_0), from the mass system with the static residual,
            # whose acceleration part is nil at an equilibrium; lam_0 differs from lam_s by time loads at the start)
            R = S.forces(run.Q[0])[0] - S.f_lin
            lam_s = self._mass.solve(np.r_[-R, np.zeros(self.mc)])[self.nf:]
            Hs = _rows(run, lam_s, self.a0)[0]
            self._static = spla.splu(sp.bmat([[self.K0 + Hs, J.T], [J, None]], format="csc"))

    def _pad(self, b: np.ndarray) -> np.ndarray:
        return np.concatenate([b, np.zeros((self.mc,) + b.shape[1:])]) if self.mc else b

    def forward(self, Fs: np.ndarray | None, F0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dq_0, da_0, dlam_0) for the columns of Fs (the statics' dR/dp at q_0, None for a reference start) and F0
        (the forcing at the start), (nf, P) each."""
        nf = self.nf
        P = F0.shape[1]
        if not P:
            return np.zeros((nf, 0)), np.zeros((nf, 0)), np.zeros((self.mc, 0))
        dq = np.zeros((nf, P)) if Fs is None else -self._static.solve(self._pad(Fs))[:nf]
        r = -(self.K0 @ dq + F0)
        if not self.mc:
            return dq, self._mass.solve(r), np.zeros((0, P))
        r = r - self.H0 @ dq
        z = self._mass.solve(np.concatenate([r, -(self.Ja0 @ dq)]))
        return dq, z[:nf], z[nf:]

    def adjoint(self, qbar: np.ndarray, abar: np.ndarray, wl: np.ndarray | None) -> tuple[np.ndarray,
                                                                                             np.ndarray | None]:
        """(mu_0, xi) for the adjoints flowing into q_0, a_0 and lam_0 (wl; None without rows): the output's
        derivative is -mu_0 . F_0 - xi . dR_s/dp (xi None for a reference start)."""
        nf = self.nf
        z = self._mass.solve(np.r_[abar, wl] if self.mc else abar)
        mu = z[:nf]
        if not self.static:
            return mu, None
        # (transposed: K_0 is unsymmetric for lines in a current, the drag's load stiffness at rest)
        qb = qbar - self.K0.T @ mu
        if self.mc:
            qb = qb - self.H0 @ mu - self.Ja0.T @ z[nf:]
        return mu, self._static.solve(self._pad(qb), trans="T")[:nf]
