"""Levenberg-Marquardt on scaled parameters with an exact Jacobian, for any model of residuals r(p).

The parameters are scaled by their start values (theta = p / p0), so that J'J is well conditioned whatever their
units. A trial step (J'J + mu diag J'J) d = -J'r is accepted when it does not raise the sum of squares (mu / 3),
else mu x 4 and a new trial; a trial whose model fails (evaluate returns None) counts as rejected. It stops when the
Gauss-Newton correction still to come, or the step taken, is below `step_tol` of the estimate's standard deviation
(further steps cannot change the answer at the data's resolution), or after max_iter iterations.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ancf_sym.util.checks import SceneError


@dataclass
class Fit:
    p: np.ndarray  # the estimate
    state: Any  # evaluate's state at the estimate
    r: np.ndarray  # residuals there
    J: np.ndarray  # d r / d p there (unscaled)
    scale: np.ndarray  # the start values the parameters were scaled by
    iterations: int
    converged: bool
    status: str
    history: list = field(default_factory=list)  # (iteration, sum of squares, estimate)

    def statistics(self) -> tuple[float, np.ndarray]:
        """(noise sigma, covariance sigma^2 (J'J)^-1 of the estimate) of the linearised model, sigma^2 = r'r/(m-n)
        (inverted on the scaled parameters, where J'J is well conditioned)."""
        m, n = self.J.shape
        sigma2 = float(self.r @ self.r) / (m - n)
        Js = self.J * self.scale
        return float(np.sqrt(sigma2)), np.linalg.inv(Js.T @ Js) * sigma2 * np.outer(self.scale, self.scale)


def levenberg_marquardt(evaluate: Callable[[np.ndarray, Any], tuple[Any, np.ndarray] | None],
                        jacobian: Callable[[Any], np.ndarray], p0: np.ndarray, max_iter: int = 30,
                        step_tol: float = 1e-6, model: str = "the model") -> Fit:
    """Minimise |r(p)|^2. evaluate(p, state_before) -> (state, r) or None (the model failed at p); jacobian(state)
    -> d r / d p (m x n), called once at the start and once after each accepted step. The start must evaluate
    (SceneError otherwise, naming `model`: what evaluate solves)."""
    p0 = np.asarray(p0, float)
    cur = evaluate(p0, None)
    if cur is None:
        raise SceneError(f"calibrate: {model} at the start values failed")
    p, mu, history, status, converged, it = p0.copy(), 1e-3, [], "max_iter reached", False, 0
    m, n = len(cur[1]), len(p0)
    Jp = jacobian(cur[0])
    J = Jp * p0  # d r / d (p / p0)
    for it in range(1, max_iter + 1):
        state, r = cur
        JtJ, g = J.T @ J, J.T @ r
        cost = float(r @ r)
        history.append((it - 1, cost, p.copy()))
        sigma2 = cost / max(m - n, 1)
        std = np.sqrt(np.maximum(np.diag(np.linalg.inv(JtJ)) * sigma2, 0.0))
        tol = step_tol * np.maximum(std, 1e-15)
        if np.all(np.abs(np.linalg.solve(JtJ, -g)) <= tol):
            converged, status = True, "converged"
            break
        while True:
            step = np.linalg.solve(JtJ + mu * np.diag(np.diag(JtJ)), -g)
            trial = evaluate(p + step * p0, state)
            if trial is not None and float(trial[1] @ trial[1]) <= cost:
                break
            mu *= 4.0
            if mu > 1e12:
                status = "no step lowers the sum of squares"
                break
        if mu > 1e12:
            break
        p, cur, mu = p + step * p0, trial, max(mu / 3.0, 1e-9)
        Jp = jacobian(cur[0])
        J = Jp * p0
        if np.all(np.abs(step) <= tol):
            converged, status = True, "converged"
            break
    history.append((it, float(cur[1] @ cur[1]), p.copy()))
    return Fit(p, cur[0], cur[1], Jp, p0, it, converged, status, history)
