"""Spatial rigid bodies and their joints, in natural coordinates.

A body's unknowns are q_b = (r, e1, e2, e3): its centre of mass r and the world components of its body-fixed axes
e_k, tied by the six exact rows e_i . e_j = delta_ij. The parametrisation was chosen against the alternatives
for what the rest of the package does with it:
- Euler parameters (r, p, |p|^2 = 1; 7 unknowns) give the mass matrix 4 G(p)^T I G(p), which depends on the
  configuration, and a quadratic-velocity force; the integrators here (Newmark family with a constant M in a
  compiled step graph, collocation) and the energy bookkeeping would all need a q-dependent M and its derivatives.
  A body point r + R(p) s is quadratic in p and the joints would be general nonlinear rows.
- Rotation-vector updates need a Lie-group integrator, not the vector-space Newmark family used for the members.
- Natural coordinates (this module; the spatial analogue of the planar bodies' (x, y, cos, sin)): the kinetic energy
  1/2 m |r'|^2 + 1/2 sum_kl C_kl e_k' . e_l' with C = int rho s s^T dV = tr(I)/2 - I (I about the centre, in the
  body axes) has a CONSTANT mass matrix diag(m, m, m) + C (x) I_3, like the ANCF members' (the gyroscopic terms of
  Euler's equations come out of the orthonormality multipliers and the constraints' phi_vv term); no singular
  orientation exists; gravity and forces at the centre are linear in q; a body point r + sum_k s_k e_k and a body
  direction sum_k a_k e_k are linear in q, so every joint below is linear or bilinear: exact rows with constant
  Hessians through the constraint layer the supports use (ancf_sym.model.constraints). The price, 12 unknowns and six
  multipliers per body instead of 7 and one, is small next to a member's.
C must be positive semi-definite: the triangle inequalities I_k <= I_i + I_j that every real mass distribution
satisfies (equality: a lamina, whose C is singular off the constraint manifold but whose kinetic energy is positive
definite on it, which is what the constrained solves need).

Joints (all in world coordinates of the reference state; the body points and directions they name are fixed in
the body where they lie then): spherical (a point to the ground or to another body), revolute (spherical + one
axis kept parallel), prismatic (relative orientation fixed and the point slides along one axis), pin (a member
node on a body point) and rigid (pin + the member's slope direction turns with the body; beam3d: its whole frame
of gradients r_x, r_y, r_z).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ancf_sym.bodies.rows import Vec, body_sides, const, coords, dot, equal, normals
from ancf_sym.util.checks import fail, number, vector

BODY_SIZE = 12  # r (3), e1, e2, e3 (3 each)
JOINT_KINDS = ("spherical", "revolute", "prismatic", "pin", "rigid")
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))  # the orthonormality rows e_i . e_j = delta_ij
ORTHONORMAL_TOL = 1e-9  # accepted |A A^T - I| of user-given axes


@dataclass
class SpatialBody:
    name: str
    mass: float  # [kg]
    inertia: np.ndarray  # (3, 3) about the centre of mass, in the body axes [kg m^2]
    position: np.ndarray  # centre of mass in the reference state [m]
    axes: np.ndarray  # (3, 3) rows: the body's x, y, z axes in world components, reference state
    force: np.ndarray  # dead force at the centre of mass [N]

    @property
    def q0(self) -> np.ndarray:
        return np.concatenate([self.position, self.axes.ravel()])

    @property
    def second_moment(self) -> np.ndarray:
        """C = int rho s s^T dV in the body axes: tr(I)/2 - I."""
        return 0.5 * np.trace(self.inertia) * np.eye(3) - self.inertia

    def local(self, point: np.ndarray) -> np.ndarray:
        """Body coordinates of a world point of the reference state."""
        return self.axes @ (np.asarray(point, float) - self.position)

    def local_direction(self, d: np.ndarray) -> np.ndarray:
        return self.axes @ np.asarray(d, float)


@dataclass
class SpatialJoint:
    kind: str  # one of JOINT_KINDS
    body: str
    point: np.ndarray  # world point in the reference state [m]
    axis: np.ndarray | None = None  # unit world axis in the reference state (revolute, prismatic)
    other: str | None = None  # the second body (None: the ground, or a member for pin/rigid)
    member: str | None = None
    at: Any = None


def _inertia(path: str, v: Any) -> np.ndarray:
    a = np.asarray(v, dtype=float) if not isinstance(v, (str, bytes)) else np.zeros(0)
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise fail(path, "must be 3 principal moments or a symmetric 3x3 tensor (body axes) [kg m^2]", v)
    scale = float(np.max(np.abs(a)))
    if scale == 0 or np.max(np.abs(a - a.T)) > 1e-12 * scale:
        raise fail(path, "must be a symmetric, non-zero 3x3 tensor", v)
    w = np.linalg.eigvalsh(a)
    if w[0] <= 0:
        raise fail(path, f"must be positive definite (eigenvalues {w.tolist()})", v)
    if w[2] > w[0] + w[1] + 1e-12 * scale:
        raise fail(path, f"violates the triangle inequality of principal moments (largest {w[2]:g} > "
                   f"{w[0]:g} + {w[1]:g}): no mass distribution has it", v)
    return 0.5 * (a + a.T)


def _axes(path: str, v: Any) -> np.ndarray:
    if v is None:
        return np.eye(3)
    a = np.asarray(v, dtype=float) if not isinstance(v, (str, bytes)) else np.zeros(0)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise fail(path, "must be 3 rows: the body's x, y, z axes in world components", v)
    if np.max(np.abs(a @ a.T - np.eye(3))) > ORTHONORMAL_TOL or np.linalg.det(a) < 0:
        raise fail(path, "must be orthonormal and right-handed (rows x, y, z with z = x cross y)", v)
    return a


def make_body(scene, name: str, mass: Any, inertia: Any, position: Any, axes: Any = None,
              force: Any = None) -> SpatialBody:
    """A checked spatial body (refused before any work: no or non-positive mass, an inertia that is not symmetric
    positive definite or breaks the triangle inequality, axes that are not a rotation, a taken name)."""
    if not isinstance(name, str) or not name or name in scene.bodies or name in scene.members:
        raise fail("body.name", "must be a new non-empty string (not a member's or another body's)", name)
    p = "body"
    if mass is None:
        raise fail(f"{p}.mass", "is required (a body without mass has no dynamics)", mass)
    m = number(f"{p}.mass", mass, positive=True)
    if inertia is None:
        raise fail(f"{p}.inertia", "is required", inertia)
    return SpatialBody(name, m, _inertia(f"{p}.inertia", inertia), vector(f"{p}.position", position, 3),
                       _axes(f"{p}.axes", axes), np.zeros(3) if force is None else vector(f"{p}.force", force, 3))


def _unit(path: str, v: Any) -> np.ndarray:
    a = vector(path, v, 3)
    n = float(np.linalg.norm(a))
    if n == 0:
        raise fail(path, "must be a non-zero vector", v)
    return a / n


def make_joint(scene, kind: str, body: str, point: Any = None, axis: Any = None, other: str | None = None,
               member: str | None = None, at: Any = None) -> SpatialJoint:
    """A checked spatial joint: spherical / revolute / prismatic of `body` to the ground or to body `other`, at the
    world `point` (default the body's centre) about/along the world `axis`; pin / rigid: the node `at` of
    `member` tied to the body point where it lies."""
    if kind not in JOINT_KINDS:
        raise fail("joint.kind", f"must be one of {' | '.join(JOINT_KINDS)}", kind)
    if body not in scene.bodies:
        raise fail(f"{kind}.body", f"names no body; bodies: {sorted(scene.bodies)}", body)
    b = scene.bodies[body]
    if kind in ("pin", "rigid"):
        scene.check_at(member, at, node_only=True, field_name=f"{kind}.at")
        return SpatialJoint(kind, body, np.zeros(3), member=member, at=at)
    if other is not None and (other not in scene.bodies or other == body):
        raise fail(f"{kind}.other", f"must name another body; bodies: {sorted(scene.bodies)}", other)
    pt = b.position.copy() if point is None else vector(f"{kind}.point", point, 3)
    ax = None
    if kind in ("revolute", "prismatic"):
        if axis is None:
            raise fail(f"{kind}.axis", "is required in 3D (a world direction)", axis)
        ax = _unit(f"{kind}.axis", axis)
    return SpatialJoint(kind, body, pt, ax, other)


# -- coordinates -----------------------------------------------------------------------------------------------
def state(x: np.ndarray, offset: int) -> tuple[np.ndarray, np.ndarray]:
    """(centre, axes) of a body: axes rows are its x, y, z axes in world components."""
    q = np.asarray(x[offset:offset + BODY_SIZE], float)
    return q[:3].copy(), q[3:].reshape(3, 3).copy()


def angular_velocity(x: np.ndarray, v: np.ndarray, offset: int) -> np.ndarray:
    """omega = 1/2 sum_k e_k x e_k' (exact for orthonormal axes: e_k' = omega x e_k)."""
    E = np.asarray(x[offset + 3:offset + BODY_SIZE], float).reshape(3, 3)
    Ed = np.asarray(v[offset + 3:offset + BODY_SIZE], float).reshape(3, 3)
    return 0.5 * np.cross(E, Ed).sum(axis=0)


def sensor(x: np.ndarray, v: np.ndarray, offset: int) -> np.ndarray:
    """The "body" sensor of a spatial body: centre (3), angular velocity (3, world), axes e1, e2, e3 (9)."""
    r, E = state(x, offset)
    return np.concatenate([r, angular_velocity(x, v, offset), E.ravel()])


def mass_triplets(scene, off: dict[str, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, cols, values) of every body's constant mass matrix diag(m, m, m) + C (x) I_3 (C: second moment)."""
    rows, cols, vals = [], [], []
    for name, b in scene.bodies.items():
        o = off[name]
        rows.append(o + np.arange(3))
        cols.append(o + np.arange(3))
        vals.append(np.full(3, b.mass))
        C = b.second_moment
        k, l, c = np.meshgrid(np.arange(3), np.arange(3), np.arange(3), indexing="ij")
        rows.append((o + 3 + 3 * k + c).ravel())
        cols.append((o + 3 + 3 * l + c).ravel())
        vals.append(C[k, l].ravel())
    if not rows:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals).astype(float)


