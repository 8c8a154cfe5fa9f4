"""Planar rigid bodies and their joints, in natural coordinates.

A body's unknowns are q_b = (x, y, c, s): its centre of mass and the unit vector u = (cos angle, sin angle) of its
body-fixed x axis, tied by the exact constraint c^2 + s^2 = 1. This choice (natural coordinates) fits the scene's
assembly without any new kernel:
- kinetic energy 1/2 m |r_dot|^2 + 1/2 J (c_dot^2 + s_dot^2), and c_dot^2 + s_dot^2 = angle_dot^2 exactly: the mass
  matrix diag(m, m, J, J) is constant, like the ANCF members' (no velocity-dependent inertia forces);
- gravity and a force at the centre are linear in q_b: a constant generalized force (the dead-load vector);
- a body point r_b + R(u) p (R = [[c, -s], [s, c]], p body-fixed) is linear in q_b, so a revolute joint to the
  ground and a pin to a member node are linear constraint rows, and a rigid body-member joint (the member's slope
  turns with the body) is bilinear: all exact, with exact constant Jacobian/Hessian structure, through the same
  constraint layer as the supports (ancf_sym.model.constraints). No angle wraps or singular orientations. A revolute
  joint between two bodies is linear too; a prismatic joint (to the ground or a body) is bilinear (ancf_sym.bodies.rows).
Spatial bodies, in the same natural-coordinate spirit, are ancf_sym.bodies.spatial.
So plain numpy is their home: nothing here needs symbolic differentiation or generated code.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ancf_sym.bodies.rows import Vec, body_sides, dot
from ancf_sym.util.checks import SceneError, number

BODY_SIZE = 4  # x, y, cos(angle), sin(angle)


@dataclass
class Body:
    name: str
    mass: float  # [kg]
    inertia: float  # about the centre of mass [kg m^2]
    position: np.ndarray  # centre of mass in the reference state [m]
    angle: float  # reference angle [rad]
    force: np.ndarray  # dead force at the centre of mass [N]

    @property
    def q0(self) -> np.ndarray:
        return np.array([*self.position, math.cos(self.angle), math.sin(self.angle)])

    def local(self, point: np.ndarray) -> np.ndarray:
        """Body-fixed coordinates of a world point given in the reference state."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        d = np.asarray(point, float) - self.position
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


@dataclass
class BodyJoint:
    kind: str  # "revolute" (body-ground or body-body) | "prismatic" (slides along axis, no relative turn) |
    # "pin" (body-member node) | "rigid" (pin + member slope turns with body)
    body: str
    point: np.ndarray  # world point of the joint in the reference state [m]
    member: str | None = None
    at: Any = None
    other: str | None = None  # revolute / prismatic: the second body (None: the ground)
    axis: np.ndarray | None = None  # prismatic: unit sliding direction (world, reference state)


def _vec2(field_name: str, v: Any) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float).ravel()
    except (TypeError, ValueError):
        raise SceneError(f"{field_name} must be 2 numbers, got {v!r}") from None
    if a.size != 2 or not np.all(np.isfinite(a)):
        raise SceneError(f"{field_name} must be 2 finite numbers, got {v!r}")
    return a


def make_body(scene, name: str, mass: Any, inertia: Any, position: Any, angle: Any = 0.0,
              force: Any = None) -> Body:
    """A checked Body (refused before any work: no mass, non-positive inertia, a 3D scene, a taken name)."""
    if scene.dim != 2:
        raise SceneError(f"body {name!r}: rigid bodies are planar (x, y, angle); the scene is {scene.dim}D")
    if not isinstance(name, str) or not name or name in scene.bodies or name in scene.members:
        raise SceneError(f"body name must be a new non-empty string (not a member's), got {name!r}")
    if mass is None:
        raise SceneError(f"body {name!r}: mass is required (a body without mass has no dynamics)")
    m = number(f"body {name!r}: mass", mass, positive=True)
    if inertia is None:
        raise SceneError(f"body {name!r}: inertia is required")
    J = number(f"body {name!r}: inertia", inertia, positive=True)
    pos = _vec2(f"body {name!r}: position", position)
    ang = number(f"body {name!r}: angle", angle)
    F = np.zeros(2) if force is None else _vec2(f"body {name!r}: force", force)
    return Body(name, m, J, pos, ang, F)


