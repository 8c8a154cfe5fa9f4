"""Vectors affine in the scene's coordinates, and the exact constraint rows they make.

A rigid body's points and directions (planar: r + R(u) p with u = (cos, sin); spatial: r + sum_k p_k e_k), a member
node's position and gradients, and fixed world vectors are all affine in the coordinates. Joints equate two such
vectors (linear rows) or ask a dot product of two to take a value (bilinear rows): exactly the rows the constraint
layer (ancf_sym.model.constraints.Rows) stores, with constant Jacobian structure and constant Hessians.
"""
from __future__ import annotations

import numpy as np


class Vec:
    """A vector affine in the coordinates: component c = sum_i coef[c][i] x_i + const[c]."""

    def __init__(self, coef: list[dict] | None = None, const=None, dim: int = 3):
        self.const = np.zeros(dim if coef is None else len(coef)) if const is None else np.asarray(const, float)
        self.coef = coef if coef is not None else [{} for _ in self.const]

    def __add__(self, o: "Vec") -> "Vec":
        coef = [dict(a) for a in self.coef]
        for c, b in enumerate(o.coef):
            for i, v in b.items():
                coef[c][i] = coef[c].get(i, 0.0) + v
        return Vec(coef, self.const + o.const)

    def scaled(self, s: float) -> "Vec":
        return Vec([{i: s * v for i, v in a.items()} for a in self.coef], s * self.const)

    def __sub__(self, o: "Vec") -> "Vec":
        return self + o.scaled(-1.0)


def const(v) -> Vec:
    """A fixed world vector."""
    v = np.asarray(v, float)
    return Vec(None, v)


def coords(idx) -> Vec:
    """The vector of the coordinates idx (a node's r or a gradient, a body's centre)."""
    return Vec([{int(i): 1.0} for i in idx])


def body_sides(mesh, j, point, direction) -> tuple:
    """(p_a, p_b, dir_a, dir_b, label) of a joint between body j.body and body j.other (None: the ground) at the world
    point j.point: the two bodies' points that lie there in the reference state, and functions giving a world
    direction d of the reference state as fixed in either side. point(offset, p) and direction(offset, a) are the
    body kind's affine vectors of a body point / body-fixed direction."""
    scene = mesh.scene
    b, o = scene.bodies[j.body], mesh.bodies[j.body]
    other = scene.bodies[j.other] if j.other else None
    oo = mesh.bodies[j.other] if j.other else None
    pb = point(oo, other.local(j.point)) if other else const(j.point)

    def dir_a(d: np.ndarray) -> Vec:
        return direction(o, b.local(b.position + d))

    def dir_b(d: np.ndarray) -> Vec:
        return direction(oo, other.local(other.position + d)) if other else const(d)

    return point(o, b.local(j.point)), pb, dir_a, dir_b, f"{j.kind} {j.body}-{j.other or 'ground'}"


def _emit(rows, label: str, kind: str, lin: dict, quad: list, d: float) -> None:
    rows.row({i: v for i, v in lin.items() if v != 0}, d, label, kind, quad)
    rows.k.append(0.0)  # exact


def equal(rows, a: Vec, b: Vec, label: str, kind: str = "position") -> None:
    """One linear row per component: a - b = 0."""
    diff = a - b
    for c in range(len(diff.coef)):
        _emit(rows, label, kind, diff.coef[c], [], float(-diff.const[c]))


def dot(rows, a: Vec, b: Vec, value: float, label: str, kind: str) -> None:
    """One row a . b = value (bilinear in the coordinates)."""
    lin: dict = {}
    quad = []
    for c in range(len(a.coef)):
        for i, u in a.coef[c].items():
            quad += [(i, j, u * w) for j, w in b.coef[c].items() if u * w != 0]
            lin[i] = lin.get(i, 0.0) + u * b.const[c]
        for j, w in b.coef[c].items():
            lin[j] = lin.get(j, 0.0) + w * a.const[c]
    _emit(rows, label, kind, lin, quad, float(value - a.const @ b.const))


def normals(t: np.ndarray) -> list[np.ndarray]:
    """Two unit vectors orthogonal to the unit 3-vector t and to each other (t, n1, n2 right-handed)."""
    a = np.array([1.0, 0, 0]) if abs(t[0]) < 0.9 else np.array([0, 1.0, 0])
    n1 = np.cross(t, a)
    n1 /= np.linalg.norm(n1)
    return [n1, np.cross(t, n1)]
