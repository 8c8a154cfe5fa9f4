"""The step graphs' mass product: M u through M = kron(Mbar, I_d) where a scene's mass matrix has that form (cables:
every direction of a node shares its shape functions), the plain sparse product elsewhere."""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import StepSystem
from ancf_sym.util.sparsity import kron_identity_factor, kron_product_mx

STEEL = dict(material=Material(E=200e9, density=7800), section=Section.circle(0.01))


def mass_product(S: StepSystem, u: np.ndarray) -> np.ndarray:
    us = ca.MX.sym("u", S.nf)
    return np.asarray(ca.Function("m", [us], [S.mass_mx(us)])(u)).ravel()


def bound(M: sp.spmatrix, u: np.ndarray) -> np.ndarray:
    """Round-off bound of a sum of k products per row: k eps sum |M_ij u_j| (k = the row's nonzeros)."""
    A = abs(sp.csr_matrix(M))
    k = np.diff(sp.csr_matrix(M).indptr)
    return k * np.finfo(float).eps * (A @ np.abs(u)) + 1e-300


def test_kron_factor_found_and_refused():
    """A matrix built as kron(B, I_d) gives back (d, B); one entry off the pattern of directions, or a size that d does
    not divide, gives None."""
    rng = np.random.default_rng(1)
    B = sp.random(7, 7, density=0.4, random_state=rng) + sp.identity(7)
    B = sp.csc_matrix(B + B.T)
    for d in (2, 3):
        A = sp.kron(B, sp.identity(d), format="csc")
        found = kron_identity_factor(A, dims=(d,))
        assert found is not None and found[0] == d and (found[1] != B).nnz == 0
        A2 = A.tolil()
        A2[0, 1] = 1.0  # couples two directions of the first node
        assert kron_identity_factor(A2.tocsc(), dims=(d,)) is None
    assert kron_identity_factor(sp.identity(7), dims=(2,)) is None  # 7 unknowns cannot pair up


def test_kron_product_equals_the_matrix_product():
    """kron(B, I_d) u from the reshaped product equals the sparse product within the round-off of its sums, also for
    an unsymmetric B (the product takes B^T)."""
    rng = np.random.default_rng(2)
    B = sp.csc_matrix(sp.random(9, 9, density=0.3, random_state=rng) + sp.identity(9))
    for d in (2, 3):
        A = sp.kron(B, sp.identity(d), format="csc")
        u = rng.standard_normal(A.shape[0])
        us = ca.MX.sym("u", A.shape[0])
        got = np.asarray(ca.Function("k", [us], [kron_product_mx(d, ca.DM(B.T), us)])(u)).ravel()
        assert np.all(np.abs(got - A @ u) <= bound(A, u))


def test_planar_and_spatial_cables_use_the_factor():
    """A pinned planar cable (its pin fixes both directions of the first node) and a spatial cable have M = kron(Mbar,
    I_d) on their unknowns with d = 2 and 3; the step graphs' M u equals the sparse product within round-off."""
    s2 = Scene(dim=2, gravity=(0, -9.81))
    s2.member("m", [(0, 0), (1, 0)], 6, axial="biot", **STEEL)
    s2.pin("m", "start")
    s3 = Scene(dim=3, gravity=(0, 0, -9.81))
    s3.member("m", [(0, 0, 0), (1, 0.2, 0)], 5, **STEEL)
    s3.pin("m", "start")
    rng = np.random.default_rng(3)
    for scene, d in ((s2, 2), (s3, 3)):
        S = StepSystem(Assembly(scene))
        assert kron_identity_factor(S.M) is not None and kron_identity_factor(S.M)[0] == d
        u = rng.standard_normal(S.nf)
        assert np.all(np.abs(mass_product(S, u) - S.M @ u) <= bound(S.M, u))


def test_plain_product_where_directions_differ():
    """A mass matrix that couples two directions of a node (one entry added to a cable's) has no factor: the plain
    sparse product, still M u."""
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("m", [(0, 0), (1, 0)], 5, axial="biot", **STEEL)
    s.pin("m", "start")
    S = StepSystem(Assembly(s))
    M = S.M.tolil()
    M[0, 1] = M[1, 0] = 1e-3  # (a mass matrix coupling two directions)
    S.M = sp.csc_matrix(M)
    S.__dict__.pop("_mass_kron", None)
    assert kron_identity_factor(S.M) is None
    u = np.random.default_rng(4).standard_normal(S.nf)
    assert np.all(np.abs(mass_product(S, u) - S.M @ u) <= bound(S.M, u))


def test_mass_dm_is_the_mass_matrix():
    """The step graphs' M as a DM (kron(Mbar, I_d) where M has that form, else M's own arrays) has M's pattern and
    entries exactly: b * 1.0 = b, and the factor was checked entry for entry."""
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("m", [(0, 0), (1, 0)], 6, axial="biot", **STEEL)
    s.pin("m", "start")
    c = Scene(dim=2, gravity=(0, -9.81))
    c.member("m", [(0, 0), (1, 0)], 6, axial="biot", **STEEL)
    c.clamp("m", "start")  # (an odd number of unknowns: no factor)
    for scene, has_factor in ((s, True), (c, False)):
        S = StepSystem(Assembly(scene))
        assert (kron_identity_factor(S.M) is not None) == has_factor
        Md, M = S.mass_dm(), sp.csc_matrix(S.M)
        assert Md.sparsity() == ca.Sparsity(M.shape[0], M.shape[1], M.indptr.tolist(), M.indices.tolist())
        assert np.array_equal(np.array(Md.nonzeros()), M.data)
