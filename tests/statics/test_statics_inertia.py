"""The sparse inertia count of a reduced Hessian (ancf_sym.statics.inertia) against dense eigenvalues.

Sylvester's law makes the count exact for any symmetric H and full-rank J; the test draws random symmetric matrices
whose spectra straddle zero (shifts -2..8 of a GOE-like matrix of size 3..40) with 0..2 constraint rows, so a wrong
sign convention, permutation or Schur-complement term shows as a wrong count. Eigenvalues closer to zero than the
shift sigma = 100 eps max|H_ii| would be ambiguous: none occur for these draws (gap checked)."""
import numpy as np
import scipy.sparse as sp

from ancf_sym.statics.inertia import STABILITY_EPS, reduced_inertia


def test_negative_count_matches_dense_eigenvalues():
    rng = np.random.default_rng(0)
    for _ in range(200):
        n, m = int(rng.integers(3, 40)), int(rng.integers(0, 3))
        A = rng.standard_normal((n, n))
        A = A + A.T + rng.uniform(-2, 8) * np.eye(n)
        J = rng.standard_normal((m, n)) if m else None
        Z = np.linalg.svd(J)[2][m:].T if m else np.eye(n)
        w = np.linalg.eigvalsh(Z.T @ A @ Z)
        assert np.min(np.abs(w)) > 1e3 * STABILITY_EPS * np.abs(np.diag(A)).max()
        res = reduced_inertia(sp.csc_matrix(A), sp.csr_matrix(J) if m else None)
        assert res.stable is not None
        assert res.negative == int(np.sum(w < 0))
        assert res.stable == bool(w.min() > 0)
        if not res.stable:  # the direction has negative curvature on the constraint manifold
            d = res.direction
            if m:
                assert np.abs(J @ d).max() < 1e-8
            assert d @ A @ d < 0
