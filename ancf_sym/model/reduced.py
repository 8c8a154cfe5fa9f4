"""Reduced coordinates of a scene: the unknowns left once the exact supports and joints that fix or identify
coordinates are eliminated, x_full = E y + c.

Exact rows 'x_i = d' (pins, clamps of axis-aligned members) fix coordinates; rows 'x_i - x_j = d' (hinges,
coincident joints) identify coordinates (one unknown for the group); the remaining exact rows (rigid joints, skew
clamps) keep Lagrange multipliers. ReducedModel is the one set-up of them that the statics Newton and the step system of every dynamics scheme build
on (the control model and the modal linearisation read the same cached partition).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.util import setup_cache
from ancf_sym.model.assembly import Assembly
from ancf_sym.scene.builder import SceneError
from ancf_sym.util.sparsity import index_dtype


@dataclass
class Partition:
    """Unknowns of a scene: x_full = E y + c.

    Exact rows 'x_i = d' fix coordinates (eliminated); rows 'x_i - x_j = d' (hinges, coincident joints)
    identify coordinates (one unknown for the group); the remaining exact rows keep Lagrange multipliers."""
    E: sp.csc_matrix  # (n, ny) 0/1 map from unknowns to coordinates
    c: np.ndarray  # (n,) fixed values and identification offsets
    roots: np.ndarray  # (ny,) the coordinate that represents each unknown
    pos: np.ndarray  # (n,) unknown of each coordinate, -1 if fixed
    rows: np.ndarray  # exact rows kept with multipliers (indices into asm.exact)
    fixed: np.ndarray  # fixed coordinates
    n_identified: int  # coordinates merged into another one

    @property
    def ny(self) -> int:
        return len(self.roots)

    def reduce_matrix(self, A: sp.spmatrix, B: sp.spmatrix | np.ndarray | None = None) -> sp.csc_matrix:
        """E^T A E (a mass or stiffness matrix on the unknowns), or E^T A B (its coupling to other coordinates)."""
        if B is None and not self.n_identified:  # E selects coordinates: the entries of free rows and columns
            return self._select(A)
        R = (self.E.T @ A @ (self.E if B is None else sp.csc_matrix(B))).tocsc()
        R.sort_indices()
        return R


    def reduce_vector(self, f: np.ndarray) -> np.ndarray:
        """E^T f (a generalized force on the unknowns): f at the unknowns' coordinates where nothing is identified
        (each column of E holds a single 1: the product's sums have one term each, the same numbers)."""
        if not self.n_identified:
            return np.asarray(f, dtype=float)[self.roots]
        return self.E.T @ f

    def _select(self, A: sp.spmatrix) -> sp.csc_matrix:
        """E^T A E where every unknown is one coordinate (no identifications): A's entries in free rows and columns,
        renumbered (pos is increasing on the free coordinates, so sorted columns stay sorted; no sums): the result
        of the sparse products E^T A E, entry for entry."""
        if not (sp.issparse(A) and A.format == "csc" and A.has_canonical_format):  # (else A as it is: no copy)
            A = sp.csc_matrix(A)
            A.sum_duplicates()  # (canonical: sorted, duplicates summed)
        pos = self.pos
        cols = np.repeat(np.arange(A.shape[1]), np.diff(A.indptr))
        keep = (pos[A.indices] >= 0) & (pos[cols] >= 0)
        counts = np.bincount(pos[cols[keep]], minlength=self.ny)
        indptr = np.zeros(self.ny + 1, dtype=A.indptr.dtype)
        np.cumsum(counts, out=indptr[1:])
        R = sp.csc_matrix((A.data[keep], pos[A.indices[keep]].astype(A.indices.dtype), indptr),
                          shape=(self.ny, self.ny))
        R.eliminate_zeros()  # (as the sparse products did: the element mass matrices' zero entries are not stored)
        return R


def reduce_shared(part: Partition, A: sp.spmatrix) -> sp.csc_matrix:
    """part.reduce_matrix(A), kept (read-only) when the partition and A both come from ancf_sym.util.setup_cache (their
    keys are then the exact inputs of the result: the mass matrix of a second run of the same structure)."""
    ka, kp = setup_cache.key_of(A), setup_cache.key_of(part)
    if ka is None or kp is None:
        return part.reduce_matrix(A)
    return setup_cache.cached("reduced_matrix", (ka, kp), lambda: part.reduce_matrix(A))


def full_mx(y: ca.MX, pos: np.ndarray, c: np.ndarray) -> ca.MX:
    """The scene coordinates x = E y + c as a gather (coordinate k is unknown pos[k], or fixed where pos[k] < 0):
    the element gathers that follow merge with it into one, where a product with E would cost a sparse product at
    every evaluation. Control passes the unknowns [q; s] with the moved support coordinates as unknowns too."""
    x = ca.vertcat(y, ca.MX.zeros(1))[np.where(pos >= 0, pos, y.shape[0]).tolist()]
    return x + ca.DM(c) if np.any(c) else x


def partition(asm: Assembly) -> Partition:
    """The reduced coordinates of an assembly's exact constraints (see Partition). Kept by the exact inputs it reads
    (the constraint rows and the number of coordinates; ancf_sym.util.setup_cache): shared, read-only, by the scenes
    with the same supports and joints."""
    ex = asm.exact
    key = setup_cache.array_key(asm.n, ex.A, ex.d, ex.qrow, ex.qi, ex.qj)
    return setup_cache.cached("partition", key, lambda: _partition(ex, asm.n))


def _partition(ex, n: int) -> Partition:
    A = ex.A.tocsr()
    nnz_row = np.diff(A.indptr)
    has_quad = np.zeros(ex.m, bool)
    has_quad[ex.qrow] = True
    parent = np.arange(n)
    off = np.zeros(n)  # x_k = x_parent + off_k

    def find(k):
        path = []
        while parent[k] != k:
            path.append(k)
            k = parent[k]
        root, acc = k, 0.0
        for node in reversed(path):  # compress, accumulating offsets from the root down
            acc += off[node]
            off[node] = acc
            parent[node] = root
        return root

    def value(k):
        r = find(k)
        return r, (off[k] if k != r else 0.0)

    keep_rows = []
    tol = lambda v: 1e-12 * (1.0 + abs(v))
    # identifications x_i - x_j = d first, then fixes
    ident = [r for r in range(ex.m) if nnz_row[r] == 2 and not has_quad[r]
             and abs(A.data[A.indptr[r]] + A.data[A.indptr[r] + 1]) <= 1e-14 * abs(A.data[A.indptr[r]])]
    ident_set = set(ident)
    for r in ident:
        (i, j), (ai, _) = A.indices[A.indptr[r]:A.indptr[r + 1]], A.data[A.indptr[r]:A.indptr[r + 1]]
        d = ex.d[r] / ai  # x_i - x_j = d
        ri, oi = value(int(i))
        rj, oj = value(int(j))
        if ri == rj:
            if abs(oi - oj - d) > tol(d):
                keep_rows.append(r)  # inconsistent cycle: leave it to a multiplier (the scene is then infeasible)
            continue
        parent[rj] = ri
        off[rj] = oi - d - oj
    fixed_val: dict[int, float] = {}
    for r in range(ex.m):
        if nnz_row[r] == 1 and not has_quad[r]:
            c = int(A.indices[A.indptr[r]])
            v = float(ex.d[r] / A.data[A.indptr[r]])
            root, o = value(c)
            rv = v - o
            if root in fixed_val and abs(fixed_val[root] - rv) > tol(rv):
                raise SceneError(f"constraint {ex.labels[r]!r} fixes coordinate {c} to {v!r}, which other supports "
                                 f"or joints fix to {fixed_val[root] + o!r}")
            fixed_val[root] = rv
        elif r not in ident_set:
            keep_rows.append(r)
    # (numpy over all coordinates; Python only for the identified ones: a mesh of 1000 elements has 4000)
    roots_all = np.arange(n)
    for k in np.flatnonzero(parent != roots_all):
        roots_all[k] = find(int(k))  # (compresses: off[k] is then the offset from the root)
    offs = np.where(roots_all != np.arange(n), off, 0.0)
    fixed_roots = np.fromiter(fixed_val, dtype=np.int64, count=len(fixed_val))
    fixed_at = np.zeros(n)
    fixed_at[fixed_roots] = np.fromiter(fixed_val.values(), dtype=float, count=len(fixed_val))
    is_fixed = np.zeros(n, bool)
    is_fixed[fixed_roots] = True
    is_fixed = is_fixed[roots_all]
    c = offs + np.where(is_fixed, fixed_at[roots_all], 0.0)
    identified = bool(np.any(roots_all != np.arange(n)))
    free_roots = np.unique(roots_all[~is_fixed]) if identified else np.flatnonzero(~is_fixed)
    ymap = -np.ones(n, dtype=np.int64)
    ymap[free_roots] = np.arange(len(free_roots))
    pos = np.where(is_fixed, -1, ymap[roots_all])
    rows_e = np.flatnonzero(pos >= 0)
    if identified:
        E = sp.csc_matrix((np.ones(len(rows_e)), (rows_e, pos[rows_e])), shape=(n, len(free_roots)))
    else:  # one coordinate per unknown, in order: the CSC arrays directly (in SciPy's own index type: no checks)
        it = index_dtype(n)
        E = sp.csc_matrix((np.ones(len(rows_e)), rows_e.astype(it), np.arange(len(rows_e) + 1, dtype=it)),
                          shape=(n, len(free_roots)))
    keep = np.array(sorted(set(keep_rows)), dtype=np.int64)
    # rows whose coordinates are all fixed are redundant once the coordinates are eliminated
    if len(keep):
        touch = []
        for r in keep:
            cols = A.indices[A.indptr[r]:A.indptr[r + 1]]
            qc = np.r_[ex.qi[ex.qrow == r], ex.qj[ex.qrow == r]]
            touch.append(bool(np.any(pos[np.r_[cols, qc].astype(np.int64)] >= 0)))
        keep = keep[np.array(touch, bool)]
    return Partition(E, c, free_roots, pos, keep, np.flatnonzero(is_fixed), int(np.sum(~is_fixed) - len(free_roots)))


class ReducedModel:
    """The reduced coordinates an analysis works on, set up once from an assembly: the partition (supports that fix
    coordinates eliminated, hinges identified), the number of kept constraint rows, the constant generalized force
    of the linear terms (gravity, dead loads), the scales, and the maps between the unknowns and the scene's
    coordinates. The statics Newton works on one; the step system (ancf_sym.system.step_system) is one, with its
    graphs."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        self.coordinates(partition(asm), asm)
        self.f_lin_full = f_lin = asm.constant_force()
        self.f_lin = self.part.reduce_vector(f_lin)

    def coordinates(self, part: Partition, asm: Assembly) -> None:
        """The partition's unknowns and the assembly's scales."""
        self.part = part
        self.E = part.E
        self.nf = part.ny
        self.pos = part.pos
        self.mc = len(part.rows)
        self.gather = np.where(part.pos >= 0, part.pos, self.nf)  # full coordinate k = ext[gather[k]], ext[nf] = 0
        self.length_scale = asm.mesh.length_scale
        self.span = float(np.max(np.abs(asm.x0))) + 1.0
        self.is_position = position_unknowns(part, asm)

    def full(self, xf: np.ndarray) -> np.ndarray:
        """Coordinates of the scene from the unknowns."""
        return self.full_v(xf) + self.part.c

    def full_v(self, vf: np.ndarray) -> np.ndarray:
        """E vf: every coordinate is one unknown or fixed (a gather, cheaper than the sparse product)."""
        vf = np.asarray(vf, dtype=float)
        if vf.ndim != 1:
            return self.E @ vf
        ext = np.empty(self.nf + 1)
        ext[:-1], ext[-1] = vf, 0.0
        return ext[self.gather]

    def full_rows(self, Q: np.ndarray) -> np.ndarray:
        """`full` of each row of Q (k x nf): the scene coordinates as rows (k x n)."""
        return self.full_v_rows(Q) + self.part.c

    def full_v_rows(self, V: np.ndarray) -> np.ndarray:
        """`full_v` of each row of V (k x nf), as rows (k x n)."""
        ext = np.zeros((len(V), self.nf + 1))
        ext[:, :-1] = V
        return ext.take(self.gather, axis=1)

    def reduce(self, x_full: np.ndarray) -> np.ndarray:
        """Unknowns from scene coordinates (that satisfy the eliminated constraints)."""
        return np.asarray(x_full)[self.part.roots].copy()

    def reduce_force(self, f_full: np.ndarray) -> np.ndarray:
        """Generalized force on the unknowns (E^T f)."""
        return self.part.reduce_vector(f_full) if np.ndim(f_full) == 1 else self.E.T @ f_full


def position_unknowns(part: Partition, asm: Assembly) -> np.ndarray:
    """Per unknown: True where it is a position [m] (a node's, a rigid body's centre), False for the gradients and a
    body's unit axis vectors [-] (as statics.criteria.coordinate_scales)."""
    dim = asm.scene.dim
    full = np.zeros(asm.n, dtype=bool)
    for mm in asm.mesh.members.values():
        k = np.arange(mm.x0.size)
        full[mm.offset + k[k % mm.node_size < dim]] = True
    for o in asm.mesh.bodies.values():
        full[o:o + dim] = True
    mask = np.zeros(part.ny, dtype=bool)
    free = part.pos >= 0
    np.logical_or.at(mask, part.pos[free], full[free])
    return mask
