"""Contact kernels evaluated only for the element-surface pairs in reach, at every point a step graph evaluates.

A contact law (normal law, damping, friction) is exactly 0 where the gap is positive (ancf_sym.elements.contact:
the penetration max(0, -gap) and every force and tangent are products with it), so skipping the kernels of pairs
whose smallest gap is surely positive changes no value, only what is evaluated. Inside the step graphs, each
contact kernel's mapped call over a member's N elements is split into blocks of BLOCK consecutive elements; a
block's kernels run (Function.conditional) only when one of its elements may reach the surface, else the block's
outputs are exact zeros. The test is made in the graph from the iterate itself, so it needs no margin for the
motion within a step: a pair that comes within reach during a step (between two Newton iterates) is evaluated at
the first iterate where it is in reach, as the all-pairs graph would.

The bound: every point of an element's cubic centre line lies in the convex hull of its Bezier control points
(r0, r0 + L r_x0 / 3, r1 - L r_x1 / 3, r1), hence in the ball about the chord's midpoint m whose radius rho is the
largest distance of a control point from m. The gap the kernels sample at their Gauss points is then at least
- ground {n.r >= d}:                n.m - rho - d - t;
- a drum of axis a, centre c:       |P (m - c)| - rho - R - t, P = I - a a^T the kernel's own projector (|P| <= 1
                                    for |a|^2 <= 2: the axis of a fixed drum is a unit vector, a body's drum's axis
                                    sum a_k e_k of the body's axes, unit to the constraints' tolerance);
with the drum's centre and axis read from the same inputs as the kernel's (fixed: its parameters; carried by a body:
the body's coordinates in the state). A pair is out of reach when the bound exceeds contact.gap.FLOOR x L (round-off
of the positions).

Blocks, not single pairs: the pairs in reach of a surface are consecutive along the member, and each block costs
a conditional call with its input and output slices. Measured on the tracked vehicle's wheel (64 elements, 3 in
reach, Hessian kernel): 0.071, 0.079, 0.103 ms with blocks of 4, 8, 16 elements against 0.139 ms for all pairs;
the gradient kernels 0.015-0.019 ms either way (they are cheap: 0.3 us per element). 8 keeps the graphs small.
"""
from __future__ import annotations

from typing import Callable

import casadi as ca
import numpy as np

from ancf_sym import registry
from ancf_sym.contact import gap as contact_gap

ENABLED = True  # (tests switch it off to compare against the all-pairs graphs; clear the graph caches then)
BLOCK = 8  # elements per switched block

_SWITCHES: dict = {}  # (kernel map's name, block size) -> its conditional on "a pair in reach"


def _obstacle_kind(effect: str) -> str | None:
    """How the kernel's inputs give the surface: 'ground', 'fixed' (a drum in the parameters), 'body3' (a spatial
    body's drum: r, e1, e2, e3 after the element's coordinates), 'centre' (a drum centred at the first coordinates
    after the element's), or None (not a contact law this module knows: always evaluated)."""
    base = effect[:-len("_friction")] if effect.endswith("_friction") else effect
    return {"contact_ground": "ground", "contact_drum": "fixed", "contact_body_drum": "body3",
            "contact_circle": "centre", "contact_body": "centre"}.get(base)


def _gather(x: ca.MX, idx: np.ndarray) -> ca.MX:
    """x at idx (N, k) as a k x N matrix (column e: the element's k coordinates)."""
    N, k = idx.shape
    return ca.reshape(x[idx.ravel().tolist()], k, N)


def _ball(x: ca.MX, idx: np.ndarray, L: ca.MX, dim: int, node: int, cache: dict) -> tuple[ca.MX, ca.MX]:
    """(m (dim x N), rho (1 x N)): the ball about each element's chord midpoint holding its Bezier control points;
    kept in `cache` by the element table (the contacts of one member share it)."""
    key = (idx[:, :2 * node].tobytes(), idx.shape[0])
    if key in cache:
        return cache[key]
    R0, T0 = _gather(x, idx[:, :dim]), _gather(x, idx[:, dim:2 * dim])
    R1, T1 = _gather(x, idx[:, node:node + dim]), _gather(x, idx[:, node + dim:node + 2 * dim])
    h = 0.5 * (R0 - R1)  # b0 - m (b3 - m = -h)
    l3 = ca.repmat(L / 3, dim, 1)
    u1, u2 = h + l3 * T0, h + l3 * T1  # b1 - m, -(b2 - m)
    rho = ca.sqrt(ca.fmax(ca.sum1(h * h), ca.fmax(ca.sum1(u1 * u1), ca.sum1(u2 * u2))))
    out = cache[key] = (0.5 * (R0 + R1), rho)
    return out


