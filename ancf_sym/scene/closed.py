"""Closed members (belts, track chains): a path of straight segments and circular arcs, sampled into the nodes of a
loop whose last element ends on its first node; and open circular arcs (curved members, `arc_nodes`).

A path is a list of pieces, each ("line", a, b) or ("arc", centre, radius, angle0, sweep) in the x-y plane (angles
in rad, sweep > 0 counter-clockwise); consecutive pieces must join. `belt_path` builds the path of a belt wrapped
around pulleys (the convex hull of circles, counter-clockwise). `sample` puts n nodes at equal arc length with the
path's unit tangents: a cubic Hermite element between two nodes of an arc then follows the arc to O(h^4).
"""
from __future__ import annotations

import numpy as np

from ancf_sym.util.checks import SceneError

JOIN_TOL = 1e-9  # relative mismatch allowed where two pieces meet


def _piece_length(piece) -> float:
    if piece[0] == "line":
        return float(np.linalg.norm(np.subtract(piece[2], piece[1])))
    return float(piece[2] * abs(piece[4]))


def _piece_point(piece, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Point and unit tangent at arc length s along one piece."""
    if piece[0] == "line":
        a, b = np.asarray(piece[1], float), np.asarray(piece[2], float)
        t = (b - a) / np.linalg.norm(b - a)
        return a + s * t, t
    c, R, a0, sweep = np.asarray(piece[1], float), float(piece[2]), float(piece[3]), float(piece[4])
    phi = a0 + np.sign(sweep) * s / R
    radial = np.array([np.cos(phi), np.sin(phi)])
    return c + R * radial, np.sign(sweep) * np.array([-radial[1], radial[0]])


def check_path(path: list) -> float:
    """Total length; SceneError if a piece is malformed or the pieces do not join into a loop."""
    if not path:
        raise SceneError("loop path: needs at least one piece")
    total = 0.0
    for i, piece in enumerate(path):
        kind = piece[0] if isinstance(piece, (tuple, list)) and piece else None
        if kind == "line" and len(piece) == 3:
            pass
        elif kind == "arc" and len(piece) == 5:
            if not piece[2] > 0 or piece[4] == 0:
                raise SceneError(f"loop path piece {i}: arc needs radius > 0 and a non-zero sweep, got {piece!r}")
        else:
            raise SceneError(f"loop path piece {i}: expected ('line', a, b) or ('arc', centre, radius, angle0, sweep), "
                             f"got {piece!r}")
        L = _piece_length(piece)
        if not np.isfinite(L) or L <= 0:
            raise SceneError(f"loop path piece {i}: length must be positive and finite, got {L!r}")
        total += L
    for i, piece in enumerate(path):
        end = _piece_point(piece, _piece_length(piece))[0]
        start = _piece_point(path[(i + 1) % len(path)], 0.0)[0]
        if np.linalg.norm(end - start) > JOIN_TOL * max(total, 1.0):
            raise SceneError(f"loop path: piece {i} ends at {end.tolist()} but piece {(i + 1) % len(path)} starts "
                             f"at {start.tolist()} (the pieces must join into a closed loop)")
    return total


def sample(path: list, n: int, dim: int = 2) -> tuple[np.ndarray, np.ndarray, float]:
    """(points (n, dim), unit tangents (n, dim), path length): n nodes at equal arc length, the first at the start
    of the first piece."""
    total = check_path(path)
    lengths = np.array([_piece_length(p) for p in path])
    ends = np.cumsum(lengths)
    pts, tans = np.zeros((n, dim)), np.zeros((n, dim))
    for k in range(n):
        s = total * k / n
        i = int(min(np.searchsorted(ends, s, side="right"), len(path) - 1))
        r, t = _piece_point(path[i], s - (ends[i] - lengths[i]))
        pts[k, :2], tans[k, :2] = r, t
    return pts, tans, total


def belt_path(pulleys: list[tuple[tuple[float, float], float]]) -> list:
    """Path of a belt around pulleys [(centre, radius), ...] listed counter-clockwise around the loop (each on the
    convex hull): outer tangent lines between consecutive pulleys and the arcs between them."""
    if len(pulleys) < 2:
        raise SceneError(f"belt_path: needs at least 2 pulleys, got {len(pulleys)}")
    cs = [np.asarray(c, float) for c, _ in pulleys]
    Rs = [float(R) for _, R in pulleys]
    if any(not R > 0 for R in Rs):
        raise SceneError(f"belt_path: pulley radii must be positive, got {Rs}")
    m = len(cs)
    # outer tangent from pulley i to i+1 (belt turning counter-clockwise: the pulleys lie on its left)
    legs = []
    for i in range(m):
        j = (i + 1) % m
        d = cs[j] - cs[i]
        D = np.linalg.norm(d)
        if D <= abs(Rs[i] - Rs[j]):
            raise SceneError(f"belt_path: pulleys {i} and {j} overlap (distance {D:g} <= |R_i - R_j|)")
        u = d / D
        # normal n (pointing away from the pulleys' left side) with n . u = (R_i - R_j) / D
        cos_a = (Rs[i] - Rs[j]) / D
        sin_a = np.sqrt(1 - cos_a**2)
        n = cos_a * u + sin_a * np.array([u[1], -u[0]])  # to the right of the travel direction
        legs.append((cs[i] + Rs[i] * n, cs[j] + Rs[j] * n, n))
    path = []
    for i in range(m):
        a, b, n = legs[i]
        path.append(("line", tuple(a), tuple(b)))
        j = (i + 1) % m
        n_out = legs[j][2]
        a0 = np.arctan2(n[1], n[0])
        sweep = (np.arctan2(n_out[1], n_out[0]) - a0) % (2 * np.pi)
        path.append(("arc", tuple(cs[j]), Rs[j], float(a0), float(sweep)))
    return path


def arc_through(a, m, b) -> tuple[np.ndarray, float, float, float]:
    """(centre, radius, angle0, sweep) of the circular arc from a through m to b (planar points; sweep > 0
    counter-clockwise); SceneError if the points are (nearly) collinear or coincide."""
    a, m, b = (np.asarray(p, float)[:2] for p in (a, m, b))
    d = 2 * ((m[0] - a[0]) * (b[1] - a[1]) - (m[1] - a[1]) * (b[0] - a[0]))
    size = max(np.linalg.norm(m - a), np.linalg.norm(b - a), np.linalg.norm(b - m))
    if not size > 0 or abs(d) <= 1e-12 * size**2:
        raise SceneError("arc through: the three points are collinear or coincide (a straight member takes "
                         f"points), got {[a.tolist(), m.tolist(), b.tolist()]}")
    # circumcentre: |c - a| = |c - m| = |c - b|
    am, ab = m - a, b - a
    c = a + np.array([ab[1] * (am @ am) - am[1] * (ab @ ab), am[0] * (ab @ ab) - ab[0] * (am @ am)]) / d
    R = float(np.linalg.norm(a - c))
    ang = [float(np.arctan2(*(p - c)[::-1])) for p in (a, m, b)]
    ccw_b, ccw_m = (ang[2] - ang[0]) % (2 * np.pi), (ang[1] - ang[0]) % (2 * np.pi)
    sweep = ccw_b if ccw_m < ccw_b else ccw_b - 2 * np.pi
    return c, R, ang[0], float(sweep)


def arc_nodes(centre, radius: float, angle0: float, sweep: float, n: int, dim: int = 2
              ) -> tuple[np.ndarray, np.ndarray, float]:
    """(points (n + 1, dim), unit tangents (n + 1, dim), arc length) of n elements of equal arc length along the
    arc from angle0 [rad] by sweep [rad] (> 0 counter-clockwise) about centre, in the x-y plane."""
    piece = ("arc", tuple(np.asarray(centre, float)[:2]), float(radius), float(angle0), float(sweep))
    total = _piece_length(piece)
    pts, tans = np.zeros((n + 1, dim)), np.zeros((n + 1, dim))
    for k in range(n + 1):
        r, t = _piece_point(piece, total * k / n)
        pts[k, :2], tans[k, :2] = r, t
    return pts, tans, total
