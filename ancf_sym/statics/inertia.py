"""Is a reduced Hessian positive definite? Sylvester's inertia from one sparse factorisation, O(n) on a banded mesh.

The reduced Hessian Z^T H Z (Z a basis of the null space of the constraint Jacobian J, m rows) is positive definite
exactly when the KKT matrix K = [[H, J^T], [J, 0]] has m negative eigenvalues (and J has full rank). K is congruent
to [[H + rho J^T J, J^T], [J, 0]] for every rho, and for H_rho = H + rho J^T J nonsingular its inertia is
In(H_rho) + In(-S) with S = J H_rho^-1 J^T (m x m, dense, m small: the rows left after the supports that fix
coordinates are eliminated). So neg(K) = neg(H_rho) + pos(S). Without constraint rows, a banded Cholesky (scipy's LAPACK dpbtrf) of H + sigma I
settles the usual stable case first in O(n x band^2); only when it fails (or the band is wide) is the count needed.

neg(H_rho) comes from a sparse LDL^T: SciPy's SuperLU with a symmetric fill-reducing ordering and diagonal pivots
only (diag_pivot_thresh = 0, SymmetricMode) gives P H P^T = L U with U = D L^T, so the signs of diag(U) are the
inertia (checked: the row and column permutations must agree; SciPy has no sparse LDL^T, CHOLMOD is not a
dependency, CasADi's ldl hides D inside its solve). The banded Cholesky only says yes or no; this gives the count
and a direction.

Threshold: H is shifted by sigma = STABILITY_EPS x max|H_ii| first, so "stable" means every eigenvalue of the
reduced Hessian is above -sigma: an exactly zero mode (a free rotation about a pin) computes within a fraction of
eps ||H|| and stays stable, while a column past its Euler load (eigenvalue -4e-14 ||H|| at EA L^2/EI = 1e8) does not.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dpbtrf, dpbtrs
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu, spsolve_triangular

STABILITY_EPS = 100 * np.finfo(float).eps  # negative-curvature threshold, relative to max |H_ii|
BAND_LIMIT = 64  # widest band (entries above the diagonal) worth a banded Cholesky
DENSE_DIRECTION = 2000  # up to this size the direction of most negative curvature is an eigenvector


@dataclass
class Inertia:
    stable: bool | None  # None: the factorisation pivoted off the diagonal (inertia not read from it)
    negative: int  # negative eigenvalues of the reduced Hessian (below -sigma)
    direction: np.ndarray | None  # a direction of negative curvature (max-norm 1), None if stable


def reduced_inertia(H: sp.spmatrix, J: sp.spmatrix | None = None, rank_tol: float | None = None) -> Inertia:
    """Inertia of the Hessian H (n x n, symmetric) reduced to the null space of J (m x n, full row rank).

    rank_tol: J may have dependent rows (exact contact: five contact points per element on four transverse
    coordinates); its rank r is then the number of eigenvalues of S = J H_rho^-1 J^T above rank_tol x their largest
    magnitude (S has rank r exactly, its other m - r eigenvalues are round-off), and neg = neg(H_rho) + pos(S) - r."""
    H = sp.csc_matrix(H)
    n = H.shape[0]
    m = 0 if J is None else J.shape[0]
    if n == 0:
        return Inertia(True, 0, None)
    diag = np.abs(H.diagonal())
    hmax = float(diag.max()) if diag.size and diag.max() > 0 else float(abs(H).max() or 1.0)
    sigma = STABILITY_EPS * hmax
    if not m and _banded_positive_definite(H, sigma):
        return Inertia(True, 0, None)
    if m:
        J = sp.csr_matrix(J)
        jn = float(sp.linalg.norm(J, axis=1).max()) or 1.0
        Hs = sp.csc_matrix(H + sigma * sp.identity(n, format="csc") + (hmax / jn**2) * (J.T @ J))
    elif np.all(H.diagonal() != 0):  # the shift on the stored diagonal, no sparse sum
        Hs = H.copy()
        Hs.setdiag(Hs.diagonal() + sigma)
    else:
        Hs = sp.csc_matrix(H + sigma * sp.identity(n, format="csc"))
    try:
        lu = splu(Hs, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular after the shift: only a constraint-normal direction can be
        return Inertia(None, 0, None)
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return Inertia(None, 0, None)
    d = lu.U.diagonal()
    neg_h = int(np.sum(d < 0))
    pos_s = 0
    if m:
        X = lu.solve(np.asarray(J.T.todense()))
        w = np.linalg.eigvalsh(0.5 * (J @ X + (J @ X).T))
        if rank_tol is None:
            pos_s = int(np.sum(w > 0))
        else:
            cut = rank_tol * float(np.max(np.abs(w), initial=0.0))
            pos_s, m = int(np.sum(w > cut)), int(np.sum(np.abs(w) > cut))
    negative = neg_h + pos_s - m
    if negative <= 0:
        return Inertia(True, 0, None)
    return Inertia(False, negative, _direction(H, J, lu, d))


def _banded_positive_definite(H: sp.csc_matrix, sigma: float) -> bool:
    """H + sigma I positive definite by a banded Cholesky (banded_cholesky)."""
    return banded_cholesky(H, sigma) is not None


def banded_cholesky(H: sp.csc_matrix, sigma: float = 0.0) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Upper banded Cholesky factor of H + sigma I (LAPACK dpbtrf) in the coordinates' own order, or in a reverse
    Cuthill-McKee order when that is narrower: a 1D mesh numbered node by node is a band of width 2 x node size, so
    this is O(n x band^2), cheaper than a general sparse factorisation. Returns (factor, order or None), or None
    when H + sigma I is not positive definite or the band is too wide to pay (a sparse LDL^T or LU then serves)."""
    n = H.shape[0]
    rows, cols = H.indices, np.repeat(np.arange(n), np.diff(H.indptr))  # CSC entries (no format conversion)
    up = rows <= cols
    r, c, v = rows[up], cols[up], H.data[up]
    bw = int(np.max(c - r, initial=0))
    perm = None
    if bw > BAND_LIMIT:
        perm = reverse_cuthill_mckee(sp.csr_matrix(H), symmetric_mode=True)
        inv = np.empty(n, dtype=np.int64)
        inv[perm] = np.arange(n)
        r2, c2 = inv[rows], inv[cols]
        up = r2 <= c2
        r, c, v = r2[up], c2[up], H.data[up]
        bw = int(np.max(c - r, initial=0))
        if bw > BAND_LIMIT:
            return None
    ab = np.zeros((bw + 1, n))
    ab[bw + r - c, c] = v  # (a canonical CSC matrix holds each entry once)
    ab[bw] += sigma
    cb, info = dpbtrf(ab, lower=0, overwrite_ab=1)
    return (cb, perm) if info == 0 else None