def add_loads(scene, off: dict[str, int], Q: np.ndarray) -> None:
    """Gravity m g and the dead force at each centre of mass into the generalized force Q (potential -Q.x)."""
    for name, b in scene.bodies.items():
        Q[off[name]:off[name] + 3] += b.mass * np.asarray(scene.gravity, float) + b.force


# -- constraint rows (ancf_sym.bodies.rows) ------------------------------------------------------------------
def direction(o: int, a: np.ndarray) -> Vec:
    """World vector of the body-fixed direction a: sum_k a_k e_k."""
    return Vec([{o + 3 + 3 * k + c: float(a[k]) for k in range(3)} for c in range(3)])


def point(o: int, s: np.ndarray) -> Vec:
    """World position of the body point s (body coordinates): r + sum_k s_k e_k."""
    return coords(range(o, o + 3)) + direction(o, s)


def constraint_rows(rows, mesh) -> None:
    """Exact rows of every body: its orthonormal axes, then its joints (linear or bilinear)."""
    scene = mesh.scene
    for name, o in mesh.bodies.items():
        for i, j in PAIRS:
            dot(rows, direction(o, np.eye(3)[i]), direction(o, np.eye(3)[j]), float(i == j), f"axes {name}", "slope")
    for j in scene.body_joints:
        _joint_rows(rows, mesh, j)


