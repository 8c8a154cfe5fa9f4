"""Cubic Hermite functions of xi = x/L in [0, 1] and their xi-derivatives (without the L factors)."""
from __future__ import annotations


def h(xi):
    """[h1, h2, h3, h4]: r(x) = h1 r(0) + L h2 r_x(0) + h3 r(L) + L h4 r_x(L)."""
    return [1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -(xi**2) + xi**3]


def dh(xi):
    return [-6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2, 6 * xi - 6 * xi**2, -2 * xi + 3 * xi**2]


def ddh(xi):
    return [-6 + 12 * xi, -4 + 6 * xi, 6 - 12 * xi, -2 + 6 * xi]