def make_joint(scene, kind: str, body: str, point: Any = None, member: str | None = None, at: Any = None,
               other: str | None = None, axis: Any = None) -> BodyJoint:
    """A checked body joint. revolute: `point` (world, reference state; default the centre of mass) pinned to the
    ground or, with `other`, to that body. prismatic: the body slides along the world `axis` through `point`
    without turning, relative to the ground or to body `other`. pin / rigid: the member node `at` tied to the body
    point where the node lies in the reference state."""
    if body not in scene.bodies:
        raise SceneError(f"{kind}.body={body!r} names no body; bodies: {sorted(scene.bodies)}")
    b = scene.bodies[body]
    if kind in ("revolute", "prismatic"):
        if other is not None and (other not in scene.bodies or other == body):
            raise SceneError(f"{kind}.other={other!r} must name another body; bodies: {sorted(scene.bodies)}")
        p = b.position.copy() if point is None else _vec2(f"{kind}.point", point)
        ax = None
        if kind == "prismatic":
            ax = _vec2(f"{kind}.axis", axis)
            if not np.linalg.norm(ax) > 0:
                raise SceneError(f"prismatic.axis must be a non-zero vector, got {axis!r}")
            ax = ax / np.linalg.norm(ax)
        return BodyJoint(kind, body, p, other=other, axis=ax)
    if kind not in ("pin", "rigid"):
        raise SceneError(f"body joint kind must be 'revolute', 'prismatic', 'pin' or 'rigid', got {kind!r}")
    scene.check_at(member, at, node_only=True, field_name=f"{kind}.at")
    if kind == "rigid" and scene.members[member].element != "cable2d":
        raise SceneError(f"rigid body joint on member {member!r}: planar cable members only")
    return BodyJoint(kind, body, np.zeros(2), member, at)


# -- coordinates -----------------------------------------------------------------------------------------------
def state(x: np.ndarray, offset: int) -> tuple[float, float, float]:
    """(x, y, angle) of a body from the global coordinates (angle by atan2 of the unit vector: no wrap-around)."""
    q = np.asarray(x[offset:offset + BODY_SIZE], float)
    return float(q[0]), float(q[1]), float(math.atan2(q[3], q[2]))