def lower_bound(element: str, effect: str, idx: np.ndarray, P: ca.MX, x: ca.MX, dim: int,
                cache: dict) -> ca.MX | None:
    """(1 x N) a lower bound of the gap at every point of each row's element centre line against the row's surface
    (module docstring), from the full coordinates x (MX) and the kernel's parameters P (n_p x N); None for a kernel
    without a known surface. idx: the kernel's coordinate indices per row (the element's, then the obstacle's). A
    term's rows may hold several contacts (the same kernel on the same member: their rows one after the other),
    so every row reads its own parameters and obstacle."""
    kind = _obstacle_kind(effect)
    if kind is None:
        return None
    nd = registry.ELEMENTS[element].ndof
    n_p = P.shape[0]
    L, t = P[0, :], P[3, :]
    m, rho = _ball(x, idx, L, dim, nd // 2, cache)
    if kind == "ground":
        return ca.sum1(P[4:4 + dim, :] * m) - rho - P[4 + dim, :] - t

    def rows(M: ca.MX, a: ca.MX) -> ca.MX:  # the columns of M scaled by the row a
        return M * ca.repmat(a, M.shape[0], 1)
    axis = P[5:8, :] if dim == 3 else None
    if kind == "fixed":
        centre = P[n_p - dim:, :]
    elif kind == "body3":  # the body's r, e1, e2, e3; axis sum a_k e_k through r + sum s_k e_k (as the kernel)
        B = _gather(x, idx[:, nd:nd + 12])
        e = [B[3 * k:3 * k + 3, :] for k in (1, 2, 3)]
        axis = rows(e[0], P[5, :]) + rows(e[1], P[6, :]) + rows(e[2], P[7, :])
        centre = B[0:3, :] + rows(e[0], P[n_p - 3, :]) + rows(e[1], P[n_p - 2, :]) + rows(e[2], P[n_p - 1, :])
    else:  # centre: the obstacle's first coordinates (a planar body's drum, a drum driven as coordinates)
        centre = _gather(x, idx[:, nd:nd + dim])
    D = m - centre
    if axis is not None:
        D = D - rows(axis, ca.sum1(axis * D))
    return ca.sqrt(ca.sum1(D * D)) - rho - P[4, :] - t


def _switch(mapper: Callable[[int], ca.Function], n: int) -> ca.Function:
    """mapper(n) as a conditional: index 0 -> exact zeros of its outputs (no kernel work), else mapper(n)."""
    f = mapper(n)
    key = (f.name(), n)
    sw = _SWITCHES.get(key)
    if sw is None:
        ins = [ca.MX.sym(f.name_in(k), f.sparsity_in(k)) for k in range(f.n_in())]
        zero = ca.Function(f"{f.name()}_out_of_reach", ins, [ca.MX.zeros(f.sparsity_out(k)) for k in range(f.n_out())])
        sw = _SWITCHES[key] = ca.Function.conditional(f"{f.name()}_in_reach", [zero], f)
    return sw


def call(mapper: Callable[[int], ca.Function], element: str, effect: str, idx: np.ndarray, Z: ca.MX, P,
         x: ca.MX, dim: int, cache: dict) -> list:
    """The outputs of mapper(N)(Z, P) (a contact kernel mapped over the N elements of idx; Z its inputs, P its
    parameters), with the kernels of each block of BLOCK elements run only where one of its pairs is in reach of
    the surface (exact zeros elsewhere: the same values); the plain call where the surface is unknown, the member
    has no more than BLOCK elements, or the switch is off."""
    N = idx.shape[0]
    P = ca.MX(P) if not isinstance(P, ca.MX) else P
    bound = lower_bound(element, effect, idx, P, x, dim, cache) if ENABLED and N > BLOCK else None
    if bound is None:
        return mapper(N).call([Z, P])
    floor = contact_gap.FLOOR * P[0, :]
    near = bound <= floor  # (1 x N: 1 where the pair may be in reach)
    starts = list(range(0, N, BLOCK))
    rows = np.arange(N)
    A = ca.DM(ca.Sparsity.triplet(N, len(starts), rows.tolist(), (rows // BLOCK).tolist()), 1.0)
    count = ca.mtimes(near, A)  # (1 x blocks: pairs in reach per block)
    outs = []
    for j, a in enumerate(starts):
        b = min(a + BLOCK, N)
        outs.append(_switch(mapper, b - a).call([count[j], Z[:, a:b], P[:, a:b]]))
    return [ca.horzcat(*[o[k] for o in outs]) for k in range(len(outs[0]))]
