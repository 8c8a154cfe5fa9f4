"""Banded LDL^T of the step matrix inside the full Newton iteration: the element Hessians are gathered straight into
the matrix's lower band (no compressed-column matrix, no copy of it), the constant mass part added there, and the
band factorised and solved by the generated band kernels (ancf_sym.codegen.band), which return max |a_jj| (the
round-off floor's matrix scale) and max |dz| on the way.

Used for symmetric positive definite step matrices (the "ldl" case without multipliers, damping matrices, torques
or penalty joints) whose half-bandwidth in the unknowns' own order is at most a generated kernel's w (a chain of
planar cable elements: 7), with at least MIN_SIZE unknowns; elsewhere CasADi's sparse LDL^T. The same
factorisation (no pivoting, the same pivots), another order of the operations: the updates agree to round-off.
At 1000 planar cable elements one iteration costs ~570 instead of ~650 us (bench/DYNAMICS_RESULTS.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels, registry

# fewest unknowns for the band path: one iteration of a pinned planar cable, band vs CasADi's LDL^T, 64 elements
# (258 unknowns) 46 vs 42 us, 130 (522) 89 vs 92 us, 250 (1002) 151 vs 172 us, 1000 (4002) 582 vs 667 us
MIN_SIZE = 512
PAD_PIVOT = 2.0 ** -1000  # pivot of the padding columns: positive, below any step matrix's diagonal, 1/it finite


@dataclass
class BandLayout:
    """Lower band of an n x n matrix stored column by column, (w + 1) slots per column (slot a of column j holds
    a_(j+a, j)), padded to whole chunks of m columns; the padding columns are decoupled (zero off-diagonal, pivot
    PAD_PIVOT, right-hand side 0: their solution is 0)."""
    w: int
    m: int
    n: int
    indptr: np.ndarray  # the matrix's (symmetric) pattern, compressed columns
    indices: np.ndarray

    @cached_property
    def pattern(self) -> ca.Sparsity:
        """The pattern as a CasADi Sparsity, made on first use (~4 ms at 1000 planar cable elements; a full-Newton
        run on the band never needs it: its matrix lives in the band storage)."""
        return ca.Sparsity(self.n, self.n, self.indptr.tolist(), self.indices.tolist())

    @property
    def columns(self) -> int:
        return -(-self.n // self.m) * self.m

    @property
    def size(self) -> int:
        return (self.w + 1) * self.columns

    def slots(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Slot of each entry (row, col); -1 for the upper triangle (the factorisation reads the lower one)."""
        rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
        return np.where(rows >= cols, (rows - cols) + (self.w + 1) * cols, -1)

    def padding_slots(self) -> np.ndarray:
        return (self.w + 1) * np.arange(self.n, self.columns)

    def values(self, A: sp.spmatrix) -> np.ndarray:
        """The band storage of a numeric matrix with this pattern (padding pivots included)."""
        A = sp.coo_matrix(A)
        s = self.slots(A.row, A.col)
        out = np.bincount(s[s >= 0], A.data[s >= 0], minlength=self.size)
        out[self.padding_slots()] = PAD_PIVOT
        return out

    def solve_mx(self, band: ca.MX, b: ca.MX) -> tuple[ca.MX, ca.MX, ca.MX]:
        """(A^-1 b, max |a_jj|, max |A^-1 b|) for A given by its band storage `band` (size self.size)."""
        w, m = self.w, self.m
        fwd, bwd = kernels.load_band("fwd", w, m), kernels.load_band("bwd", w, m)
        chunks = ca.horzsplit(ca.reshape(band, w + 1, self.columns), m)
        rhs = ca.vertsplit(ca.vertcat(b, ca.MX.zeros(self.columns - self.n)), m)
        st = ca.MX.zeros(w * (w + 1) // 2 + w + 1)
        Ls, zs = [], []
        for Ak, bk in zip(chunks, rhs):
            st, Lk, zk = fwd(st, Ak, bk)
            Ls.append(Lk)
            zs.append(zk)
        sb = ca.MX.zeros(w + 1)
        xs = [None] * len(Ls)
        for k in reversed(range(len(Ls))):
            sb, xs[k] = bwd(sb, Ls[k], zs[k])
        return ca.vertcat(*xs)[:self.n], st[-1], sb[w]


def band_layout(pattern: ca.Sparsity) -> BandLayout | None:
    """The band layout for matrices with the symmetric pattern `pattern`, or None where it does not apply (fewer than
    MIN_SIZE unknowns, a half-bandwidth wider than every generated kernel's, or a diagonal entry missing)."""
    return band_layout_csc(pattern.size1(), pattern.size2(), np.array(pattern.colind()), np.array(pattern.row()))


def band_layout_csc(n_rows: int, n_cols: int, indptr: np.ndarray, indices: np.ndarray) -> BandLayout | None:
    """band_layout of the pattern given by its compressed columns (sorted, no duplicates)."""
    n = n_rows
    if n < MIN_SIZE or n_cols != n:
        return None
    cols = np.repeat(np.arange(n), np.diff(indptr))
    bw = int(np.max(np.abs(indices - cols))) if len(indices) else 0
    fits = [(w, m) for w, m in registry.BAND_LDL if bw <= w]
    if not fits or np.count_nonzero(indices == cols) != n:
        return None
    w, m = min(fits)
    return BandLayout(w, m, n, np.asarray(indptr), np.asarray(indices))
