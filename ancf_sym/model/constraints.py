"""Supports and joints as equality constraints c(x) = A x + sum_k coef_k x_i x_j - d = 0.

Every support and joint of this package is linear or quadratic (sums of products x_i x_j) in the nodal coordinates,
so c, its Jacobian and its Hessian are exact sparse arrays without any symbolic work at run time:
- pin: r = r0; clamp: pin + slope direction (n . r_x = 0 for each normal n of the reference slope; beam3d:
  all gradients fixed); fix_slope: the slope part alone;
- hinge: r_a = r_b (beam3d with an axis: + the relative rotations normal to it); rigid: hinge + the relative slope
  direction (planar: (R t_a) x t_b = 0 with R the reference rotation from t_a to t_b; beam3d: the relative rotation
  of the two node frames, three rows that see rotations only (_frame_rows); a beam3d and a cable3d member: the
  cable's slope direction in the beam's frame; cable3d polyline corners: the angle between the slopes).
The penalty form of paper 002 adds 1/2 k c^2 per row instead (k from EA/(1 m) for positions, EI/(1 m) for slopes).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ancf_sym.bodies import rows as affine_rows, planar as bodies, spatial as spatial_bodies
from ancf_sym.util import setup_cache
from ancf_sym.model.mesh import Mesh, MemberMesh


@dataclass
class Rows:
    """A growing set of constraint rows."""
    n: int
    lin: list = field(default_factory=list)  # (row, col, coef)
    quad: list = field(default_factory=list)  # (row, i, j, coef)
    d: list = field(default_factory=list)
    label: list = field(default_factory=list)  # what each row enforces
    kind: list = field(default_factory=list)  # "position" | "slope" (sets the penalty scale)
    k: list = field(default_factory=list)  # penalty stiffness, or 0 for exact rows

    def row(self, coefs: dict, d: float, label: str, kind: str, quad: list | None = None) -> None:
        r = len(self.d)
        self.lin += [(r, c, v) for c, v in coefs.items() if v != 0]
        self.quad += [(r, i, j, v) for i, j, v in (quad or [])]
        self.d.append(d)
        self.label.append(label)
        self.kind.append(kind)


def _normals(t: np.ndarray) -> list[np.ndarray]:
    return [np.array([-t[1], t[0]])] if len(t) == 2 else affine_rows.normals(t)


def _slices(mm: MemberMesh, node: int, dim: int):
    """Global indices of r, r_x (and r_y, r_z for beam3d) at a node."""
    dofs = mm.node_dofs(node)
    return [dofs[k * dim:(k + 1) * dim] for k in range(mm.node_size // dim)]


def _fix(rows: Rows, idx, values, label, kind):
    for i, v in zip(idx, values):
        rows.row({int(i): 1.0}, float(v), label, kind)


def support_rows(rows: Rows, mesh: Mesh, s) -> None:
    mm = mesh.members[s.member]
    dim = mesh.scene.dim
    node = mm.node(s.at)
    parts = _slices(mm, node, dim)
    ref = mm.x0[node].reshape(-1, dim)
    label = f"{s.kind} {s.member}@{s.at}"
    if s.kind in ("pin", "clamp"):
        _fix(rows, parts[0], ref[0], label, "position")
    if s.kind in ("clamp", "slope"):
        if mm.member.element == "beam3d" and s.kind == "clamp":
            for p, rv in zip(parts[1:], ref[1:]):
                _fix(rows, p, rv, label, "slope")
        else:
            for n in _normals(ref[1] / np.linalg.norm(ref[1])):
                rows.row({int(i): float(v) for i, v in zip(parts[1], n)}, 0.0, label, "slope")


def joint_rows(rows: Rows, dim: int, ma: MemberMesh, na: int, mb: MemberMesh, nb: int, kind: str, label: str,
               axis: np.ndarray | None = None) -> None:
    """Rows of a hinge or rigid joint between internal node na of ma and nb of mb (a beam3d hinge with an axis:
    the relative rotations normal to it fixed)."""
    pa, pb = _slices(ma, na, dim), _slices(mb, nb, dim)
    gap = ma.x0[na][:dim] - mb.x0[nb][:dim]  # reference offset kept (zero for coincident nodes)
    for k in range(dim):
        rows.row({int(pa[0][k]): 1.0, int(pb[0][k]): -1.0}, float(gap[k]), label, "position")
    if kind == "hinge" and axis is not None:
        _frame_rows(rows, ma, pa, na, mb, pb, nb, label, affine_rows.normals(axis))
    if kind != "rigid":
        return
    if "beam3d" in (ma.member.element, mb.member.element):
        if mb.member.element != "beam3d":  # a cable side: the relative rotations normal to its slope
            basis = affine_rows.normals(mb.x0[nb][3:6] / np.linalg.norm(mb.x0[nb][3:6]))
        elif ma.member.element != "beam3d":
            basis = affine_rows.normals(ma.x0[na][3:6] / np.linalg.norm(ma.x0[na][3:6]))
        else:
            J0 = _gradients(ma, na).T
            basis = J0 / np.linalg.norm(J0, axis=1)[:, None]
        _frame_rows(rows, ma, pa, na, mb, pb, nb, label, basis)
    elif dim == 3:
        _cable3d_corner_rows(rows, ma.x0[na][3:6], mb.x0[nb][3:6], pa[1], pb[1], label)
    else:
        ta, tb = ma.x0[na][dim:2 * dim], mb.x0[nb][dim:2 * dim]
        ang = np.arctan2(ta[0] * tb[1] - ta[1] * tb[0], ta @ tb)
        c, s = np.cos(ang), np.sin(ang)
        R = np.array([[c, -s], [s, c]])
        # (R t_a) x t_b = (R t_a)_0 t_b1 - (R t_a)_1 t_b0, bilinear in (t_a, t_b)
        ia, ib = pa[1], pb[1]
        quad = [(int(ia[m]), int(ib[1]), R[0, m]) for m in range(2)] + [(int(ia[m]), int(ib[0]), -R[1, m]) for m in range(2)]
        rows.row({}, 0.0, label, "slope", quad)


def rotation_sensor(J0: np.ndarray, e: np.ndarray, method: str, section_b: float = 1.0, section_h: float = 1.0
                    ) -> np.ndarray:
    """(3, 3) gradient (columns: d/dr_x, d/dr_y, d/dr_z) of e . omega, the small rotation of a beam3d node's frame
    from its reference gradients J0 = [r_x r_y r_z], as each form defines that frame:
    - elastic_line: the bending part (normal to the tangent t) from the centre-line slope, t x dt, and the twist
      about t from the section vectors, (z . dr_y - y . dr_z) / 2 (the torsion kernel's twist). The elements bend
      through r_xx and twist through r_y, r_z; the slope-to-section shear is a local penalty (G A per element).
    - continuum: the section's rotation from r_y and r_z alone (about y: t . dr_z, about z: -t . dr_y): the
      continuum form bends through the section field (Timoshenko), the slope differs by the shear. Its twist weighs
      the turns of r_y and r_z as the section resists them (b^2 : h^2, the fibres' int y^2 dA : int z^2 dA), so a
      torque through the joint turns both alike instead of shearing the node's section (its G A, one element's).
    Neither sees a gradient's stretch, nor the tilt between slope and sections that the form resists only by one
    element's shear (elastic line: the sections' tilt; continuum: the slope's): a joint built from these sensors
    cannot be satisfied by such a local strain, whose stiffness vanishes with the element length."""
    s = np.linalg.norm(J0, axis=0)
    t, y, z = (J0 / s).T
    et = float(e @ t)
    if method == "elastic_line":
        g = [np.cross(e, t), et / 2 * z, -et / 2 * y]
    else:
        wy = section_b**2 / (section_b**2 + section_h**2)
        g = [np.zeros(3), et * wy * z - float(e @ z) * t, -et * (1 - wy) * y + float(e @ y) * t]
    return np.stack(g, axis=1) / s


def _gradients(mm: MemberMesh, node: int) -> np.ndarray:
    """(3, k) reference gradients of a 3D node: beam3d [r_x r_y r_z], cable3d [r_x]."""
    return mm.x0[node].reshape(-1, 3)[1:].T


def _sensor(mm: MemberMesh, J0: np.ndarray, e: np.ndarray) -> np.ndarray:
    m = mm.member
    if m.element != "beam3d":  # a cable's slope: e . omega for e normal to it
        return (np.cross(e, J0[:, 0]) / float(J0[:, 0] @ J0[:, 0]))[:, None]
    return rotation_sensor(J0, e, m.beam_method, m.section.b or 1.0, m.section.h or 1.0)


def _frame_rows(rows: Rows, ma: MemberMesh, pa, na: int, mb: MemberMesh, pb, nb: int, label: str, basis) -> None:
    """Rows fixing the components along `basis` (unit vectors; side a's three axes for a rigid joint, the two
    normals of a hinge's axis or of a cable side's slope) of the relative rotation of two node frames (beam3d; a
    cable3d side has its slope only) at their reference value.

    Each row is a sum of dot products of the nodes' gradients (so it is unchanged by any rigid rotation of the
    joint as a whole): sum M_ij a_i . b_j + A_ij a_i . a_j + B_ij b_i . b_j = its reference value, with a_i, b_j the
    columns of J_a, J_b. Its gradient at the reference state is the sensor e . (omega_a - omega_b) of the two
    frames (rotation_sensor, each side's own form), for e along each basis vector: the rows measure independent
    components of the relative rotation, and no strain of either node. Solved for (M, A, B) by least squares,
    checked exact."""
    Ja0, Jb0 = _gradients(ma, na), _gradients(mb, nb)
    ka, kb = Ja0.shape[1], Jb0.shape[1]
    # unknowns M (ka x kb), A (ka x ka), B (kb x kb), row-major; d/da_i = sum_j M_ij b_j + (A_ij + A_ji) a_j, ...
    oA, oB = ka * kb, ka * kb + ka * ka
    K = np.zeros((3 * (ka + kb), oB + kb * kb))
    for i in range(ka):
        for j in range(kb):
            K[3 * i:3 * i + 3, i * kb + j] += Jb0[:, j]  # M_ij -> d/da_i
            K[3 * (ka + j):3 * (ka + j) + 3, i * kb + j] += Ja0[:, i]  # M_ij -> d/db_j
        for j in range(ka):
            K[3 * i:3 * i + 3, oA + i * ka + j] += Ja0[:, j]  # A_ij -> d/da_i
            K[3 * j:3 * j + 3, oA + i * ka + j] += Ja0[:, i]  # A_ij -> d/da_j
    for i in range(kb):
        for j in range(kb):
            K[3 * (ka + i):3 * (ka + i) + 3, oB + i * kb + j] += Jb0[:, j]
            K[3 * (ka + j):3 * (ka + j) + 3, oB + i * kb + j] += Jb0[:, i]
    for e in basis:
        g = np.r_[_sensor(ma, Ja0, e).T.ravel(), -_sensor(mb, Jb0, e).T.ravel()]
        coef = np.linalg.lstsq(K, g, rcond=None)[0]
        if np.linalg.norm(K @ coef - g) > 1e-9 * np.linalg.norm(g):  # the sensors disagree on a rigid rotation
            raise AssertionError(f"{label}: no objective row measures this relative rotation")
        blocks = ((coef[:oA].reshape(ka, kb), pa, pb, Ja0, Jb0), (coef[oA:oB].reshape(ka, ka), pa, pa, Ja0, Ja0),
                  (coef[oB:].reshape(kb, kb), pb, pb, Jb0, Jb0))
        quad, d = [], 0.0
        for C, P, Q, X, Y in blocks:
            for i in range(C.shape[0]):
                for j in range(C.shape[1]):
                    if abs(C[i, j]) > 1e-14 * np.abs(coef).max():
                        quad += [(int(P[1 + i][k]), int(Q[1 + j][k]), float(C[i, j])) for k in range(3)]
                        d += C[i, j] * float(X[:, i] @ Y[:, j])
        rows.row({}, d, label, "slope", quad)


def _cable3d_corner_rows(rows: Rows, ta, tb, ia, ib, label: str) -> None:
    """A rigid corner of a cable3d polyline: a cable has no section vectors, so all a corner of two slopes can tie is
    the angle between them (the corner's plane may turn about either side's axis: a cable carries no torsion).
    Row r_a . r_b - cos0 / 2 (s_b / s_a |r_a|^2 + s_a / s_b |r_b|^2) = 0: unchanged by rigid rotations, blind to
    either slope's stretch, it measures the relative rotation about t_a x t_b. Collinear sides (no angle to
    measure): the slopes are equal, as at an inner node."""
    sa, sb = np.linalg.norm(ta), np.linalg.norm(tb)
    cos0 = float(ta @ tb) / (sa * sb)
    if 1.0 - abs(cos0) < 1e-9:
        for k in range(3):
            rows.row({int(ib[k]): 1.0, int(ia[k]): -float(np.sign(cos0)) * sb / sa}, 0.0, label, "slope")
        return
    quad = [(int(ia[k]), int(ib[k]), 1.0) for k in range(3)]
    quad += [(int(ia[k]), int(ia[k]), -cos0 / 2 * sb / sa) for k in range(3)]
    quad += [(int(ib[k]), int(ib[k]), -cos0 / 2 * sa / sb) for k in range(3)]
    rows.row({}, 0.0, label, "slope", quad)


def _penalty_scale(mm: MemberMesh, kind: str) -> float:
    """Paper 002's references: EA/L for positions, EI/L for slopes, with L = 1 m."""
    m = mm.member
    EA = m.material.E * m.section.area
    EI = m.material.E * (m.section.bending_inertia or 0.0)
    return EA if kind == "position" else (EI if EI > 0 else EA * 1e-6)


