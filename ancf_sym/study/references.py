"""Independent references for the statics studies: the planar rod with the cable's own energy, solved as a
boundary-value problem (scipy solve_bvp), without any ANCF discretisation.

The cable energy per reference length is W = EA/2 e(lam)^2 + EI/2 kappa^2 with r' = lam (cos th, sin th),
kappa = |r' x r''| / |r'|^3 = th'/lam (ancf_sym/elements/cable.py). Its Euler-Lagrange equations, with the internal
force n(s) = F_tip + int_s^L f (dead loads per reference length f, dead tip force F_tip):
    x' = lam cos th,  y' = lam sin th,  th' = m lam^2 / EI,  m' = -lam n . (-sin th, cos th),
    EA e(lam) e'(lam) - m^2 lam / EI = n . (cos th, sin th)            (axial balance, solved for lam),
with th(0) = 0, r(0) = 0 (clamp) and m(L) = 0 (free end). Strain measures: green e = (lam^2 - 1)/2, biot e = lam - 1.
The potential (strain energy + load potentials) is integrated alongside, so energies are referenced too.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_bvp


@dataclass(frozen=True)
class RodReference:
    tip: np.ndarray  # (x, y) of the free end [m]
    potential: float  # strain energy + potential of the loads (zero at the undeformed clamp height) [J]
    strain_energy: float  # [J]
    max_residual: float  # solve_bvp's largest relative residual
    nodes: int
    how: str  # one line saying how it was obtained


def _stretch(N: np.ndarray, m: np.ndarray, EA: float, EI: float, strain: str) -> np.ndarray:
    """lam solving EA e e' - m^2 lam/EI = N (Newton from the axial-only guess; strains are small to moderate)."""
    if strain == "biot":
        return (N + EA) / (EA - m * m / EI)
    lam = np.sqrt(np.maximum(1.0 + 2.0 * N / EA, 0.25))
    for _ in range(30):
        f = EA * (lam**3 - lam) / 2 - m * m * lam / EI - N
        df = EA * (3 * lam**2 - 1) / 2 - m * m / EI
        step = f / df
        lam = lam - step
        if np.max(np.abs(step)) < 1e-15:
            break
    return lam


def clamped_rod(L: float, EA: float, EI: float, w: tuple[float, float] = (0.0, 0.0),
                tip_force: tuple[float, float] = (0.0, 0.0), strain: str = "green", tol: float = 1e-10,
                load_steps: int = 20) -> RodReference:
    """Rod clamped at the origin along +x under a dead distributed load w [N/m] and a dead tip force [N]."""
    if strain not in ("green", "biot"):
        raise ValueError(f"strain must be green or biot, got {strain!r}")
    wx, wy = w
    Fx, Fy = tip_force

    def solve(scale, guess_s, guess_y):
        def rhs(s, y):
            x_, y_, th, m, _, _ = y
            nx, ny = scale * (Fx + wx * (L - s)), scale * (Fy + wy * (L - s))
            c, si = np.cos(th), np.sin(th)
            lam = _stretch(nx * c + ny * si, m, EA, EI, strain)
            e = (lam**2 - 1) / 2 if strain == "green" else lam - 1
            W = EA / 2 * e**2 + m * m * lam**2 / (2 * EI)
            return np.vstack([lam * c, lam * si, m * lam**2 / EI, -lam * (-nx * si + ny * c), W,
                              -scale * (wx * x_ + wy * y_)])

        def bc(ya, yb):
            return np.array([ya[0], ya[1], ya[2], yb[3], ya[4], ya[5]])

        return solve_bvp(rhs, bc, guess_s, guess_y, tol=tol, max_nodes=200000, bc_tol=1e-12)

    s = np.linspace(0.0, L, 201)
    y = np.zeros((6, s.size))
    y[0] = s
    for k in range(1, load_steps + 1):
        sol = solve(k / load_steps, s, y)
        if sol.status != 0:
            raise RuntimeError(f"reference rod: solve_bvp failed at load factor {k}/{load_steps}: {sol.message}")
        s, y = sol.x, sol.y
    end = y[:, -1]
    potential = end[4] + end[5] - (Fx * end[0] + Fy * end[1])
    return RodReference(tip=end[:2].copy(), potential=float(potential), strain_energy=float(end[4]),
                        max_residual=float(np.max(sol.rms_residuals)), nodes=int(s.size),
                        how=(f"planar rod with the cable's {strain} energy, solve_bvp (tol {tol:g}, {s.size} nodes), "
                             f"load continued in {load_steps} steps"))
