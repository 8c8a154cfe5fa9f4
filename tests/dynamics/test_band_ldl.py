"""Banded LDL^T of the step matrix (generated band kernels, ancf_sym.system.band): solutions against a dense solve
within the round-off of a backward-stable factorisation (error <= n eps cond(A) |x|), where the band path applies,
and a full Newton iteration of a fine planar cable on the band against the same iteration with CasADi's LDL^T."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import scipy.sparse as sp

from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import StepSystem, clear_graph_cache
from ancf_sym.system import band as band_mod
from ancf_sym.system.band import MIN_SIZE, band_layout

EPS = np.finfo(float).eps


def pattern(A: sp.spmatrix) -> ca.Sparsity:
    A = sp.csc_matrix(A)
    A.sort_indices()
    return ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist())


def spd_band(n: int, w: int, seed: int) -> sp.csc_matrix:
    """A random symmetric positive definite matrix of half-bandwidth w, diagonally dominant (cond ~ 10), about a
    third of its band entries structurally zero (as in a chain of nodes, whose last coordinates skip band slots)."""
    rng = np.random.default_rng(seed)
    offsets = [-k for k in range(1, w + 1)]
    L = sp.diags([rng.uniform(-1, 1, n - k) * (rng.uniform(size=n - k) > 0.3) for k in range(1, w + 1)], offsets)
    A = sp.csc_matrix(L + L.T + sp.diags(2.0 * w + rng.uniform(1, 2, n)))
    A.eliminate_zeros()
    return A


def band_solve(A: sp.csc_matrix, b: np.ndarray) -> tuple[np.ndarray, float, float]:
    layout = band_layout(pattern(A))
    assert layout is not None
    v, r = ca.MX.sym("v", layout.size), ca.MX.sym("b", A.shape[0])
    x, amax, xmax = ca.Function("f", [v, r], list(layout.solve_mx(v, r)))(layout.values(A), b)
    return np.asarray(x).ravel(), float(amax), float(xmax)


@pytest.mark.parametrize("n", [MIN_SIZE, 1000, 1300])  # (padding of the last chunk: none / some)
def test_band_solve_against_dense(n):
    """x = A^-1 b within n eps cond(A) |x| (backward stability of LDL^T without pivoting on an SPD matrix); max |a_jj|
    exactly the largest diagonal entry (the padding pivots lie below it), max |x| that of the returned x."""
    A = spd_band(n, 7, seed=n)
    b = np.random.default_rng(n + 1).standard_normal(n)
    x, amax, xmax = band_solve(A, b)
    Ad = A.toarray()
    ref = np.linalg.solve(Ad, b)
    assert np.max(np.abs(x - ref)) <= n * EPS * np.linalg.cond(Ad) * np.max(np.abs(ref))
    assert amax == np.max(np.abs(A.diagonal()))
    assert xmax == np.max(np.abs(x))


def test_band_refused_where_it_does_not_apply():
    """Wider than every kernel's band, fewer than MIN_SIZE unknowns, or a diagonal entry missing: None."""
    wide = spd_band(MIN_SIZE, 7, seed=1) + sp.eye(MIN_SIZE, k=8) + sp.eye(MIN_SIZE, k=-8)
    assert band_layout(pattern(wide)) is None
    assert band_layout(pattern(spd_band(MIN_SIZE - 1, 7, seed=2))) is None
    A = spd_band(MIN_SIZE, 7, seed=3).tolil()
    A[5, 5] = 0.0
    A = sp.csc_matrix(A)
    A.eliminate_zeros()
    assert band_layout(pattern(A)) is None
    assert band_layout(pattern(spd_band(MIN_SIZE, 7, seed=4))) is not None


def cable(n: int) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("m", [(0, 0), (3, 0)], n, Material(E=20e9, density=7200), Section(area=7.854e-5, I=4.909e-10),
             axial="biot")
    s.pin("m", "start")
    return s


def test_newton_iteration_on_the_band(monkeypatch):
    """A pinned planar cable of 130 elements (522 unknowns, half-bandwidth 7) takes the band path; its Newton update
    equals the one from CasADi's sparse LDL^T (the same system with the band path switched off) within
    n eps cond(KKT) |dz|; the residual norm and max |a_jj| are the same numbers (the same entries, no solve)."""
    runs = {}
    for on in (True, False):
        clear_graph_cache()
        monkeypatch.setattr(band_mod, "MIN_SIZE", MIN_SIZE if on else 10 ** 9)
        S = StepSystem(Assembly(cable(130)))
        assert S.nf >= MIN_SIZE and (S._band_layout() is not None) == on
        rng = np.random.default_rng(5)
        S.x[:] = S.reduce(S.asm.x0) + 1e-3 * rng.standard_normal(S.nf)
        S.p[:] = rng.standard_normal(S.nf)
        S.cm[:], S.cc[:] = 4e6, 2e3  # (h = 1e-3 s: the inertia part dominates, as in a step)
        runs[on] = (S.iterate().copy(), S.norms.copy())
        if not on:
            kkt = S.jacobian().toarray()
    clear_graph_cache()
    (dz1, n1), (dz0, n0) = runs[True], runs[False]
    tol = len(dz0) * EPS * np.linalg.cond(kkt)
    assert np.max(np.abs(dz1 - dz0)) <= tol * np.max(np.abs(dz0))
    assert n1[4] == n0[4] and n1[0] == n0[0]
    assert abs(n1[2] - n0[2]) <= tol * n0[2]


def test_run_on_the_band_equals_the_sparse_ldl(monkeypatch):
    """20 steps of the same cable with and without the band path: tips within 1e-9 m (the updates differ by
    round-off, far below the Newton tolerance of 1 % of the truncation error; the iteration counts are equal)."""
    from ancf_sym.dynamics import DynamicOptions, simulate
    opts = DynamicOptions(dt=1e-3, t_end=0.02, integrator="generalized_alpha", rho_inf=0.9, output_dt=0.01,
                          energies=False, sensors=[{"name": "tip", "kind": "position", "member": "m", "at": "end"}])
    res = {}
    for on in (True, False):
        clear_graph_cache()
        monkeypatch.setattr(band_mod, "MIN_SIZE", MIN_SIZE if on else 10 ** 9)
        res[on] = simulate(cable(130), opts)
    clear_graph_cache()
    assert res[True].status == res[False].status == "completed"
    assert res[True].counters == res[False].counters
    assert np.max(np.abs(res[True].sensors["tip"] - res[False].sensors["tip"])) < 1e-9


def test_band_layout_from_the_index_maps():
    """The band path is chosen before any graph is built, from the kernels' index maps: its pattern is exactly the
    step matrix's (forces_pf's Hessian united with M's), and forces_pf, which the band iteration does not use, is
    built only on first use (then the same graph as on the sparse path)."""
    clear_graph_cache()
    S = StepSystem(Assembly(cable(130)))
    assert "forces_pf" not in S._graphs and "forces_band" in S._graphs
    M = sp.csc_matrix(S.M)
    M.sort_indices()
    expected = S.forces_pf.sparsity_out(1).unite(pattern(M))
    assert S.kkt_sparsity == expected
    assert S.gradient_source is S._graphs["forces_band"]
    x = S.reduce(S.asm.x0) + 1e-3 * np.random.default_rng(3).standard_normal(S.nf)
    # (the same kernels and gathers: the same gradient, bit for bit)
    assert np.array_equal(np.asarray(S.gradient_source(x, S.par)[0]), np.asarray(S.forces_pf(x, S.par)[0]))
    clear_graph_cache()
