"""Coordinates that a symmetry of the scene holds at their start values: a first IPOPT phase without them.

A slack cable hanging in a vertical plane of a 3-D scene starts straight and compressed: its tangent is indefinite
in the plane AND out of it, and out of the plane nothing loads it (the gradient there is zero) and nothing couples
it to the plane (zero Hessian block), so every minimiser's path stays in the plane. IPOPT's inertia correction
adds one shift delta I to the whole Hessian, large enough for the most negative curvature anywhere: the
out-of-plane one persists while parts of the cable are still compressed, and its shift damps the in-plane steps
too (measured: 4 elements, 500 iterations creeping to 0.1 % of the potential, where the planar scene converges in
71). Held at their start values, those coordinates leave IPOPT the planar problem; the Newton finish and the
stability check then judge the answer in all coordinates, so holding them cannot make a wrong answer succeed
(an answer unstable out of the plane is left along its negative curvature as any saddle is).

Unloaded and uncoupled at the start is not yet a symmetry: a straight rope's axial coordinates are both under a
transverse end load, and their first order decoupling ends as soon as it bends. `mirrored` asks the scene itself:
a symmetry that holds the coordinates is a mirror about their start values, under which the gradient at a
displaced state mirrors too (to round-off, at a displacement far from infinitesimal); without one, no held phase
(it would cost two IPOPT runs whose answers the check after the solve then rejects).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp


def held_coordinates(gradient: np.ndarray, hessian: sp.spmatrix | None, rows: sp.spmatrix | None,
                     force_floor: float, stiffness_floor: float) -> np.ndarray:
    """Indices of the coordinates that no load moves at the start and that nothing couples to the others:
    |gradient_i| <= force_floor, and no Hessian entry above stiffness_floor nor exact constraint row (`rows`, the
    rows' Jacobian pattern) joins them to a coordinate outside the set (found by removing coupled coordinates until
    none is left). Coordinates in a constraint row are then left free (their rows hold them). Empty where every
    coordinate, or none, would be held."""
    n = gradient.size
    if hessian is None or n == 0:
        return np.zeros(0, dtype=np.int64)
    held = np.abs(gradient) <= force_floor
    H = abs(sp.csr_matrix(hessian))
    C = (H + H.T) > stiffness_floor
    constrained = np.zeros(n, dtype=bool)
    if rows is not None and rows.shape[0]:
        R = (abs(sp.csr_matrix(rows)) > 0).astype(np.int8)
        C = C + ((R.T @ R) > 0)  # coordinates in one row move together
        constrained[np.unique(R.indices)] = True
    C = C.astype(np.int8).tocsr()
    while held.any() and not held.all():
        coupled = held & (C @ (~held).astype(np.int8) > 0)  # a held coordinate that a moving one pulls on
        if not coupled.any():
            break
        held &= ~coupled
    held &= ~constrained
    if held.all() or not held.any():
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(held)


def mirrored(gradient: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, held: np.ndarray,
             rows: sp.spmatrix | None = None, size: float = 1e-2, tol: float = 1e-8) -> bool:
    """Is the potential even in the held coordinates about their start values? g(x0 + R d) = R g(x0 + d) for a
    displacement d of `size` times the coordinates' scale (R: the held coordinates' sign flipped), to `tol` of the
    gradient's size: a mirror symmetry holds to round-off at any d, a mere first-order decoupling fails at O(d^2).
    Coordinates in constraint rows (`rows`: a pin's, a joint's) stay at x0 and are not compared: their rows hold
    them (a pinned end's out-of-plane coordinate is on the mirror plane)."""
    rng = np.random.default_rng(0)  # (fixed: the same decision on every run)
    d = size * max(1.0, float(np.abs(x0).max())) * rng.standard_normal(x0.size)
    free = np.ones(x0.size, dtype=bool)
    if rows is not None and rows.shape[0]:
        free[np.unique(sp.csr_matrix(rows).indices)] = False
    d[~free] = 0.0
    Rd = d.copy()
    Rd[held] *= -1.0
    g1, g2 = gradient(x0 + d), gradient(x0 + Rd)
    g1[held] *= -1.0
    g1, g2 = g1[free], g2[free]
    scale = max(float(np.abs(g1).max()), float(np.abs(g2).max()))
    return bool(np.all(np.isfinite(g1)) and np.all(np.isfinite(g2)) and np.abs(g2 - g1).max() <= tol * scale)
