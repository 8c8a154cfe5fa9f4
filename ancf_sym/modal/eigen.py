"""The lowest eigenpairs of K y = w^2 M y on the subspace G y = 0, constraints eliminated exactly.

Small models: a null-space basis T of G (SVD), then the dense symmetric pencil (T'KT, T'MT). Large models: shift-
invert Lanczos (ARPACK through scipy.sparse.linalg.eigsh) whose operator is the top-left block of the factorised
KKT matrix [[K - sigma M, G'], [G, 0]]^-1: it maps M y to the constrained solution, is self-adjoint in the M inner
product, and its largest eigenvalues 1/(w^2 - sigma) are the modes nearest the shift (the m directions it annihilates
give 0, the far end of its spectrum). The shift is 0 first; where that factorisation is singular or the answer has
zero modes (rigid motions of free structures), again with a negative shift below the lowest elastic mode: K - sigma
M is then regular and the rigid modes come out as w^2 = 0 to round-off. An unsymmetric K (a current's drag in
water: a load that follows the line) takes the same operator with Arnoldi (eigs) or the dense unsymmetric pencil.
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ancf_sym.scene.builder import SceneError

DENSE_MAX = 40  # unknowns (or modes + this) up to which the dense pencil is used: measured on a 120-element
# cantilever, the dense solve of the whole spectrum puts its round-off, eps x the highest w^2, on the lowest mode
# too (4e-6 of it), where shift-invert resolves the lowest modes to their own relative precision
ZERO_REL = 1e-12  # |w^2| below this times the model's largest diag(K)/diag(M): a zero (rigid) mode. The computed
# w^2 of a rigid motion is round-off of the tangent's largest entries (eps * max K / M times a growth factor, measured
# ~1e-15 of it on free beams); an elastic mode that low is not resolvable from a rigid one in double precision.
UNSYMMETRIC_REL = 1e-10  # |K - K'| above this times |K|: the unsymmetric pencil (complex w^2 where a mode flutters)
REAL_REL = 1e-9  # |Im w^2| below this times |w^2|: a real eigenvalue of the unsymmetric pencil (Arnoldi's round-off)


def stiffness_scale(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """max diag(K)/diag(M) [1/s^2]: the order of the model's highest w^2."""
    dk, dm = np.abs(K.diagonal()), M.diagonal()
    ok = dm > 0
    return float(np.max(dk[ok] / dm[ok])) if np.any(ok) and np.any(dk[ok] > 0) else 1.0


def symmetric(K: sp.spmatrix) -> bool:
    """K equal to K' (to round-off: symmetrised Hessians are exact; an unsymmetric K is a non-conservative load's
    stiffness, e.g. a current's drag)."""
    D = abs(K - K.T)
    return D.nnz == 0 or D.max() <= UNSYMMETRIC_REL * abs(K).max()


def dense_modes(K, M, G, k: int) -> tuple[np.ndarray, np.ndarray]:
    Kd, Md = K.toarray(), M.toarray()
    if G.shape[0]:
        T = la.null_space(G.toarray())
        Kd, Md = T.T @ Kd @ T, T.T @ Md @ T
    if symmetric(K):
        w2, Z = la.eigh(0.5 * (Kd + Kd.T), 0.5 * (Md + Md.T), subset_by_index=[0, min(k, Kd.shape[0]) - 1])
    else:  # the unsymmetric pencil: every eigenvalue, the k of lowest real part
        w2, Z = la.eig(Kd, 0.5 * (Md + Md.T))
        o = np.argsort(w2.real)[:k]
        w2, Z = w2[o], Z[:, o]
    Y = T @ Z if G.shape[0] else Z
    return w2, Y


def _shift_invert(K, M, G, k: int, sigma: float):
    n, m = K.shape[0], G.shape[0]
    A = (K - sigma * M).tocsc() if sigma else K.tocsc()
    kkt = sp.bmat([[A, G.T], [G, None]], format="csc") if m else A
    with warnings.catch_warnings():
        warnings.simplefilter("error", sla.MatrixRankWarning)
        lu = sla.splu(kkt)  # (RuntimeError where exactly singular)
    pad = np.zeros(m)
    op = sla.LinearOperator((n, n), matvec=lambda v: lu.solve(np.r_[np.ravel(v), pad])[:n] if m else
                            lu.solve(np.ravel(v)), dtype=float)
    ncv = min(n, max(2 * k + 1, k + 20))
    # a fixed start vector (ARPACK's own is random): the same scene gives the same modes to the last bit; a seeded
    # random one, not ones, which a symmetric structure's antisymmetric modes are orthogonal to
    v0 = np.random.default_rng(0).standard_normal(n)
    if symmetric(K):
        w2, Y = sla.eigsh(K, k=k, M=M, sigma=sigma, which="LM", OPinv=op, ncv=ncv, v0=v0)
    else:  # (Arnoldi on the same operator: its eigenvalues 1/(w^2 - sigma), complex where a mode flutters)
        w2, Y = sla.eigs(K, k=k, M=M, sigma=sigma, which="LM", OPinv=op, ncv=ncv, v0=v0)
    o = np.argsort(w2.real)
    return w2[o], Y[:, o]


