"""Drums carried by spatial rigid bodies (3D scenes): cable3d and beam3d centre lines against a cylinder fixed in a
body (ancf_sym.bodies.spatial: coordinates r, e1, e2, e3), a wheel, a sprocket's pitch circle or a pulley.

The drum is declared in world coordinates of the reference state, like the spatial joints: a point on its axis
(default the body's centre) and the axis direction (default the body's z axis); both are stored in body components
(s, a), so in any state the axis is a = sum a_k e_k through the point r + sum s_k e_k, linear in the body's
coordinates. The kernels <element>_contact_body_drum (normal law) and <element>_contact_body_drum_friction (damping
and regularised Coulomb friction, with the drum surface's velocity r' + sum_k (e_k . (x - r)) e_k' at the contact
point x: the body's spin about the drum axis and its tumbling) take the element's coordinates followed by the
body's 12 (ancf_sym.elements.contact); their forces act on the member and on the body, with exact tangents.
The drum is an infinite cylinder: a scene whose member should not touch a body's drum (the left chain and the
right wheels) simply does not declare that contact.
"""
from __future__ import annotations

from typing import Any

import numpy as np

BODY_SIZE = 12  # ancf_sym.bodies.spatial.BODY_SIZE


def geometry(scene, body: str, centre: Any, axis: Any) -> tuple[Any, Any]:
    """(centre, axis) in world coordinates of the reference state, with the defaults of a spatial body's drum: its
    centre of mass, its z axis (checked as vectors by ancf_sym.contact.drum)."""
    b = scene.bodies[body]
    return (b.position if centre is None else centre), (b.axes[2] if axis is None else axis)


def call(c, mesh, friction: bool) -> tuple[str, np.ndarray, np.ndarray]:
    """(effect, idx (N, kernel input), P (N, parameters)) of a spatial body's drum: idx the element's coordinates
    and the body's; P in registry order (L, k, kh, t, R, a (body components)[, c, mu, eps], s (body components))."""
    mm = mesh.members[c.member]
    idx, L = mm.elem_dofs(), mm.elem_length
    b, o = mesh.scene.bodies[c.body], mesh.bodies[c.body]
    idx = np.hstack([idx, np.tile(np.arange(o, o + BODY_SIZE), (len(idx), 1))])
    row = [c.stiffness, c.hertz, c.thickness, c.radius, *b.local_direction(c.axis)]
    row += [c.damping, c.mu, c.eps] if friction else []
    row += list(b.local(c.centre))
    P = np.column_stack([L, np.tile(row, (len(L), 1))])
    return ("contact_body_drum_friction" if friction else "contact_body_drum"), idx, P


def pose(c, asm, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(centre, axis) of a body-carried drum in the state x: planar, the body's centre (axis None: z); spatial, the
    axis point r + sum s_k e_k and the axis sum a_k e_k."""
    o = asm.mesh.bodies[c.body]
    x = np.asarray(x, float)
    if asm.scene.dim == 2:
        return x[o:o + 2], None
    b = asm.scene.bodies[c.body]
    E = x[o + 3:o + BODY_SIZE].reshape(3, 3)
    return x[o:o + 3] + E.T @ b.local(c.centre), E.T @ b.local_direction(c.axis)


def poses(c, asm, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """pose of a spatial body's drum in each of the states X (S, n): centres (S, 3) and axes (S, 3)."""
    o = asm.mesh.bodies[c.body]
    b = asm.scene.bodies[c.body]
    E = np.asarray(X, float)[:, o + 3:o + BODY_SIZE].reshape(-1, 3, 3)  # rows e1, e2, e3
    return X[:, o:o + 3] + np.einsum("ski,k->si", E, b.local(c.centre)), \
        np.einsum("ski,k->si", E, b.local_direction(c.axis))