@dataclass
class Constraints:
    """c(x) = A x + sum_k coef_k x_i x_j - d; rows with k > 0 are penalties, the others exact."""
    A: sp.csr_matrix
    qrow: np.ndarray
    qi: np.ndarray
    qj: np.ndarray
    qcoef: np.ndarray
    d: np.ndarray
    k: np.ndarray
    labels: list

    @property
    def m(self) -> int:
        return len(self.d)

    def value(self, x: np.ndarray) -> np.ndarray:
        c = self.A @ x - self.d
        if len(self.qrow):  # bilinear rows (rigid joints' slope rows)
            c += np.bincount(self.qrow, self.qcoef * x[self.qi] * x[self.qj], minlength=self.m)
        return c

    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        n = self.A.shape[1]
        Q = sp.coo_matrix((np.r_[self.qcoef * x[self.qj], self.qcoef * x[self.qi]],
                           (np.r_[self.qrow, self.qrow], np.r_[self.qi, self.qj])), shape=(self.m, n))
        return (self.A + Q).tocsr()

    def hessian(self, lam: np.ndarray) -> sp.csr_matrix:
        """Hessian of lam . c(x) (constant: the constraints are at most bilinear)."""
        n = self.A.shape[1]
        v = lam[self.qrow] * self.qcoef
        return sp.coo_matrix((np.r_[v, v], (np.r_[self.qi, self.qj], np.r_[self.qj, self.qi])), shape=(n, n)).tocsr()

    def subset(self, rows: np.ndarray) -> "Constraints":
        rows = np.asarray(rows, dtype=int)
        remap = -np.ones(self.m, dtype=int)
        remap[rows] = np.arange(len(rows))
        keep = remap[self.qrow] >= 0
        return Constraints(_take_rows(self.A, rows), remap[self.qrow[keep]], self.qi[keep], self.qj[keep], self.qcoef[keep],
                           self.d[rows], self.k[rows], [self.labels[r] for r in rows])


