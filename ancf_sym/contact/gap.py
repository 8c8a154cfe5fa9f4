"""The true smallest gap between a member's centre line and a contact surface, and the check that the contact law
saw it.

The penalty law samples the gap at the Gauss points of every element only (ancf_sym.contact), and exact contact
puts its rows there (ancf_sym.contact.exact). A surface smaller
than the spacing of those points, a drum of radius R against an element of length h, can sit between two of them:
the centre line passes through it and no point feels it. This module finds, per element and surface, the closest
point of the element's cubic Hermite centre line r(xi) = A0 + A1 xi + A2 xi^2 + A3 xi^3 (xi in [0, 1]):

- ground {n.r >= level}: the gap n.r(xi) - level - t is a cubic in xi; its minimum on [0, 1] is at an end or at a
  root of its quadratic derivative: exact.
- drum (circle, cylinder of unit axis a, centre c): the gap |P (r(xi) - c)| - R - t (P = I - a a^T) is smallest
  where f(xi) = |P (r(xi) - c)|^2 (a polynomial of degree 6) is. f is sampled at SAMPLES + 1 points per element;
  from every sample lower than its neighbours (and the ends) Newton's iteration on f'(xi) = 2 D.D' with
  f'' = 2 (D'.D' + D.D'') (exact derivatives of the cubic), kept inside the two neighbouring sample intervals,
  converges to the local minimum; the smallest of them is the element's.

Only pairs in reach are projected: the cubic lies in the convex hull of its Bezier control points (r0, r0 + L r_x0/3,
r1 - L r_x1/3, r1), which bounds the gap from below per element; elements whose bound is above the answer sought
are skipped. A scene without penalty contact builds nothing here.

Hidden penetration: a true gap deeper than HIDDEN_FACTOR x the deepest penetration the law sees at its own sample
points, plus the sampling's sagitta where its points resolve a
drum and a floor of FLOOR x the element length (round-off of the geometry), means the law missed the surface:
statics (ancf_sym.statics) and dynamics (the time loop) do not report such a state as success.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ancf_sym.elements.quadrature import gauss01

SAMPLES = 16  # sample intervals per element for the start of the drum projection (f has at most 3 local minima)
NEWTON_ITER = 30  # Newton's iterations on f' at most (quadratic convergence: 4-6 from a sample within 1/16)
NEWTON_DONE = 1e-9  # a step below this in xi was taken where the error is ~ its square: the iteration stops
# A true gap deeper than this multiple of the law's own deepest sampled penetration p (plus the sagitta below) is
# hidden from the law. At a point-like contact whose apex lies between two loaded points the centre line reaches
# about 2 p (measured 2.01 p: a rope pushed up by a drum 13x wider than its elements, tests/contact/test_contact_drum.py).
HIDDEN_FACTOR = 3.0
# The law resolves a drum of radius rho = R + t where its points lie no farther apart than RESOLVE x rho (an arc of
# 14 degrees between points): there the cubic held at two points s apart may cut the arc between them like a chord,
# by up to the sagitta s^2 / (8 rho) <= rho / 128, which falls as h^2 under refinement (a rope landing on a drum
# touches between points first). Where the points lie farther apart the allowance is 0: a rope over a drum of radius
# 0.02 m reached 82 p and 7 p at 32 and 64 elements (points 0.017 and 0.008 m apart), with a contact force 42 % and
# 2 % off the converged one; at 128 elements (0.004 m) 1.05 p (tests/contact/test_contact_gap.py).
RESOLVE = 0.25
STATUS = "Hidden_Contact_Penetration"  # statics status of a state the check refuses
FLOOR = 1e-9  # x element length: below it a negative gap is round-off of the positions, not penetration


def is_drum(c) -> bool:
    return hasattr(c, "radius")


def checked_contacts(scene) -> list:
    """The scene's penalty contacts (the law sampled at Gauss points), in declaration order. Exact contact's rows sit
    at the same points, but with no penetration scale of their own they are reported (report(..., "exact")), not
    checked: between the points the cubic dips by its interpolation error (45 um at the touchdown of a rope with
    I = 1e-15 m^4 on 0.25 m elements, examples/rope_on_ground.py)."""
    return [c for c in getattr(scene, "contacts", ()) if c.method == "penalty"]


def cubic(asm, c, X: np.ndarray) -> np.ndarray:
    """(S, n_el, 4, dim) power-basis coefficients A_k of the centre line r(xi) = sum A_k xi^k of every element of
    the contact's member in the states X (S, n) (cubic Hermite: nodal r, r_x and the element length L)."""
    mm = asm.mesh.members[c.member]
    d = asm.scene.dim
    q = np.asarray(X, float)[:, mm.elem_dofs()]
    node = q.shape[2] // 2
    L = mm.elem_length[:, None]
    r0, t0, r1, t1 = q[..., :d], L * q[..., d:2 * d], q[..., node:node + d], L * q[..., node + d:node + 2 * d]
    return np.stack([r0, t0, 3 * (r1 - r0) - 2 * t0 - t1, 2 * (r0 - r1) + t0 + t1], axis=2)