def banded_solve(factor: tuple[np.ndarray, np.ndarray | None], b: np.ndarray) -> np.ndarray:
    """Solve (H + sigma I) x = b with a factor from banded_cholesky."""
    cb, perm = factor
    if perm is None:
        return dpbtrs(cb, b, lower=0)[0]
    x = np.empty_like(b)
    x[perm] = dpbtrs(cb, b[perm], lower=0)[0]
    return x


def _direction(H, J, lu, d) -> np.ndarray | None:
    """Most negative curvature of the reduced Hessian: an eigenvector (dense) up to DENSE_DIRECTION coordinates,
    else L^-T e_k of the most negative pivot (d^T H_rho d = D_k < 0) projected on the null space of J."""
    n = H.shape[0]
    if n <= DENSE_DIRECTION:
        import scipy.linalg as sla
        Z = sla.null_space(J.toarray()) if J is not None and J.shape[0] else np.eye(n)
        Hr = Z.T @ H.toarray() @ Z
        w, V = np.linalg.eigh(0.5 * (Hr + Hr.T))
        v = Z @ V[:, 0]
    else:
        k = int(np.argmin(d))
        e = np.zeros(n)
        e[k] = 1.0
        y = spsolve_triangular(sp.csr_matrix(lu.L.T), e, lower=False, unit_diagonal=True)
        v = y[lu.perm_c]  # SuperLU: B[perm[i], perm[j]] = H_rho[i, j], B = L U: v^T H_rho v = y^T B y = D_k
        if J is not None and J.shape[0]:
            Jd = J.toarray() if J.shape[0] * n < 5e7 else None
            if Jd is None:
                return None
            v = v - J.T @ np.linalg.lstsq(Jd @ Jd.T, Jd @ v, rcond=None)[0]
    s = float(np.max(np.abs(v)))
    return v / s if s > 0 else None