def sparse_modes(K, M, G, k: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The k modes nearest the lowest ones by shift-invert Lanczos; returns (w^2, Y, the shift used)."""
    scale = stiffness_scale(K, M)
    zero = ZERO_REL * scale
    try:
        w2, Y = _shift_invert(K, M, G, k, 0.0)
        if np.all(np.abs(w2) > zero) and np.all(np.isfinite(w2)):
            return w2, Y, 0.0
        elastic = np.abs(w2[np.isfinite(w2) & (np.abs(w2) > zero)])
    except (RuntimeError, sla.MatrixRankWarning, sla.ArpackError):
        elastic = np.zeros(0)
    sigma = -(0.1 * float(elastic.min()) if len(elastic) else 1e-6 * scale)
    w2, Y = _shift_invert(K, M, G, k, sigma)
    return w2, Y, sigma


def lowest_modes(K, M, G, k: int) -> tuple[np.ndarray, np.ndarray, str]:
    """(w^2 ascending, M-normalised mode vectors as columns, method). An unsymmetric K (a non-conservative load's
    stiffness): the k eigenvalues of lowest real part of the unsymmetric pencil, real (with real vectors) where
    every one is real to round-off, else complex w^2 and vectors (a mode the load feeds or damps)."""
    n = K.shape[0]
    if k > n - G.shape[0]:
        raise SceneError(f"modes = {k} exceeds the {n - G.shape[0]} degrees of freedom the supports, joints and "
                         "contacts leave")
    if n - G.shape[0] <= DENSE_MAX + 2 * k:
        w2, Y = dense_modes(K, M, G, k)
        method = "dense"
    else:
        w2, Y, sigma = sparse_modes(K, M, G, k)
        method = f"shift-invert Lanczos (sigma = {sigma:.6g})"
    if np.iscomplexobj(w2) or np.iscomplexobj(Y):  # (the unsymmetric pencil) the largest entry real and positive;
        big = np.argmax(np.abs(Y), axis=0)  # a real eigenvalue's vector is then real to round-off: its real part
        ph = Y[big, np.arange(Y.shape[1])]
        Y = Y * (np.conj(ph) / np.abs(ph))
        w2 = np.asarray(w2, complex)
        if np.all(np.abs(w2.imag) <= REAL_REL * np.abs(w2)):
            w2, Y = w2.real, Y.real
    # M-normalised (eigh and ARPACK give it to round-off; made exact), the largest entry positive (a fixed sign)
    Y = Y / np.sqrt(np.einsum("ij,ij->j", Y.conj(), M @ Y).real)
    big = np.argmax(np.abs(Y), axis=0)
    Y = Y * np.sign(Y[big, np.arange(Y.shape[1])].real)
    return w2, Y, method


def damped_modes(K, M, D, G, k: int, sigma: float) -> np.ndarray:
    """The k eigenvalues lambda (Im >= 0, by |lambda|) of (lambda^2 M + lambda D + K) y + G' mu = 0, G y = 0 nearest
    the real shift sigma (< 0, below the lowest mode), by shift-invert Arnoldi (scipy.sparse.linalg.eigs) on the
    first-order form z = (y, v = lambda y). The operator (A - sigma B)^-1 B solves one KKT system with
    K + sigma D + sigma^2 M (factorised once) and returns v = P w1 + sigma y, P the M-orthogonal projector onto G v = 0
    (so the constraint directions, which are no modes, map to 0 instead of to spurious eigenvalues)."""
    n, m = K.shape[0], G.shape[0]
    Ks = (K + sigma * D + sigma ** 2 * M).tocsc()
    kkt = sp.bmat([[Ks, G.T], [G, None]], format="csc") if m else Ks
    lu = sla.splu(kkt)
    C = (D + sigma * M).tocsr()
    if m:
        mlu = sla.splu(M.tocsc())
        MiGt = mlu.solve(G.T.toarray())
        S = la.cho_factor(G @ MiGt)

        def project(w):
            return w - MiGt @ la.cho_solve(S, G @ w)
    else:
        def project(w):
            return w
    pad = np.zeros(m)

    def op(w):
        w = np.ravel(w)
        w1, w2 = w[:n], w[n:]
        rhs = -(M @ w2) - C @ w1
        y = lu.solve(np.r_[rhs, pad])[:n] if m else lu.solve(rhs)
        return np.r_[y, project(w1) + sigma * y]

    A = sla.LinearOperator((2 * n, 2 * n), matvec=op, dtype=float)
    nev = min(2 * k + 2, 2 * n - 2)
    nu = sla.eigs(A, k=nev, which="LM", return_eigenvectors=False, ncv=min(2 * n, max(2 * nev + 1, nev + 20)))
    nu = nu[np.abs(nu) > 1e-12 * np.max(np.abs(nu))]
    lam = sigma + 1.0 / nu
    lam = lam[lam.imag >= -1e-9 * np.abs(lam)]  # one of each conjugate pair (real ones: every one)
    lam = lam[np.argsort(np.abs(lam))]
    return lam[:k]
