"""Coarse-mesh start for fine meshes: the scene meshed COARSE_FACTOR times coarser, solved, and its solution
interpolated onto the fine mesh with the cable's own cubic Hermite shape functions (exact: every fine element lies
inside one coarse element, whose cubic it reproduces). Newton then continues on the fine mesh.

Why: the reduced tangent's condition number grows like n^2 (axial against global bending stiffness) to n^4, and on
paper 000's cantilever eps x cond passes 1 between 10 000 and 100 000 elements: from the straight beam the first
Newton update at 100 000 elements came out 0.004 instead of 2.54 (tip slope) and the iterations crawled. The
long-wave shape is what the coarse mesh resolves well (the tip converges like h^4: 10 000 and 100 000 elements give
the same tip to ~1e-15 relative); the fine mesh only adds short-wave corrections, for which its tangent is accurate.
Measured (bench/STATICS_RESULTS.md), paper 000's cantilever: 100 000 elements from a 10 000-element start converge
in 1-3 Newton iterations, the tip within 3e-12 m of the converged one (Newton from the straight beam: refused);
20 000 elements 0.25 s instead of 55 (Biot) / 106 (Green) iterations and 2.3 / 4.9 s from the straight beam; from
2000 elements up the solve is 1.3 - 2.7x faster than from the straight beam (8-12 iterations there), hence
COARSE_ABOVE.

Scenes it applies to: straight open cable members (a polyline's vertices, closed loops and beam3d sections would
need more than the centreline), no rigid bodies and no contacts; members of at least COARSE_ABOVE elements are
coarsened, and their element counts must be divisible by COARSE_FACTOR (so that every node a support, joint or load
names is a node of the coarse mesh). Elsewhere there is no coarse start.
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ancf_sym.model.assembly import Assembly
from ancf_sym.elements.hermite import weights
from ancf_sym.scene.builder import Scene

COARSE_ABOVE = 2000  # elements of a member from which the coarse start is used (measured, module docstring)
COARSE_FACTOR = 10


def _coarse_at(at: Any, m, factor: int) -> Any:
    """A location of the fine member on the coarse one; None if a node index is not a coarse node."""
    if not isinstance(at, (int, np.integer)) or isinstance(at, bool):
        return at  # 'start', 'end', a material coordinate
    i = int(at) % m.n_nodes
    return i // factor if i % factor == 0 else None


def coarse_scene(scene: Scene) -> Scene | None:
    """The scene with its long members meshed COARSE_FACTOR times coarser, or None where there is no coarse start
    (no member that long, or a scene the module docstring excludes)."""
    long = {name for name, m in scene.members.items() if m.elements >= COARSE_ABOVE}
    if scene.contacts:
        return None
    return coarsened(scene, long, COARSE_FACTOR)


def coarsened(scene: Scene, long: set, factor: int) -> Scene | None:
    """The scene with the members named in `long` meshed `factor` times coarser, or None where that is not a
    coarse start (no such member, rigid bodies, drives, a polyline, closed or beam3d member, an element count not
    divisible by `factor`, a support, load or joint at a node the coarse mesh lacks). Contacts are kept as declared
    (their points per element follow the mesh)."""
    if not long or scene.bodies or scene.body_joints or scene.drives:
        return None
    for name in long:
        m = scene.members[name]
        if m.closed or len(m.points) != 2 or not m.element.startswith("cable") or m.elements % factor:
            return None
    c = copy.deepcopy(scene)
    for name in long:
        c.members[name].elements //= factor

    def place(member: str, at: Any) -> Any:
        return _coarse_at(at, scene.members[member], factor) if member in long else at

    for item in c.supports + c.loads + c.point_masses:
        if item.at is not None:
            item.at = place(item.member, item.at)
            if item.at is None:
                return None
    for j in c.joints:
        j.a, j.b = (j.a[0], place(*j.a)), (j.b[0], place(*j.b))
        if j.a[1] is None or j.b[1] is None:
            return None
    return c


def interpolate(coarse: Assembly, x_coarse: np.ndarray, fine: Assembly) -> np.ndarray:
    """Full coordinates of the fine assembly from a coarse solution: every node's position and slope from the
    coarse element around its material coordinate (Hermite interpolation, exact for the coarse cubic)."""
    x = fine.x0.copy()
    dim = fine.scene.dim
    for name, mf in fine.mesh.members.items():
        mc = coarse.mesh.members[name]
        xn = coarse.member_coordinates(x_coarse, name)
        ends = np.cumsum(mc.elem_length)
        e = np.minimum(np.searchsorted(ends, mf.s_node - 1e-12 * ends[-1]), len(ends) - 1)
        lc = mc.elem_length[e]
        xi = np.clip((mf.s_node - (ends[e] - lc)) / lc, 0.0, 1.0)
        w, wx, _ = weights(xi, lc)
        n0, n1 = mc.elem_nodes[e].T
        c = (xn[n0, :dim], xn[n0, dim:2 * dim], xn[n1, :dim], xn[n1, dim:2 * dim])
        r = sum(w[k][:, None] * c[k] for k in range(4))
        rx = sum(wx[k][:, None] * c[k] for k in range(4))
        x[mf.offset:mf.offset + mf.x0.size] = np.hstack([r, rx]).ravel()
    return x