def _joint_rows(rows, mesh, j: SpatialJoint) -> None:
    scene = mesh.scene
    b, o = scene.bodies[j.body], mesh.bodies[j.body]
    if j.kind in ("pin", "rigid"):
        mm = mesh.members[j.member]
        node = mm.node(j.at)
        dofs = mm.node_dofs(node)
        x0 = mm.x0[node].reshape(-1, 3)  # r, r_x (, r_y, r_z)
        label = f"{j.kind} {j.body}-{j.member}@{j.at}"
        equal(rows, coords(dofs[:3]), point(o, b.local(x0[0])), label)
        if j.kind == "rigid" and mm.member.element == "beam3d":
            for g in range(1, 4):  # every gradient turns with the body: r_g = sum_k (E0 r_g0)_k e_k
                equal(rows, coords(dofs[3 * g:3 * g + 3]), direction(o, b.local_direction(x0[g])), label, "slope")
        elif j.kind == "rigid":  # a cable's slope stays along the body-fixed reference tangent (twist is free)
            t = x0[1] / np.linalg.norm(x0[1])
            for n in normals(t):
                dot(rows, coords(dofs[3:6]), direction(o, b.local_direction(n)), 0.0, label, "slope")
        return
    pa, pb, dir_a, dir_b, label = body_sides(mesh, j, point, direction)
    if j.kind in ("spherical", "revolute"):
        equal(rows, pa, pb, label)
        if j.kind == "revolute":  # the first body's axis stays normal to the second's two normals of it
            for n in normals(j.axis):
                dot(rows, dir_a(j.axis), dir_b(n), 0.0, label, "slope")
        return
    # prismatic: the relative orientation fixed by three rows g_i(a) . g_j(b) = 0 (independent: they measure the
    # three components of a small relative rotation), and the point moves along the axis only
    g = [j.axis] + normals(j.axis)
    for i, k in ((1, 2), (2, 0), (0, 1)):
        dot(rows, dir_a(g[i]), dir_b(g[k]), 0.0, label, "slope")
    for n in g[1:]:  # (p_a - p_b) . n_b = 0, n_b the second body's normals of the axis
        dot(rows, pa - pb, dir_b(n), 0.0, label, "position")