def _take_rows(A: sp.csr_matrix, rows: np.ndarray) -> sp.csr_matrix:
    """A[rows] of a CSR matrix (each row's stored entries in their order), by numpy gathers: SciPy's fancy row
    indexing costs ~70 us whatever the size, a set-up step of every run."""
    A = A.tocsr()
    counts = np.diff(A.indptr)[rows]
    indptr = np.zeros(len(rows) + 1, dtype=A.indptr.dtype)
    np.cumsum(counts, out=indptr[1:])
    take = np.repeat(A.indptr[rows] - indptr[:-1], counts) + np.arange(indptr[-1], dtype=A.indptr.dtype)
    return sp.csr_matrix((A.data[take], A.indices[take], indptr), shape=(len(rows), A.shape[1]))


def _csr(lin: list, m: int, n: int) -> sp.csr_matrix:
    """The CSR matrix of (row, col, value) entries, columns sorted in each row: what coo_matrix(...).tocsr() gives,
    without its conversions (~110 us a run), and kept by the exact entries (ancf_sym.util.setup_cache: shared,
    read-only, by the scenes with the same supports and joints)."""
    a = np.array(lin, dtype=float).reshape(-1, 3)
    return setup_cache.cached("constraint_matrix", setup_cache.array_key(a, m, n), lambda: _csr_of(a, m, n))