def surfaces(asm, c, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre (S, d), P (S, d, d)) of a drum in the states X (P projects normal to the axis; a drum carried by a
    body moves with it)."""
    d = asm.scene.dim
    if c.body is None:
        P = np.eye(d) if c.axis is None else np.eye(d) - np.outer(c.axis, c.axis)
        return np.broadcast_to(c.centre, (len(X), d)), np.broadcast_to(P, (len(X), d, d))
    from ancf_sym.contact import body as contact_body

    X = np.asarray(X, float)
    o = asm.mesh.bodies[c.body]
    if d == 2:  # the body's centre; the axis z
        return X[:, o:o + 2], np.broadcast_to(np.eye(2), (len(X), 2, 2))
    centre, axis = contact_body.poses(c, asm, X)  # (all states at once: the check of every accepted step)
    P = np.eye(3) - axis[:, :, None] * axis[:, None, :] / np.einsum("si,si->s", axis, axis)[:, None, None]
    return centre, P


def _poly(A: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """r(xi) of cubics A (N, 4, d) at xi (N, m) -> (N, m, d)."""
    p = xi[..., None]
    return A[:, None, 0] + p * (A[:, None, 1] + p * (A[:, None, 2] + p * A[:, None, 3]))


def _relative(c, A: np.ndarray, centre: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The drum's radial part of cubics A (N, 4, d) with per-row centre (N, d) and projector P (N, d, d)."""
    B = np.matmul(A, P)  # (batched: ~10x the einsum's speed on the rows of many states)
    B[:, 0] -= np.matmul(centre[:, None, :], P)[:, 0]
    return B


def gap_lower_bound(c, A: np.ndarray) -> np.ndarray:
    """(N,) a lower bound of each cubic's smallest gap, from the convex hull of its Bezier control points b_k (the
    ground: the lowest of them; a drum: a ball about the chord's midpoint holding them all); A: the cubics (ground)
    or their radial parts (drums, _relative)."""
    b1 = A[:, 0] + A[:, 1] / 3
    b2 = b1 + (A[:, 1] + A[:, 2]) / 3
    b3 = A.sum(axis=1)
    if not is_drum(c):
        n = c.normal
        return np.minimum(np.minimum(A[:, 0] @ n, b1 @ n), np.minimum(b2 @ n, b3 @ n)) - c.level - c.thickness
    m = 0.5 * (A[:, 0] + b3)
    h = b3 - m
    r2 = np.maximum(np.einsum("nd,nd->n", h, h),
                    np.maximum(np.einsum("nd,nd->n", b1 - m, b1 - m), np.einsum("nd,nd->n", b2 - m, b2 - m)))
    return np.sqrt(np.einsum("nd,nd->n", m, m)) - np.sqrt(r2) - c.radius - c.thickness


