"""Mesh members into elements: global coordinate numbering and the reference (straight, unstretched) state.

Each member owns its nodes; a polyline member gets one run of nodes per straight segment, the vertex nodes
duplicated and tied by internal rigid joints. Node coordinates: cables [r, r_x], beam3d [r, r_x, r_y, r_z].
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ancf_sym.util import setup_cache
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.elements.hermite import weights
from ancf_sym.registry import ELEMENTS
from ancf_sym.scene.builder import Member, Scene, SceneError


MIN_ELEMENT_FRACTION = 1e-6  # shortest element allowed, as a fraction of its member's length
MIN_STRETCH = 1e-3  # smallest |r_x| accepted in a given state (the reference has |r_x| = 1 + prestrain)


def node_size(element: str) -> int:
    return ELEMENTS[element].ndof // 2


@dataclass
class MemberMesh:
    member: Member
    offset: int  # first global coordinate of the member
    node_size: int
    x0: np.ndarray  # (n_nodes, node_size) reference nodal coordinates
    elem_nodes: np.ndarray  # (n_el, 2) node indices (member-local) of each element
    elem_length: np.ndarray  # (n_el,) reference length [m]
    public_nodes: np.ndarray  # public node index -> internal node (vertex duplicates are hidden)
    vertex_pairs: list[tuple[int, int]]  # internal nodes tied rigidly at polyline vertices
    s_node: np.ndarray  # (n_nodes,) material coordinate of each internal node [m]
    length: float = 0.0  # the member's unstretched length [m] (Member.length, kept with the geometry it reads)

    @property
    def n_nodes(self) -> int:
        return len(self.x0)

    def node_dofs(self, node: int) -> np.ndarray:
        return self.offset + node * self.node_size + np.arange(self.node_size)

    def elem_dofs(self) -> np.ndarray:
        """(n_el, 2*node_size) global coordinate indices per element."""
        ns = self.node_size  # (one broadcast: element e's start node's coordinates, then its end node's)
        return (self.offset + self.elem_nodes[:, :, None] * ns + np.arange(ns)).reshape(len(self.elem_nodes), 2 * ns)

    def node(self, at) -> int:
        """Internal node index of a public location: 'start', 'end' or a public node index."""
        if at == "start":
            return 0
        if at == "end":
            return self.n_nodes - 1
        return int(self.public_nodes[at])

    def coordinate(self, at) -> float:
        """Material coordinate s [m] of a location: a float is s itself; 'start', 'end' or a public node index give
        that node's coordinate (check the location first: Scene.check_at)."""
        return float(at) if isinstance(at, float) else float(self.s_node[self.node(at)])

    def locate(self, s: float) -> tuple[int, float]:
        """(element, xi) of material coordinate s [m]."""
        ends = np.cumsum(self.elem_length)
        e = int(min(np.searchsorted(ends, s - 1e-12 * ends[-1]), len(ends) - 1))
        start = ends[e] - self.elem_length[e]
        return e, float(np.clip((s - start) / self.elem_length[e], 0.0, 1.0))


