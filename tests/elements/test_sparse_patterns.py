"""The CSC helpers of ancf_sym.util.sparsity against SciPy's own conversions: the same pattern, index type and values
entry for entry (they replace SciPy's conversions in the set-up of every run, whose numbers must not change)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.util.sparsity import casadi_sparsity, csc_pattern, dm


def test_csc_pattern_merges_duplicates():
    """indptr and indices are SciPy's canonical pattern of the triplets, and inv maps every triplet to its entry."""
    rng = np.random.default_rng(3)
    r, c = rng.integers(0, 20, 300), rng.integers(0, 25, 300)
    indptr, indices, inv = csc_pattern(r, c, 20, 25)
    A = sp.coo_matrix((np.ones(300), (r, c)), shape=(20, 25)).tocsc()
    assert np.array_equal(indptr, A.indptr) and np.array_equal(indices, A.indices)
    cols = np.repeat(np.arange(25), np.diff(indptr))
    assert np.array_equal(indices[inv], r) and np.array_equal(cols[inv], c)


def test_dm_keeps_pattern_and_values():
    """dm of a CSC matrix (sorted, taken as it is) and of the same matrix in CSR form: the same DM, and the pattern
    casadi_sparsity makes is CasADi's four-argument one."""
    A = sp.random(15, 12, density=0.3, format="csc", random_state=1)
    D1, D2 = dm(A), dm(A.tocsr())
    assert D1.sparsity() == D2.sparsity() and np.array_equal(np.array(D1.nonzeros()), np.array(D2.nonzeros()))
    assert np.array_equal(np.array(D1), A.toarray())
    assert casadi_sparsity(15, 12, A.indptr, A.indices) == ca.Sparsity(15, 12, A.indptr.tolist(), A.indices.tolist())


def test_kron_factor_dm_is_the_factor_as_dm():
    """kron_factor_dm gives the DM of kron_identity_factor's B (same pattern, same values) and None where there is
    no factor."""
    from ancf_sym.util.sparsity import kron_factor_dm, kron_identity_factor
    B = sp.random(9, 9, density=0.4, format="csc", random_state=2) + sp.identity(9)
    A = sp.kron(B, sp.identity(2), format="csc")
    d, Bd = kron_factor_dm(A)
    d2, Bs = kron_identity_factor(A)
    assert d == d2 == 2 and Bd.sparsity() == dm(Bs).sparsity()
    assert np.array_equal(np.array(Bd.nonzeros()), np.array(dm(Bs).nonzeros()))
    A2 = A.tolil()
    A2[0, 0] += 1.0  # (direction 0 heavier than direction 1: no factor)
    assert kron_factor_dm(A2.tocsc(), dims=(2,)) is None
