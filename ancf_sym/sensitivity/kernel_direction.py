"""The derivative of a kernel's outputs along a direction of its parameters (and state), from its compiled companion.

Where a scene number enters a kernel's parameter rows P nonlinearly (a beam's Poisson ratio and b x h, a drum's
radius and centre, the ground's level, a contact's thickness), dU/dp is no kernel evaluation at other parameters:
it is the kernel's forward derivative along dP = dP/dp, d/dP [U, grad U, H] . dP, which the companion
<name>_dp (q, p, dq, dp) -> (de, dg, dH) gives exactly (CasADi AD of the kernel's own symbolic graph, compiled:
registry.PARAMETER_DIRECTION_EFFECTS). With dp = 0 and dq a state change it gives the Hessian's change along dq
(the third derivatives of a curved kernel without an _hvp companion, for the modal prestress change).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ancf_sym import kernels

_MAPS: dict = {}


def _mapped(element: str, effect: str, gauss: int | None, N: int) -> ca.Function:
    key = (element, effect, gauss, N)
    if key not in _MAPS:
        _MAPS[key] = kernels.load_direction(element, effect, gauss).map(N)
    return _MAPS[key]


def direction_outputs(element: str, effect: str, gauss: int | None, Q: np.ndarray, P: np.ndarray, dQ: np.ndarray,
                      dP: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(de (N,), dg (N, nd), dH (N, nd, nd)) of N element calls: states Q (N, nd), parameters P (N, np), along
    (dQ, dP)."""
    N, nd = Q.shape
    e, g, H = (o.full() for o in _mapped(element, effect, gauss, N)(Q.T, np.asarray(P, float).T, dQ.T,
                                                                      np.asarray(dP, float).T))
    return e.ravel(), g.T, H.reshape(nd, N, nd).transpose(1, 0, 2)


def state_direction_hessians(element: str, effect: str, gauss: int | None, idx: np.ndarray, P: np.ndarray,
                             x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """d H / dq . dx per element (N, nd, nd) at the state x (the parameters held)."""
    return direction_outputs(element, effect, gauss, x[idx], P, dx[idx], np.zeros_like(np.asarray(P, float)))[2]


@dataclass
class DirectionPiece:
    """The derivative of one term's kernels on elements idx whose parameter rows P change by dP per unit of the
    scene parameter: the same interface as model_derivative.Piece (grad, hessian), from the companion."""
    element: str
    effect: str
    gauss: int | None
    idx: np.ndarray  # (N, nd)
    P: np.ndarray  # (N, np): the rows at the parameter's value
    dP: np.ndarray  # (N, np): their derivative
    label: str = ""

    def _outputs(self, x: np.ndarray):
        Q = x[self.idx]
        return direction_outputs(self.element, self.effect, self.gauss, Q, self.P, np.zeros_like(Q), self.dP)

    def grad(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(d energy/dp summed over the elements, d gradient/dp per element (N, nd))."""
        e, g, _ = self._outputs(x)
        return float(e.sum()), g

    def hessian(self, x: np.ndarray) -> np.ndarray:
        """d Hessian/dp per element (N, nd, nd)."""
        return self._outputs(x)[2]

    def gradients(self, X: np.ndarray) -> np.ndarray:
        """d gradient/dp assembled on the full coordinates at every state (rows of X): (len(X), n), one mapped call."""
        k, n = X.shape
        N, nd = self.idx.shape
        Q = X[:, self.idx].reshape(k * N, nd)
        P, dP = np.tile(np.asarray(self.P, float), (k, 1)), np.tile(np.asarray(self.dP, float), (k, 1))
        g = direction_outputs(self.element, self.effect, self.gauss, Q, P, np.zeros_like(Q), dP)[1]
        out = np.zeros((k, n))
        g = g.reshape(k, N * nd)
        cols = self.idx.ravel()
        for r in range(k):
            out[r] = np.bincount(cols, g[r], minlength=n)
        return out
