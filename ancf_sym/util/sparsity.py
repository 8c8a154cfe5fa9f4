"""Sparse patterns from (row, col) triplets, merged in compressed-column order (SciPy's and CasADi's layout), and
the gathers and scatters that assemble compiled kernel results into global vectors and matrices inside CasADi graphs
(the dynamics' step system and the optimal-control model and transcription alike)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.util.mx_ops import add, reshape, vec


def index_dtype(n: int) -> type:
    """SciPy's own index type for a matrix of dimension n (int32 below 2^31 - 1): index arrays given in it are taken
    without a check of their contents."""
    return np.int32 if n < 2 ** 31 - 1 else np.int64


def csc_pattern(rows: np.ndarray, cols: np.ndarray, n_rows: int,
                n_cols: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, inv): the merged CSC pattern and, for triplet k, the index of its non-zero inv[k]."""
    key = np.asarray(cols, dtype=np.int64) * n_rows + np.asarray(rows, dtype=np.int64)
    order = np.argsort(key, kind="stable")
    sk = key[order]
    first = np.empty(sk.size, dtype=bool)  # (np.unique's result without its general-purpose checks)
    first[:1] = True
    np.not_equal(sk[1:], sk[:-1], out=first[1:])
    uniq = sk[first]
    inv = np.empty(sk.size, dtype=np.int64)
    inv[order] = np.cumsum(first) - 1
    indptr = np.zeros(n_cols + 1, dtype=np.int64)
    np.cumsum(np.bincount(uniq // n_rows, minlength=n_cols), out=indptr[1:])
    return indptr, uniq % n_rows, inv


def casadi_sparsity(n_rows: int, n_cols: int, indptr: np.ndarray, indices: np.ndarray) -> ca.Sparsity:
    """A CSC pattern as a CasADi Sparsity (from one list: ~40 % less conversion than the four-argument form)."""
    return ca.Sparsity.compressed([n_rows, n_cols] + np.asarray(indptr).tolist() + np.asarray(indices).tolist())


# -- assembling compiled kernel results in CasADi MX graphs (constant index maps, no products with 0/1 matrices) --

def _sorted_csc(A):
    """A as CSC with sorted row indices: A itself where it is one already (no copy, no format checks)."""
    if sp.issparse(A) and A.format == "csc" and A.has_sorted_indices:
        return A
    A = sp.csc_matrix(A)
    A.sort_indices()
    return A


def dm(A) -> ca.DM:
    """A SciPy sparse (or dense) matrix as a CasADi DM with the same pattern."""
    A = _sorted_csc(A)
    return ca.DM(casadi_sparsity(A.shape[0], A.shape[1], A.indptr, A.indices), A.data.tolist())


def kron_identity_factor(A, dims: tuple[int, ...] = (3, 2)) -> tuple[int, sp.csc_matrix] | None:
    """(d, B) with A = kron(B, I_d) exactly, for the first d of `dims` that fits, or None. A mass matrix of elements
    whose directions share their shape functions (cables: r = S(xi) q, M_e = (rho A int s s^T) x I_d) has this form
    on unknowns grouped by d, unless supports, joints or point masses break it. (Compared on the compressed columns:
    column d j + a must hold column d j's entries, rows shifted by a; O(nnz).)"""
    f = _kron_identity_parts(A, dims)
    if f is None:
        return None
    d, m, indptr, indices, data = f
    return d, sp.csc_matrix((data, indices, indptr), shape=(m, m))


def kron_factor_dm(A, dims: tuple[int, ...] = (3, 2)) -> tuple[int, ca.DM] | None:
    """kron_identity_factor's (d, B) with B as a CasADi DM, made from its compressed arrays (no SciPy matrix)."""
    f = _kron_identity_parts(A, dims)
    if f is None:
        return None
    d, m, indptr, indices, data = f
    return d, ca.DM(casadi_sparsity(m, m, indptr, indices), data.tolist())


def _kron_identity_parts(A, dims: tuple[int, ...]) -> tuple | None:
    """(d, m, indptr, indices, data) of B (m x m, sorted CSC) with A = kron(B, I_d), or None."""
    A = _sorted_csc(A)
    n = A.shape[0]
    for d in dims:
        if n % d or n < d or A.shape[1] != n:
            continue
        cnt = np.diff(A.indptr).reshape(-1, d)  # entries per column, by groups of d columns
        if (cnt != cnt[:, :1]).any():
            continue
        c0 = cnt[:, 0]
        grp = np.repeat(np.arange(n // d), c0)
        t = np.arange(c0.sum()) - np.repeat(np.cumsum(c0) - c0, c0)
        p0 = A.indptr[d * grp] + t
        rows0 = A.indices[p0]
        if (rows0 % d).any():
            continue
        if all((A.indices[A.indptr[d * grp + a] + t] == rows0 + a).all() and
               (A.data[A.indptr[d * grp + a] + t] == A.data[p0]).all() for a in range(1, d)):
            indptr = np.zeros(len(c0) + 1, dtype=A.indptr.dtype)  # (A's index type: no conversion, no checks)
            np.cumsum(c0, out=indptr[1:])
            return d, n // d, indptr, rows0 // d, A.data[p0]
    return None


def kron_product_mx(d: int, Bt: ca.DM, u: ca.MX) -> ca.MX:
    """kron(B, I_d) u as the product of u reshaped to d x n/d with Bt = B^T (a DM): one pass over B's nonzeros for
    all d directions (at d = 2 half the memory traffic of the product with the whole matrix, same sums in the same
    order)."""
    return vec(ca.mtimes(reshape(u, d, u.size1() // d), Bt))


GATHER_LEVELS = 8  # targets summing more entries than this are summed by one sparse product (gather_sum)
GATHER_SUBSET = 4  # gather_sum: a level with fewer than 1/4 of the targets updates those alone


def gather_sum(vals: list, target: np.ndarray, n_out: int) -> ca.MX:
    """out[t] = sum of the entries k of vertcat(vals) with target[k] = t (target -1: dropped), as a few gathers
    (one per multiplicity) and additions: cheaper in the MX virtual machine than a product with a 0/1 matrix.
    Each gather runs over all n_out targets, so the targets that sum more than GATHER_LEVELS entries (a body's
    coordinates in the contact blocks of every element on its drum: 48 on a 48-element belt) are summed instead by
    one product with a 0/1 sparse matrix, whose cost is their entries' count; scenes without such targets are summed
    exactly as before."""
    valid = np.flatnonzero(target >= 0)
    cnt = np.bincount(target[valid], minlength=n_out)
    if len(valid) and cnt.max() > GATHER_LEVELS:
        heavy = cnt[target[valid]] > GATHER_LEVELS
        hk = valid[heavy]
        light = target.copy()
        light[hk] = -1
        n_src = int(sum(v.numel() for v in vals))
        P = ca.DM(casadi_sparsity(n_out, n_src, *_csc_of(target[hk], hk, n_out, n_src)), 1.0)
        return add(gather_sum(vals, light, n_out), ca.densify(ca.mtimes(P, ca.vertcat(*vals))))
    src = ca.vertcat(*vals, ca.MX.zeros(1))
    n_src = src.shape[0] - 1
    t = target[valid]
    order = valid[np.argsort(t, kind="stable")]
    if not len(order):
        return ca.MX.zeros(n_out)
    start = np.cumsum(cnt) - cnt
    out = None
    for j in range(int(cnt.max())):
        many = cnt > j
        if out is not None and np.count_nonzero(many) * GATHER_SUBSET < n_out:
            # the few targets with a (j+1)-th term: updated alone (the same sums in the same order), where a full
            # gather would copy every target with a zero added (an element table's entries shared by many terms:
            # the tracked vehicle's element-wheel blocks, 10-20 levels over 158k entries)
            sel = np.flatnonzero(many)
            out[sel.tolist()] = add(out[sel.tolist()], src[order[start[sel] + j].tolist()])
            continue
        idx = np.where(many, order[np.minimum(start + j, len(order) - 1)], n_src)
        term = src[idx.tolist()]
        out = term if out is None else add(out, term)  # (ancf_sym.util.mx_ops: the + operator takes ~30 us to resolve)
    return out


def _csc_of(rows: np.ndarray, cols: np.ndarray, n_rows: int, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """(indptr, indices) of the n_rows x n_cols pattern with one entry per (rows[k], cols[k]), cols distinct."""
    order = np.argsort(cols, kind="stable")
    indptr = np.zeros(n_cols + 1, dtype=np.int64)
    np.add.at(indptr, cols + 1, 1)
    return np.cumsum(indptr), rows[order]


def scatter(vals: list, r: np.ndarray, c: np.ndarray, n: int, src: np.ndarray | None = None,
            n_src: int | None = None, n_cols: int | None = None) -> ca.MX:
    """Sparse n x n (or n x n_cols) MX summing the values at (r, c): entry k is vertcat(vals)[src[k]] (default:
    k; n_src = the length of vertcat(vals) when src is given)."""
    n_cols = n if n_cols is None else n_cols
    indptr, indices, inv = csc_pattern(r, c, n, n_cols)
    pattern = casadi_sparsity(n, n_cols, indptr, indices)
    if src is None:
        src, n_src = np.arange(len(inv)), len(inv)
    target = -np.ones(n_src, dtype=np.int64)
    target[src] = inv
    return ca.MX(pattern, gather_sum(vals, target, len(indices)))


def hessian_entries(pos: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unknowns (a, b) of the entries of the column-major vec of a mapped kernel's Hessian output (nd x nd N:
    entry e nd^2 + a nd + b is d2U / dx_idx[e, a] dx_idx[e, b]) and the entries on two unknowns (pos: the unknown
    of each coordinate, -1 if fixed)."""
    N, nd = idx.shape
    ia = pos[np.broadcast_to(idx[:, :, None], (N, nd, nd)).ravel()]
    ib = pos[np.broadcast_to(idx[:, None, :], (N, nd, nd)).ravel()]
    return ia, ib, np.flatnonzero((ia >= 0) & (ib >= 0))


def elements_key(idx: np.ndarray) -> tuple:
    """An exact key of an element table (N x nd coordinates): calls on equal tables act on the same elements."""
    return idx.shape, idx.tobytes()


def group_calls(calls: list) -> list:
    """Mapped kernel calls (idx, G, H or None) with those on the same elements summed, in the order first seen
    (H None where any of a group's is None)."""
    groups: dict = {}
    for idx, G, H in calls:
        key = elements_key(idx)
        if key in groups:
            grp = groups[key]
            grp[1] = grp[1] + G
            grp[2] = None if H is None or grp[2] is None else grp[2] + H
        else:
            groups[key] = [idx, G, H]
    return list(groups.values())


def assemble_mx(calls: list, pos: np.ndarray, n: int, hessian: bool = True) -> tuple[ca.MX, ca.MX | None]:
    """Gradient (n) and Hessian (n x n sparse) of a sum of mapped kernel calls on the unknowns, coordinate k of
    the scene being unknown pos[k] (-1: fixed, dropped). calls: (idx (N x nd) coordinates of the elements,
    G (nd x N), H (nd x nd N) or None); calls on the same elements are summed before the scatter."""
    groups = group_calls(calls)
    if not groups:
        return ca.MX.zeros(n), (ca.MX(n, n) if hessian else None)
    g = gather_sum([vec(G) for _, G, _ in groups], np.concatenate([pos[idx.ravel()] for idx, _, _ in groups]), n)
    if not hessian:
        return g, None
    hvals, rows, cols, hpos, n_h = [], [], [], [], 0
    for idx, _, H in groups:
        ia, ib, keep = hessian_entries(pos, idx)
        hvals.append(vec(H))
        rows.append(ib[keep])
        cols.append(ia[keep])
        hpos.append(n_h + keep)
        n_h += ia.size
    K = scatter(hvals, np.concatenate(rows), np.concatenate(cols), n, np.concatenate(hpos), n_h)
    return g, K


def sx_nonzeros(A: ca.SX) -> ca.SX:
    """Nonzeros of a sparse SX as a column."""
    return ca.vertcat(*A.nonzeros()) if A.nnz() else ca.SX(0, 1)


def mx_nonzeros(A: ca.MX) -> ca.MX:
    """Nonzeros of a sparse MX as a column (no copy of the structure)."""
    return ca.sparsity_cast(A, ca.Sparsity.dense(A.nnz(), 1))
