"""Gauss-Legendre rules on [0, 1]: points and weights summing to 1."""
from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np


def _legendre(n: int, x: Decimal) -> tuple[Decimal, Decimal]:
    """P_n(x) and P_n'(x) by the three-term recurrence."""
    p0, p1 = Decimal(1), x
    for k in range(2, n + 1):
        p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
    if n == 0:
        return p0, Decimal(0)
    return p1, n * (x * p1 - p0) / (x * x - 1)


def gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss-Legendre rule on [0, 1]; exact for polynomials of degree 2n-1.

    numpy's leggauss nodes differ in the last bit between numpy versions (eigenvalue solvers), and these numbers
    are written into the generated C: they are refined by Newton's method in 40-digit decimal arithmetic and rounded
    once, so every machine gets the correctly rounded rule and the same generated code."""
    if n < 1:
        raise ValueError(f"gauss order must be >= 1, got {n}")
    x0, _ = np.polynomial.legendre.leggauss(n)
    xs, ws = [], []
    with localcontext() as ctx:
        ctx.prec = 40
        for guess in x0:
            x = Decimal(float(guess))
            for _ in range(6):  # quadratic convergence from ~1e-16: 1e-32 after one step, more for safety
                p, dp = _legendre(n, x)
                x -= p / dp
            _, dp = _legendre(n, x)
            xs.append(float((x + 1) / 2))
            ws.append(float(1 / ((1 - x * x) * dp * dp)))
    return np.array(xs), np.array(ws)
