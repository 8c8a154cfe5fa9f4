"""The Newmark / HHT / generalized-alpha family of time-step formulas, in the form of Arnold & Bruels (2007) that
Exudyn also uses: the equations hold at t_{n+1} exactly and an algorithmic acceleration abar carries the alpha
weighting,

    (1 - alpha_m) abar_{n+1} + alpha_m abar_n = (1 - alpha_f) a_{n+1} + alpha_f a_n
    q_{n+1} = q_n + h v_n + h^2 (1/2 - beta) abar_n + h^2 beta abar_{n+1}
    v_{n+1} = v_n + h (1 - gamma) abar_n + h gamma abar_{n+1}.

Newmark is alpha_m = alpha_f = 0; HHT(alpha) is alpha_m = 0, alpha_f = -alpha, beta = (1 - alpha)^2 / 4,
gamma = 1/2 - alpha (for linear systems identical to the classical HHT of paper 002; for nonlinear ones the forces
are evaluated at t_{n+1} instead of averaged); generalized-alpha(rho_inf) is alpha_m = (2 rho - 1)/(rho + 1),
alpha_f = rho/(rho + 1), gamma = 1/2 + alpha_f - alpha_m, beta = (gamma + 1/2)^2 / 4.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ancf_sym.util.checks import fail


@dataclass(frozen=True)
class Scheme:
    """Coefficients of the generalized-alpha family (Arnold-Bruels form)."""
    name: str
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def newmark(cls, beta: float = 0.25, gamma: float = 0.5) -> "Scheme":
        if not (0 < beta <= 0.5 and 0 < gamma <= 1):
            raise fail("analysis.beta", "and gamma must lie in (0, 1/2] x (0, 1]", (beta, gamma))
        return cls("newmark", 0.0, 0.0, float(beta), float(gamma))

    @classmethod
    def hht(cls, alpha: float = -0.05) -> "Scheme":
        a = float(alpha)
        if not (math.isfinite(a) and -1.0 / 3.0 - 1e-12 <= a <= 0.0):
            raise fail("analysis.alpha", "must lie in [-1/3, 0] (HHT)", alpha)
        return cls("hht", 0.0, -a, (1 - a) ** 2 / 4, 0.5 - a)

    @classmethod
    def generalized_alpha(cls, rho_inf: float = 0.9) -> "Scheme":
        r = float(rho_inf)
        if not (math.isfinite(r) and 0.0 <= r <= 1.0):
            raise fail("analysis.rho_inf", "must lie in [0, 1]", rho_inf)
        am, af = (2 * r - 1) / (r + 1), r / (r + 1)
        g = 0.5 + af - am
        return cls("generalized_alpha", am, af, 0.25 * (g + 0.5) ** 2, g)

    def cm(self, h: float) -> float:
        """d(M a_{n+1}) / d q_{n+1} = cm M."""
        return (1 - self.alpha_m) / ((1 - self.alpha_f) * self.beta * h * h)

    def cc(self, h: float) -> float:
        """d v_{n+1} / d q_{n+1} = cc I."""
        return self.gamma / (self.beta * h)

    def error_constant(self) -> float:
        """Local displacement error ~ |beta - 1/6| h^2 |a_{n+1} - a_n| (Zienkiewicz & Xie)."""
        return abs(self.beta - 1.0 / 6.0)