def _csr_of(a: np.ndarray, m: int, n: int) -> sp.csr_matrix:
    r, c = a[:, 0].astype(np.int64), a[:, 1].astype(np.int64)
    o = np.lexsort((c, r))
    key = r[o] * n + c[o]
    if len(key) > 1 and np.any(key[1:] == key[:-1]):
        return sp.coo_matrix((a[:, 2], (r, c)), shape=(m, n)).tocsr()
    idx = np.int32 if max(m, n, len(key)) < 2 ** 31 - 1 else np.int64
    indptr = np.zeros(m + 1, dtype=idx)
    np.cumsum(np.bincount(r, minlength=m), out=indptr[1:])
    return sp.csr_matrix((a[o, 2], c[o].astype(idx), indptr), shape=(m, n))


def build_constraints(mesh: Mesh) -> Constraints:
    rows = Rows(mesh.n)
    scene, dim = mesh.scene, mesh.scene.dim

    def close(start: int, method: str, factor, mm: MemberMesh):
        pos, slope = (factor, factor) if not isinstance(factor, (list, tuple, np.ndarray)) else factor
        for r in range(start, len(rows.d)):
            f = pos if rows.kind[r] == "position" else slope
            rows.k.append((f or 1.0) * _penalty_scale(mm, rows.kind[r]) if method == "penalty" else 0.0)

    for s in scene.supports:
        start = len(rows.d)
        support_rows(rows, mesh, s)
        close(start, s.method, s.penalty, mesh.members[s.member])
    for j in scene.joints:
        start = len(rows.d)
        ma, mb = mesh.members[j.a[0]], mesh.members[j.b[0]]
        label = f"{j.kind} {j.a[0]}@{j.a[1]}-{j.b[0]}@{j.b[1]}"
        joint_rows(rows, dim, ma, ma.node(j.a[1]), mb, mb.node(j.b[1]), j.kind, label, j.axis)
        close(start, j.method, j.penalty, ma)
    for name, mm in mesh.members.items():
        for a, b in mm.vertex_pairs:
            start = len(rows.d)
            joint_rows(rows, dim, mm, a, mm, b, "rigid", f"vertex {name}#{a}")
            close(start, "exact", None, mm)
    (spatial_bodies if dim == 3 else bodies).constraint_rows(rows, mesh)
    m = len(rows.d)
    A = _csr(rows.lin, m, mesh.n)
    q = np.array(rows.quad, dtype=float).reshape(-1, 4)
    return Constraints(A, q[:, 0].astype(int), q[:, 1].astype(int), q[:, 2].astype(int), q[:, 3],
                       np.array(rows.d, float), np.array(rows.k, float), rows.label)
