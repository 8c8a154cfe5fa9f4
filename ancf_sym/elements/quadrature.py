"""Gauss-Legendre rules on [0, 1]: points and weights summing to 1."""
from __future__ import annotations

import numpy as np


def gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss-Legendre rule on [0, 1]; exact for polynomials of degree 2n-1."""
    if n < 1:
        raise ValueError(f"gauss order must be >= 1, got {n}")
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1.0) / 2.0, w / 2.0