def sampled_gaps(c, A: np.ndarray) -> np.ndarray:
    """(N, gauss) the gap at the law's own points (the contact's Gauss points) of the cubics A (ground) or their
    radial parts (drums)."""
    xi = np.broadcast_to(_gauss(c.gauss), (len(A), c.gauss))
    r = _poly(A, xi)
    if not is_drum(c):
        return r @ c.normal - c.level - c.thickness
    return np.linalg.norm(r, axis=2) - c.radius - c.thickness


@functools.lru_cache(maxsize=8)
def _gauss(n: int) -> np.ndarray:
    return gauss01(n)[0]


@functools.lru_cache(maxsize=8)
def _bounds(n: int) -> np.ndarray:
    """The law's points of an element and their neighbours in the adjacent elements: [p_n - 1, p_1..p_n, 1 + p_1]."""
    p = gauss01(n)[0]
    return np.r_[p[-1] - 1.0, p, 1.0 + p[0]]


def allowance(c, xi: np.ndarray, h: np.ndarray, A: np.ndarray | None = None) -> np.ndarray:
    """How far the centre line may dip below the law's points where they resolve the contact's geometry, at xi of
    elements of length h (s: the spacing of the two points around xi):
    - a drum: the sagitta s^2 / (8 rho) where s <= RESOLVE rho (rho = R + t);
    - the ground, given the cubics A: the interpolation bound max|g''| d^2 / 8 of the gap g(xi) between two points
      d = s / h apart (g'' in xi; exact for the cubic: a curve bent onto the ground dips below the chord of its two
      loaded points by at most this), where the points resolve the gap's bend, s <= RESOLVE / kappa with kappa =
      max|g''| / h^2 its curvature per metre (the drum's rule with rho = 1 / kappa). This dip falls as h^2 under
      refinement, like the sagitta. (At a free end, beyond the last point, the centre line is extrapolated, not
      interpolated: a tip pressed into the ground is found there whenever its dip exceeds this small allowance.)
    0 elsewhere."""
    b = _bounds(c.gauss)
    k = np.clip(np.searchsorted(b, xi), 1, len(b) - 1)
    d = b[k] - b[k - 1]
    s = d * h
    if is_drum(c):
        rho = c.radius + c.thickness
        return np.where(s <= RESOLVE * rho, s * s / (8 * rho), 0.0)
    if A is None:
        return np.zeros(len(xi))
    a = A @ c.normal
    g2 = np.maximum(np.abs(2 * a[:, 2]), np.abs(2 * a[:, 2] + 6 * a[:, 3]))  # max |g''(xi)| on [0, 1] (linear)
    return np.where(s * g2 <= RESOLVE * h * h, g2 * d * d / 8, 0.0)