def mass_entries(scene, off: dict[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """(indices, values) of the diagonal mass matrix diag(m, m, J, J) of every body."""
    idx, val = [], []
    for name, b in scene.bodies.items():
        idx.append(off[name] + np.arange(BODY_SIZE))
        val.append([b.mass, b.mass, b.inertia, b.inertia])
    if not idx:
        return np.zeros(0, int), np.zeros(0)
    return np.concatenate(idx), np.concatenate(val).astype(float)


def add_loads(scene, off: dict[str, int], Q: np.ndarray) -> None:
    """Gravity m g and the dead force at each centre of mass into the generalized force Q (potential -Q.x)."""
    for name, b in scene.bodies.items():
        Q[off[name]:off[name] + 2] += b.mass * np.asarray(scene.gravity, float) + b.force


def _point_coefs(o: int, p: np.ndarray, k: int, sign: float) -> dict:
    """Coefficients of sign * (component k of the body point r_b + R(u) p) on the body's coordinates."""
    if k == 0:  # x + c p0 - s p1
        return {o: sign, o + 2: sign * p[0], o + 3: -sign * p[1]}
    return {o + 1: sign, o + 2: sign * p[1], o + 3: sign * p[0]}  # y + s p0 + c p1


def constraint_rows(rows, mesh) -> None:
    """Exact rows of every body: the unit vector's c^2 + s^2 = 1, then its joints (linear or bilinear)."""
    scene = mesh.scene
    for name, o in mesh.bodies.items():
        rows.row({}, 1.0, f"unit {name}", "slope", [(o + 2, o + 2, 1.0), (o + 3, o + 3, 1.0)])
        rows.k.append(0.0)
    for j in scene.body_joints:
        b, o = scene.bodies[j.body], mesh.bodies[j.body]
        if j.kind == "prismatic":
            _prismatic_rows(rows, mesh, j)
            continue
        if j.kind == "revolute":
            p = b.local(j.point)
            for k in range(2):
                coefs = _point_coefs(o, p, k, 1.0)
                if j.other is None:
                    rows.row(coefs, float(j.point[k]), f"revolute {j.body}", "position")
                else:  # the two bodies' points coincide: linear in both bodies' coordinates
                    oo, bo = mesh.bodies[j.other], scene.bodies[j.other]
                    for c, v in _point_coefs(oo, bo.local(j.point), k, -1.0).items():
                        coefs[c] = coefs.get(c, 0.0) + v
                    rows.row(coefs, 0.0, f"revolute {j.body}-{j.other}", "position")
                rows.k.append(0.0)
            continue
        mm = mesh.members[j.member]
        node = mm.node(j.at)
        dofs = mm.node_dofs(node)
        r0 = mm.x0[node][:2]
        p = b.local(r0)
        label = f"{j.kind} {j.body}-{j.member}@{j.at}"
        for k in range(2):  # r_node - (r_b + R p) = 0
            coefs = _point_coefs(o, p, k, -1.0)
            coefs[int(dofs[k])] = 1.0
            rows.row(coefs, 0.0, label, "position")
            rows.k.append(0.0)
        if j.kind == "rigid":
            # the slope r_x stays parallel to R(u) t, t its body-fixed reference direction: r_x x (R t) = 0,
            # R t = (c t0 - s t1, s t0 + c t1), bilinear in (r_x, u)
            t0 = mm.x0[node][2:4]
            t = b.local(b.position + t0 / np.linalg.norm(t0))
            ix, iy = int(dofs[2]), int(dofs[3])
            quad = [(ix, o + 3, t[0]), (ix, o + 2, t[1]), (iy, o + 2, -t[0]), (iy, o + 3, t[1])]
            rows.row({}, 0.0, label, "slope", quad)
            rows.k.append(0.0)


def _point(o: int, p: np.ndarray) -> Vec:
    """World position of the body point p (body coordinates): r + R(u) p, affine in (x, y, c, s)."""
    return Vec([_point_coefs(o, p, k, 1.0) for k in range(2)])


def _direction(o: int, a: np.ndarray) -> Vec:
    """World vector R(u) a of the body-fixed direction a."""
    return Vec([{o + 2: a[0], o + 3: -a[1]}, {o + 2: a[1], o + 3: a[0]}])


def _prismatic_rows(rows, mesh, j: BodyJoint) -> None:
    """A prismatic joint to the ground or a body (ancf_sym.bodies.rows): the body's x axis stays normal to the other
    side's normal of it (no relative turn), and the joint point moves along the axis only: (p_a - p_b) . n_b = 0."""
    pa, pb, dir_a, dir_b, label = body_sides(mesh, j, _point, _direction)
    u0 = np.array([math.cos(mesh.scene.bodies[j.body].angle), math.sin(mesh.scene.bodies[j.body].angle)])
    dot(rows, dir_a(u0), dir_b(np.array([-u0[1], u0[0]])), 0.0, label, "slope")
    dot(rows, pa - pb, dir_b(np.array([-j.axis[1], j.axis[0]])), 0.0, label, "position")


def connected_supported(scene) -> set[str]:
    """Bodies held by a joint to the ground (revolute, prismatic; 3D also spherical), directly or through joints
    between bodies, and the members tied to them (for the statics check). Planar and spatial bodies alike."""
    held = {j.body for j in scene.body_joints if j.kind in ("spherical", "revolute", "prismatic") and j.other is None}
    grew = True
    while grew:
        grew = False
        for j in scene.body_joints:
            if j.other is not None and (j.body in held) != (j.other in held):
                held |= {j.body, j.other}
                grew = True
    return held | {j.member for j in scene.body_joints if j.member is not None and j.body in held}