def _frame(t: np.ndarray, y_axis: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Section axes y, z orthonormal to the axis t: the given y projected, else z-up convention."""
    if y_axis is None:
        y = np.cross([0.0, 0.0, 1.0], t) if abs(t[2]) < 0.9 else np.cross(t, [1.0, 0.0, 0.0])
    else:
        y = y_axis - np.dot(y_axis, t) * t
        if np.linalg.norm(y) < 1e-9:
            raise SceneError(f"y_axis={y_axis.tolist()} is parallel to the member axis {t.tolist()}")
    y = y / np.linalg.norm(y)
    return y, np.cross(t, y)


def mesh_closed(m: Member, offset: int) -> MemberMesh:
    """A loop: node k at points[k] with slope (1 + prestrain) tangents[k], element k from node k to node k+1 (the
    last to node 0), all of reference length loop_length / (elements (1 + prestrain)). An open arc alike, with its
    elements + 1 nodes and no element closing it."""
    n, stretch = m.elements, 1.0 + m.prestrain
    if not m.closed:
        return _mesh_arc(m, offset)
    rows = []
    for r, t in zip(m.points, m.tangents):
        if m.element == "beam3d":
            y, z = _frame(t, m.y_axis)
            rows.append(np.concatenate([r, stretch * t, y, z]))
        else:
            rows.append(np.concatenate([r, stretch * t]))
    le = m.loop_length / n / stretch
    nodes = np.arange(n)
    return MemberMesh(m, offset, node_size(m.element), np.array(rows), np.c_[nodes, (nodes + 1) % n],
                      np.full(n, le), nodes, [], nodes * le, m.length)


def _mesh_arc(m: Member, offset: int) -> MemberMesh:
    rows = np.hstack([m.points, (1.0 + m.prestrain) * m.tangents])
    le = m.loop_length / m.elements / (1.0 + m.prestrain)
    nodes = np.arange(m.elements + 1)
    return MemberMesh(m, offset, node_size(m.element), rows, np.c_[nodes[:-1], nodes[1:]],
                      np.full(m.elements, le), nodes, [], nodes * le, m.length)


def mesh_member(m: Member, offset: int) -> MemberMesh:
    """The member's nodes and elements from `offset` on. The geometry is kept by the exact member fields it reads
    (ancf_sym.util.setup_cache: shared, read-only, by members that differ only in material or section)."""
    key = setup_cache.array_key(m.closed, m.points, m.elements, m.element, m.prestrain, m.y_axis, m.tangents,
                                m.loop_length, m.arc_curvature)
    g = setup_cache.cached("member_mesh", key, lambda: _mesh_member(m, 0))
    return MemberMesh(m, offset, g.node_size, g.x0, g.elem_nodes, g.elem_length, g.public_nodes,
                      list(g.vertex_pairs), g.s_node, g.length)


def _mesh_member(m: Member, offset: int) -> MemberMesh:
    if m.tangents is not None:  # a loop, or an open arc (its nodes and tangents sampled: Scene.arc)
        return mesh_closed(m, offset)
    pts = m.points
    seg_len = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    nseg = len(seg_len)
    # elements per segment proportional to length, at least one each, summing to m.elements
    share = np.maximum(1, np.round(m.elements * seg_len / seg_len.sum()).astype(int))
    while share.sum() > m.elements:
        share[np.argmax(share)] -= 1
    while share.sum() < m.elements:
        share[np.argmax(seg_len / share)] += 1
    el_len = seg_len / share
    k = int(np.argmin(el_len))
    if el_len[k] < MIN_ELEMENT_FRACTION * seg_len.sum():
        # a nearly degenerate element: its stiffness (EA/l, EI/l^3) would swamp every other in double precision
        raise SceneError(f"member {m.name!r}: segment {k} is meshed into elements of length {el_len[k]:.3g} m, "
                         f"below {MIN_ELEMENT_FRACTION:g} x the member length {seg_len.sum():.6g} m (nearly "
                         "degenerate elements); merge nearly coincident points or use fewer elements")
    ns = node_size(m.element)
    stretch = 1.0 + m.prestrain  # geometric / reference length
    rows, elem_nodes, elem_len, public, pairs, s_nodes = [], [], [], [], [], []
    s0, first = 0.0, 0
    for k in range(nseg):  # (whole segments at once: equal elements along a straight segment)
        t = (pts[k + 1] - pts[k]) / seg_len[k]
        if k > 0:
            pairs.append((first - 1, first))
        j = np.arange(share[k] + 1)
        r = pts[k] + (t * seg_len[k])[None, :] * j[:, None] / share[k]
        frame = [stretch * t] + (list(_frame(t, m.y_axis)) if m.element == "beam3d" else [])
        rows.append(np.hstack([r] + [np.broadcast_to(f, (len(j), len(f))) for f in frame]))
        s_nodes.append(s0 + seg_len[k] * j / share[k] / stretch)
        public.append(first + (j if k == 0 else j[1:]))
        e = np.arange(share[k])
        elem_nodes.append(np.stack([first + e, first + e + 1], axis=1))
        elem_len.append(np.full(share[k], seg_len[k] / share[k] / stretch))
        s0 += seg_len[k] / stretch
        first += share[k] + 1
    rows, elem_nodes, elem_len = np.vstack(rows), np.vstack(elem_nodes), np.concatenate(elem_len)
    public, s_nodes = np.concatenate(public), np.concatenate(s_nodes)
    return MemberMesh(m, offset, ns, rows, elem_nodes, elem_len, public, pairs, s_nodes, m.length)


def check_stretch(mesh: "Mesh", x: np.ndarray, what: str) -> None:
    """Refuse a state `x` (full coordinates) in which an element has (nearly) collapsed: |r_x| < MIN_STRETCH at a
    node or, for cables, at one of 5 Gauss points. No material compresses to 0.1 % of its length, and the kernels'
    1/|r_x| (Biot, decoupled strain) and |r_x|^-6 (curvature) factors make such a state a numerical singularity."""
    xi = np.concatenate([[0.0], gauss01(5)[0], [1.0]])
    d = mesh.scene.dim
    for name, mm in mesh.members.items():
        X = np.asarray(x[mm.offset:mm.offset + mm.x0.size], float).reshape(mm.n_nodes, mm.node_size)
        a, b = mm.elem_nodes[:, 0], mm.elem_nodes[:, 1]
        if mm.member.element.startswith("cable"):  # r_x(xi) of the cubic Hermite interpolation
            wx = weights(xi[None, :, None], mm.elem_length[:, None, None])[1]  # (4, n_el, points, 1)
            rx = (wx[0] * X[a, None, :d] + wx[1] * X[a, None, d:2 * d] + wx[2] * X[b, None, :d]
                  + wx[3] * X[b, None, d:2 * d])
        else:
            rx = np.stack([X[a, d:2 * d], X[b, d:2 * d]], axis=1)
        nrm = np.linalg.norm(rx, axis=2)  # (n_el, points)
        e, p = np.unravel_index(int(np.argmin(nrm)), nrm.shape)
        if nrm[e, p] < MIN_STRETCH:
            where = "at its start node" if p == 0 else "at its end node" if p == nrm.shape[1] - 1 else \
                f"at xi = {xi[p]:.3f}"
            raise SceneError(f"{what}: member {name!r}, element {e}: |r_x| = {nrm[e, p]:.3g} {where} is below "
                             f"{MIN_STRETCH:g} (a collapsed, degenerate element; the reference state has |r_x| = "
                             f"{1 + mm.member.prestrain:g})")


@dataclass
class Mesh:
    scene: Scene
    members: dict[str, MemberMesh]
    n: int  # number of global coordinates
    bodies: dict = field(default_factory=dict)  # body name -> offset of its coordinates (after the members'):
    # planar (x, y, c, s), spatial (r, e1, e2, e3)

    @property
    def x0(self) -> np.ndarray:
        x = np.zeros(self.n)
        for mm in self.members.values():
            x[mm.offset:mm.offset + mm.x0.size] = mm.x0.ravel()
        for name, o in self.bodies.items():
            q0 = self.scene.bodies[name].q0
            x[o:o + len(q0)] = q0
        return x

    @property
    def length_scale(self) -> float:
        """The longest member's length [m]; in a scene of rigid bodies alone, their joints' reach (at least 1 m)."""
        if self.members:
            return max(float(mm.length) for mm in self.members.values())
        reach = [float(np.linalg.norm(j.point - self.scene.bodies[j.body].position)) for j in self.scene.body_joints]
        return max(reach + [1.0])


def build_mesh(scene: Scene) -> Mesh:
    members, offset = {}, 0
    for name, m in scene.members.items():
        mm = mesh_member(m, offset)
        members[name] = mm
        offset += mm.x0.size
    body_offsets = {}  # empty without bodies: a scene without bodies keeps its unknowns
    for name, b in scene.bodies.items():
        body_offsets[name] = offset
        offset += len(b.q0)
    return Mesh(scene, members, offset, body_offsets)


class Probe:
    """Linear maps from the full coordinates x to r, r_x, r_xx at material coordinate s of a member: idx (dim, 4)
    global coordinates (r(0), r_x(0), r(L), r_x(L) per component) and the weights w, wx, wxx (4,)."""

    def __init__(self, mm: MemberMesh, s: float, dim: int):
        e, xi = mm.locate(s)
        n0, n1 = mm.elem_nodes[e]
        ns = mm.node_size
        self.dim = dim
        base0, base1 = mm.offset + n0 * ns, mm.offset + n1 * ns
        self.idx = np.array([[base0 + k, base0 + dim + k, base1 + k, base1 + dim + k] for k in range(dim)])
        self.w, self.wx, self.wxx = weights(xi, mm.elem_length[e])

    def r(self, x):
        return x[self.idx] @ self.w

    def rx(self, x):
        return x[self.idx] @ self.wx

    def rxx(self, x):
        return x[self.idx] @ self.wxx