# -- angle drives (ancf_sym.bodies.drives): the angle of a revolute joint ---------------------------------------------
def drive_joint(scene, body: str, relative_to: str | None, field: str) -> SpatialJoint:
    """The revolute joint between `body` and `relative_to` (None: the ground) whose angle a drive prescribes;
    refused (naming `field`) when there is none or more than one."""
    found = [j for j in scene.body_joints if j.kind == "revolute" and {j.body, j.other} == {body, relative_to}]
    other = repr(relative_to) if relative_to else "the ground"
    if len(found) != 1:
        raise fail(field, f"a spatial body's angle drive turns it about a revolute joint's axis: needs exactly one "
                   f"revolute joint between {body!r} and {other} (declare it first), found {len(found)}", body)
    return found[0]


def drive_vectors(mesh, j: SpatialJoint, body: str, relative_to: str | None) -> tuple[Vec, Vec, Vec]:
    """(u, w1, w2), affine in the coordinates: the normal n1 of the joint axis t fixed in `body`, and n1, n2 fixed
    in `relative_to` (the ground if None; t, n1, n2 right-handed, as in the reference state). While the revolute
    rows keep the two axes parallel, u = cos(angle) w1 + sin(angle) w2 with angle the rotation of `body` about t
    relative to the other side (0 in the reference state): u . w2 = sin(angle), u . w1 = cos(angle), bilinear."""
    scene = mesh.scene
    n1, n2 = normals(j.axis)

    def fixed(name: str | None, d: np.ndarray) -> Vec:
        return const(d) if name is None else direction(mesh.bodies[name], scene.bodies[name].local_direction(d))

    return fixed(body, n1), fixed(relative_to, n1), fixed(relative_to, n2)
