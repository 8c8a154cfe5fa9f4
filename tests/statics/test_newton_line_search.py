"""Full Newton's line search on a saturating residual, the regularised Coulomb law's shape r(x) = x / sqrt(x^2 + 1)
- c (root x* = c / sqrt(1 - c^2)). From x0 = 2 the full Newton update overshoots to x1 = x0 - r(x0) (1 + x0^2)^1.5
= -4.6, where |r| is larger (the tangent (1 + x^2)^-1.5 is small once |x| > 1: Newton maps x to about -x^3 for
c = 0); the line search must back off and converge to the root. Tolerance 1e-9 on a residual of order 1: Newton
converges quadratically once inside the region, so the last update is far below it.
"""
from __future__ import annotations

import numpy as np

from ancf_sym.dynamics.newton import Counters, Factor, NewtonOptions, newton

C = 0.3


def r(x: float) -> float:
    return x / np.sqrt(x * x + 1) - C


class Saturating:
    """The buffer interface of a step system for one unknown, no constraint."""
    nf, mc = 1, 0

    def __init__(self, x0: float):
        self.x, self.lam, self.dz, self.r = np.array([x0]), np.zeros(0), np.zeros(1), np.zeros(1)
        self.norms, self.floor = np.zeros(5), 0.0

    def residual(self):
        self.r[0] = r(self.x[0])
        self.norms[0], self.norms[1] = abs(self.r[0]), 0.0
        return self.r

    def iterate(self):
        self.residual()
        J = (1 + self.x[0] ** 2) ** -1.5
        self.dz[0] = -self.r[0] / J
        self.norms[2], self.norms[3], self.norms[4] = abs(self.dz[0]), 0.0, J
        return self.dz


def test_full_update_overshoots_from_this_start():
    s = Saturating(2.0)
    s.iterate()
    assert abs(r(2.0 + s.dz[0])) > abs(r(2.0))  # the plain iteration leaves the region: a line search is needed


def test_line_search_converges_on_saturating_residual():
    s = Saturating(2.0)
    out = newton(s, Factor(), None, NewtonOptions(max_iter=40, line_search=True), Counters(), tol_q=1e-9, tol_x=1e-12)
    assert out.converged, out.reason
    assert abs(s.x[0] - C / np.sqrt(1 - C * C)) < 1e-8