def project(c, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(xi (N,), gap (N,)): the closest point of each cubic to the contact's surface and its gap; A (N, 4, d): the
    cubics (ground) or their radial parts (drums, _relative)."""
    N = len(A)
    if N == 0:
        return np.zeros(0), np.zeros(0)
    if not is_drum(c):  # gap(xi) = a0 + a1 xi + a2 xi^2 + a3 xi^3: ends and roots of the derivative
        a = A @ c.normal
        disc = a[:, 2] ** 2 - 3 * a[:, 1] * a[:, 3]
        sq = np.sqrt(np.maximum(disc, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            # roots of 3 a3 xi^2 + 2 a2 xi + a1 in the cancellation-free form (a3 = 0: r2 = -a1 / (2 a2))
            q = -(a[:, 2] + np.copysign(sq, a[:, 2]))
            roots = np.column_stack([q / (3 * a[:, 3]), a[:, 1] / q])
        ok = np.isfinite(roots) & (roots >= 0) & (roots <= 1) & (disc >= 0)[:, None]
        cand = np.column_stack([np.zeros(N), np.ones(N), np.where(ok, roots, 0.0)])
        g = a[:, :1] + cand * (a[:, 1:2] + cand * (a[:, 2:3] + cand * a[:, 3:4]))
        k = g.argmin(axis=1)
        rows = np.arange(N)
        return cand[rows, k], g[rows, k] - c.level - c.thickness
    B = A  # D(xi) = B0 + B1 xi + B2 xi^2 + B3 xi^3: the radial vector; f = |D|^2
    s = np.linspace(0.0, 1.0, SAMPLES + 1)
    f = (_poly(B, np.broadcast_to(s, (N, len(s)))) ** 2).sum(axis=2)  # (N, m)
    # starts: samples at or below both neighbours (an end: below its one neighbour)
    left = np.c_[np.full(N, np.inf), f[:, :-1]]
    right = np.c_[f[:, 1:], np.full(N, np.inf)]
    e, j = np.nonzero((f <= left) & (f <= right))
    xi = s[j]
    lo, hi = s[np.maximum(j - 1, 0)], s[np.minimum(j + 1, SAMPLES)]
    Be = B[e]
    for _ in range(NEWTON_ITER):
        xc = xi[:, None]
        D = Be[:, 0] + xc * (Be[:, 1] + xc * (Be[:, 2] + xc * Be[:, 3]))
        D1 = Be[:, 1] + xc * (2 * Be[:, 2] + 3 * xc * Be[:, 3])
        D2 = 2 * Be[:, 2] + 6 * xc * Be[:, 3]
        g1 = (D * D1).sum(axis=1)
        g2 = (D1 * D1).sum(axis=1) + (D * D2).sum(axis=1)
        convex = g2 > 0  # (else a quarter of the bracket downhill)
        step = np.where(convex, -g1 / np.where(convex, g2, 1.0), -np.sign(g1) * (hi - lo) / 4)
        new = np.clip(xi + step, lo, hi)
        done = np.all(np.abs(new - xi) <= NEWTON_DONE)
        xi = new
        if done:
            break
    fx = (_poly(Be, xi[:, None])[:, 0] ** 2).sum(axis=1)
    best = np.full(N, np.inf)
    np.minimum.at(best, e, fx)
    arg = np.zeros(N)
    hit = fx <= best[e]
    arg[e[hit]] = xi[hit]
    return arg, np.sqrt(best) - c.radius - c.thickness


def _rows(asm, c, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A (S*n_el, 4, d): the cubics (ground) or their radial parts (drums), state (S*n_el,)) of states X."""
    A = cubic(asm, c, X)
    S, N = A.shape[:2]
    A = A.reshape(S * N, 4, -1)
    state = np.repeat(np.arange(S), N)
    if is_drum(c):
        if c.body is None:  # a fixed drum: one projector for all rows (none in 2D)
            if c.axis is not None:
                A = A - np.einsum("nkd,d->nk", A, c.axis)[:, :, None] * c.axis
                A[:, 0] -= c.centre - (c.centre @ c.axis) * c.axis
            else:
                A[:, 0] -= c.centre
        else:
            centre, P = surfaces(asm, c, X)
            A = _relative(c, A, centre[state], P[state])
    return A, state


@dataclass
class Closest:
    """A contact's smallest true gap in a state, where it is, and what the law sees."""
    contact: object
    index: int  # the contact's place among the scene's contacts
    gap: float  # smallest true gap of the centre line's surface [m] (inf: no element in reach, only a bound known)
    element: int
    xi: float
    s: float  # material coordinate along the member [m]
    point: np.ndarray  # the closest centre-line point
    sampled_penetration: float  # the deepest penetration at the law's own points [m] (0: none)
    element_length: float
    sag: float = 0.0  # the dip below the law's points allowed there (allowance)

    @property
    def tolerance(self) -> float:
        """How deep a true gap may be before it counts as hidden from the law."""
        return HIDDEN_FACTOR * self.sampled_penetration + self.sag + FLOOR * self.element_length

    @property
    def hidden(self) -> bool:
        return self.gap < -self.tolerance

    def name(self) -> str:
        c = self.contact
        if not is_drum(c):
            return f"the ground (contact {self.index})"
        where = f"carried by body {c.body!r}" if c.body is not None else f"at {np.round(c.centre, 6).tolist()}"
        return f"the drum of radius {c.radius:g} m {where} (contact {self.index})"

    def message(self) -> str:
        c, h = self.contact, self.element_length
        frac = float(np.diff(_bounds(c.gauss)).max())  # the widest spacing of the law's points, per element length
        spacing = frac * h
        rho = c.radius + c.thickness if is_drum(c) else np.inf
        if spacing > RESOLVE * rho:  # the law's points do not resolve the drum
            advice = (f"its points lie up to {spacing:.3g} m apart (elements of {h:.4g} m), more than {RESOLVE:g} x "
                      f"the drum's radius {c.radius:g} m + half thickness {c.thickness:g} m: mesh member "
                      f"{c.member!r} with elements no longer than {RESOLVE * rho / frac:.3g} m where it meets the "
                      f"drum (with gauss = 7: {RESOLVE * rho / float(np.diff(_bounds(7)).max()):.3g} m)")
        else:  # the points see the surface but the cubic crosses it between them
            advice = (f"its points lie up to {spacing:.3g} m apart (elements of {h:.4g} m), too far apart for the "
                      f"curvature of the contact: mesh member {c.member!r} finer (elements of at most {h / 2:.3g} m) "
                      f"where it meets {('the drum' if is_drum(c) else 'the ground')}")
        return (f"member {c.member!r} passes through {self.name()}: its centre line reaches a gap of {self.gap:.3g} m "
                f"at element {self.element} (xi = {self.xi:.3f}, s = {self.s:.4g} m), deeper than {HIDDEN_FACTOR:g} x "
                f"the penetration {self.sampled_penetration:.3g} m the penalty law sees at its {c.gauss} Gauss points per element; "
                f"{advice}")

    def record(self) -> dict:
        return {"smallest_gap": self.gap if np.isfinite(self.gap) else None, "element": self.element,
                "xi": self.xi, "s": self.s, "point": self.point.tolist(),
                "sampled_penetration": self.sampled_penetration, "hidden_penetration": bool(self.hidden)}


def closest(asm, c, x: np.ndarray, index: int = 0, reach: float | None = None) -> Closest:
    """The contact's smallest true gap in the state x, or where the law missed the surface (Closest.hidden) the
    deepest such element's. reach = None: the exact global smallest gap (elements whose hull bound is above both the
    smallest nodal gap and 0 are skipped); reach = 0: only elements the hull lets reach into the surface are
    projected (a check of penetration: gap inf when none does)."""
    mm = asm.mesh.members[c.member]
    x = np.asarray(x, float)
    A, _ = _rows(asm, c, x[None])
    lb = gap_lower_bound(c, A)
    if reach is None:  # the nodes' gaps bound the smallest from above
        ends = np.r_[A[:1, 0], A.sum(axis=1)]
        ub = (ends @ c.normal - c.level if not is_drum(c) else np.linalg.norm(ends, axis=1) - c.radius).min() \
            - c.thickness
        sel = np.flatnonzero(lb <= max(ub, 0.0))
    else:
        sel = np.flatnonzero(lb < reach)
    if not len(sel):
        return Closest(c, index, np.inf, -1, float("nan"), float("nan"), np.full(asm.scene.dim, np.nan), 0.0,
                       float(mm.elem_length.max()))
    pen = float(max(0.0, -sampled_gaps(c, A[sel]).min()))
    xi, g = project(c, A[sel])
    h = mm.elem_length[sel]
    sag = allowance(c, xi, h, A[sel])
    bad = g < -(HIDDEN_FACTOR * pen + sag + FLOOR * h)  # as _scan
    k = int(np.argmin(np.where(bad, g, np.inf))) if bad.any() else int(np.argmin(g))
    e = int(sel[k])
    r = _poly(cubic(asm, c, x[None])[0, e:e + 1], np.array([[xi[k]]]))[0, 0]
    s = float(mm.s_node[mm.elem_nodes[e, 0]] + xi[k] * mm.elem_length[e])
    return Closest(c, index, float(g[k]), e, float(xi[k]), s, r, pen, float(mm.elem_length[e]), float(sag[k]))


def report(asm, x: np.ndarray, method: str = "penalty") -> list[dict]:
    """Per contact of that method (the order of ancf_sym.contact.report, resp. contact.exact.report): the true
    smallest gap and where it is; penalty contacts also what the law sees and whether it missed the surface."""
    out = [closest(asm, c, x, i).record() for i, c in enumerate(getattr(asm.scene, "contacts", ()))
           if c.method == method]
    if method != "penalty":  # (no law, no penetration scale: not checked)
        out = [{k: v for k, v in r.items() if k not in ("sampled_penetration", "hidden_penetration")} for r in out]
    return out


def _scan(asm, X: np.ndarray) -> tuple[int, list[tuple[float, int, float]]]:
    """(the first of the states X (S, n) with a hidden penetration, or -1; per contact (its smallest true
    gap among the elements in reach over all states, or inf, the state it is in, the law's sampled penetration
    there)). Vectorised over states and elements; only elements whose hull reaches into a surface are sampled and
    projected."""
    first, deepest = len(X), []
    for c in checked_contacts(asm.scene):
        A, state = _rows(asm, c, X)
        sel = np.flatnonzero(gap_lower_bound(c, A) < 0.0)
        if not len(sel):
            deepest.append((np.inf, -1, 0.0))
            continue
        pen = np.zeros(len(X))
        np.maximum.at(pen, state[sel], np.maximum(0.0, -sampled_gaps(c, A[sel]).min(axis=1)))
        xi, g = project(c, A[sel])
        h = asm.mesh.members[c.member].elem_length
        h = h[sel % len(h)]
        tol = HIDDEN_FACTOR * pen[state[sel]] + allowance(c, xi, h, A[sel]) + FLOOR * h
        bad = state[sel][g < -tol]
        if len(bad):
            first = min(first, int(bad.min()))
        j = int(np.argmin(g))
        k = int(state[sel][j])
        deepest.append((float(g[j]), k, float(pen[k])))
    return (first if first < len(X) else -1), deepest


def hidden(asm, X: np.ndarray) -> tuple[int, list[Closest]]:
    """The first of the states X (S, n) (or one state x (n,)) in which a contact's centre line reaches into
    the surface deeper than the law's sampled penetration allows (Closest.hidden): (its index, the contacts so
    found); (-1, []) when none does."""
    X = np.atleast_2d(np.asarray(X, float))
    first, _ = _scan(asm, X)
    if first < 0:
        return -1, []
    found = [closest(asm, c, X[first], i, reach=0.0) for i, c in enumerate(getattr(asm.scene, "contacts", ()))
             if c.method == "penalty"]
    return first, [f for f in found if f.hidden]


def refusal(found: list[Closest]) -> str:
    """One message for the hidden penetrations found (the deepest first)."""
    found = sorted(found, key=lambda f: f.gap)
    return "; ".join(f.message() for f in found)


DYNAMIC_STATUS = "contact_penetration_hidden"  # a dynamic run's status when an accepted step hid a penetration


class Watch:
    """The check of a dynamic run's accepted steps, in batches (one vectorised check per compiled chunk, or per
    BATCH single steps): the first accepted state in which a penalty law missed a surface ends the run. Built only
    for scenes with penalty contact."""
    BATCH = 64

    def __init__(self, S):
        self.S, self.asm = S, S.asm
        self.t: list[float] = []
        self.Q: list[np.ndarray] = []
        self.found: tuple[float, str] | None = None  # (time, message) of the first hidden penetration
        # per contact: the smallest true gap among elements in reach over the checked steps, its time and
        # the law's sampled penetration then
        self.deepest = [(np.inf, float("nan"), 0.0) for _ in checked_contacts(self.asm.scene)]

    def add(self, t: float, q: np.ndarray) -> None:
        """One accepted step's unknowns q at time t (checked with the batch)."""
        self.t.append(t)
        self.Q.append(np.array(q, float))
        if len(self.t) >= self.BATCH:
            self.flush()

    def check(self, ts, Q: np.ndarray) -> None:
        """Accepted steps' unknowns Q (k, nf) at the times ts, checked now (a chunk's states)."""
        self.flush()
        self._check(list(ts), np.asarray(Q, float))

    def flush(self) -> None:
        if self.t:
            ts, Q = self.t, np.array(self.Q)
            self.t, self.Q = [], []
            self._check(ts, Q)

    def _check(self, ts: list, Q: np.ndarray) -> None:
        if self.found is not None or not len(ts):
            return
        X = self.S.full_rows(Q)
        first, deepest = _scan(self.asm, X)
        for i, (g, k, p) in enumerate(deepest):
            if g < self.deepest[i][0]:
                self.deepest[i] = (g, float(ts[k]), p)
        if first >= 0:
            _, found = hidden(self.asm, X[first])
            self.found = (float(ts[first]), refusal(found))

    def record(self) -> list[dict]:
        """Per contact over the checked steps: its smallest true gap [m] (None: no element ever reached
        into the surface, all gaps >= 0), when [s], and the law's sampled penetration then [m]."""
        return [{"type": "circle" if is_drum(c) else "ground", "member": c.member,
                 "smallest_gap": g if np.isfinite(g) else None, "t": t if np.isfinite(g) else None,
                 "sampled_penetration": p}
                for c, (g, t, p) in zip(checked_contacts(self.asm.scene), self.deepest)]


def gap_lower_bound_mx(asm, c, X):
    """casadi (N, 1): gap_lower_bound of every element of a fixed surface's member, in the full coordinates X (a
    casadi column; MX inside a step graph): the same Bezier hull bound written on the nodal r and r_x, for graphs that
    skip a contact's kernels while no element is in reach (its law is exactly 0 where the gap is positive). A drum
    carried by a body has no fixed centre: None."""
    import casadi as ca

    if getattr(c, "body", None) is not None:
        return None
    mm = asm.mesh.members[c.member]
    d = asm.scene.dim
    idx, L = mm.elem_dofs(), ca.DM(mm.elem_length)
    node = idx.shape[1] // 2
    col = [X[idx[:, j].tolist()] for j in range(idx.shape[1])]
    r0, r1 = col[:d], col[node:node + d]
    b = [r0, [r0[j] + L * col[d + j] / 3 for j in range(d)], [r1[j] - L * col[node + d + j] / 3 for j in range(d)],
         r1]
    if not is_drum(c):
        n = c.normal
        heights = [sum(float(n[j]) * bk[j] for j in range(d)) for bk in b]
        return ca.fmin(ca.fmin(heights[0], heights[1]), ca.fmin(heights[2], heights[3])) - c.level - c.thickness
    P = np.eye(d) if c.axis is None else np.eye(d) - np.outer(c.axis, c.axis)
    rel = [[sum(float(P[i, j]) * (bk[j] - float(c.centre[j])) for j in range(d)) for i in range(d)] for bk in b]
    m = [0.5 * (rel[0][i] + rel[3][i]) for i in range(d)]

    def sq(u):
        return sum((u[i] - m[i]) ** 2 for i in range(d))

    r2 = ca.fmax(sq(rel[3]), ca.fmax(sq(rel[1]), sq(rel[2])))
    return ca.sqrt(sum(mi ** 2 for mi in m)) - ca.sqrt(r2) - c.radius - c.thickness
