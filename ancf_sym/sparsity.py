"""Sparse patterns from (row, col) triplets, merged in compressed-column order (SciPy's and CasADi's layout)."""
from __future__ import annotations

import casadi as ca
import numpy as np


def csc_pattern(rows: np.ndarray, cols: np.ndarray, n_rows: int,
                n_cols: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, inv): the merged CSC pattern and, for triplet k, the index of its non-zero inv[k]."""
    key = np.asarray(cols, dtype=np.int64) * n_rows + np.asarray(rows, dtype=np.int64)
    uniq, inv = np.unique(key, return_inverse=True)
    counts = np.zeros(n_cols + 1, dtype=np.int64)
    np.add.at(counts, uniq // n_rows + 1, 1)
    return np.cumsum(counts), uniq % n_rows, inv


def casadi_sparsity(n_rows: int, n_cols: int, indptr: np.ndarray, indices: np.ndarray) -> ca.Sparsity:
    return ca.Sparsity(n_rows, n_cols, np.asarray(indptr).tolist(), np.asarray(indices).tolist())
