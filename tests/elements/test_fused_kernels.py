"""Fused elastic kernels (internal effects elastic_<strain> = axial_<strain> + bending of a cable in one kernel):
the same energy, gradient and Hessian as the two separate kernels to round-off, used by the step graphs only where
a cable member has both effects at the same Gauss order, and dynamics runs that agree with the separate calls.
(The fused kernels are also in kernels.catalogue(), so test_derivatives, test_companions, test_invariance,
test_hard_states and test_bad_input check them like every other kernel.)"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, kernels, registry
from ancf_sym.model.assembly import Assembly, ForceTerm, force_terms
from ancf_sym.dynamics import DynamicOptions, LINEAR_EFFECTS, StepSystem, rayleigh_data, simulate

from helpers import params, perturbed_state

FUSED = [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()
         if registry.EFFECTS[(k["element"], k["effect"])].internal]
REL = 1e-12


def test_fused_effects_are_listed_and_internal():
    assert {(el, ef) for el, ef, _ in FUSED} == {(el, f"elastic_{s}") for el in ("cable2d", "cable3d")
                                                  for s in ("green", "biot", "decoupled", "decoupled_biot")}
    assert {g for *_, g in FUSED} == {3, 4, 5, 7}
    for el, ef, _ in FUSED:
        eff = registry.EFFECTS[(el, ef)]
        assert eff.params == ("L", "EA", "EI") and eff.elastic and len(eff.parts) == 2
        assert registry.fused_effect(el, tuple(reversed(eff.parts))) == ef
    assert registry.fused_effect("cable2d", ("bending", "axial_decoupled")) == "elastic_decoupled"
    assert registry.fused_effect("cable2d", ("axial_green", "axial_decoupled")) is None
    assert registry.fused_effect("beam3d", ("line_strain", "line_bending")) is None


def _rel(a, b):
    a, b = np.asarray(a), np.asarray(b)  # kernel outputs are casadi DMs: numpy functions on numpy arrays only
    return float(np.max(np.abs(a - b))) / max(float(np.max(np.abs(b))), 1e-300)


# one density of (r_x, r_xx); the decoupled strain's fused kernels (chained through the stretches, another operation
# order) are compared in tests/elements/test_decoupled_fused.py
DENSITY = [k for k in FUSED if k[1] in {f"elastic_{s}" for s in registry.FUSED_STRAINS}]


@pytest.mark.parametrize("element,effect,gauss", DENSITY, ids=[f"{el}_{ef}_g{g}" for el, ef, g in DENSITY])
def test_fused_equals_axial_plus_bending(element, effect, gauss):
    axial, bending = registry.EFFECTS[(element, effect)].parts
    gauss_arg = None if gauss == registry.DEFAULT_GAUSS else gauss
    kf = kernels.load(element, effect, gauss_arg)
    ka, kb = kernels.load(element, axial, gauss_arg), kernels.load(element, bending, gauss_arg)
    rng = np.random.default_rng(5)
    for amp, stretch in ((0.1, 0.05), (0.3, 0.3)):
        q = perturbed_state(element, rng, amplitude=amp, stretch=stretch, angle=0.9)
        p = params(element, effect, q)
        pa, pb = p[[0, 1]], p[[0, 2]]
        ef, gf, Hf = kf(q, p)
        ea, ga, Ha = ka(q, pa)
        eb, gb, Hb = kb(q, pb)
        assert _rel(ef, ea + eb) < REL and _rel(gf, ga + gb) < REL and _rel(Hf, Ha + Hb) < REL
        e2, g2 = kernels.load_grad(element, effect, gauss_arg)(q, p)
        assert _rel(e2, ea + eb) < REL and _rel(g2, ga + gb) < REL
        assert _rel(kernels.load_energy(element, effect, gauss_arg)(q, p), ea + eb) < REL


def _scene(dim=2, members=(("a", True, "biot", None),), rayleigh=None):
    s = Scene(dim=dim, gravity=(0, -9.81) if dim == 2 else (0, 0, -9.81))
    for k, (name, bending, axial, gauss) in enumerate(members):
        y = -0.3 * k
        pts = [(0, y), (1.2, y)] if dim == 2 else [(0, y, 0), (1.2, y, 0.1)]
        s.member(name, pts, 6, Material(E=0.7e6, density=5540), Section(area=0.0018, I=1.215e-8),
                 axial=axial, bending=bending, gauss=gauss)
        s.pin(name, "start")
    if rayleigh:
        s.rayleigh(**rayleigh)
    return s


def _force_terms(s):
    asm = Assembly(s)
    nonlinear = [mk.term for mk in asm.mapped if mk.term.effect not in LINEAR_EFFECTS]
    return nonlinear, force_terms(nonlinear)


def test_force_terms_fuse_only_where_both_effects_are_on():
    # one member with both effects: one fused call covering every element of both terms
    terms, fts = _force_terms(_scene())
    assert [(ft.effect, ft.N, ft.labels) for ft in fts] == [("elastic_biot", 6, ("axial", "bending"))]
    assert np.array_equal(fts[0].P, np.c_[terms[0].P, terms[1].P[:, 1]])
    # a member without bending next to one with: only the second member's elements are fused
    terms, fts = _force_terms(_scene(members=(("a", False, "green", None), ("b", True, "green", None))))
    assert sorted((ft.effect, ft.N) for ft in fts) == [("axial_green", 6), ("elastic_green", 6)]
    # the decoupled strain's stretch-chained fused kernel, on every element
    terms, fts = _force_terms(_scene(members=(("a", True, "decoupled", None),)))
    assert [(ft.effect, ft.N, ft.labels) for ft in fts] == [("elastic_decoupled", 6, ("axial", "bending"))]
    # bending alone, or axial and bending on different members: nothing fused
    for members in ((("a", True, None, None),), (("a", False, "green", 3), ("b", True, None, 3))):
        _, fts = _force_terms(_scene(members=members))
        assert not any(ft.fused for ft in fts), members
    # every (term, element) is covered exactly once
    terms, fts = _force_terms(_scene(members=(("a", True, "green", 3), ("b", True, "green", 7),
                                              ("c", False, "green", 3))))
    covered = {}
    for ft in fts:
        for ti, rows in ft.sources:
            covered.setdefault(ti, []).extend(rows.tolist())
    assert {ti: sorted(r) for ti, r in covered.items()} == {ti: list(range(len(t.idx))) for ti, t in enumerate(terms)}


def test_no_bending_loads_no_fused_kernel(monkeypatch):
    seen = []
    load = kernels.load

    def rec(element, effect, gauss=None):
        seen.append(effect)
        return load(element, effect, gauss)
    monkeypatch.setattr(kernels, "load", rec)
    s = _scene(members=(("a", False, "biot", None),))
    asm = Assembly(s)
    StepSystem(asm, None)
    assert not any(e.startswith("elastic_") for e in seen) and "bending" not in seen


@pytest.mark.parametrize("dim,members,rayleigh", [
    (2, (("a", True, "biot", None),), None),
    (2, (("a", True, "green", None), ("b", False, "green", None)), {"alpha": 0.2, "beta": 2e-3}),
    (3, (("a", True, "biot", 3),), {"beta": 1e-3, "members": ["a"]}),
    (2, (("a", True, "decoupled", None),), None),
    (3, (("a", True, "decoupled", 3), ("b", True, "green", 3)), {"beta": 1e-3}),
], ids=["rope2d", "two_members_rayleigh", "cable3d_g3_rayleigh", "decoupled2d", "decoupled3d_g3_rayleigh"])
def test_dynamics_fused_matches_separate(dim, members, rayleigh):
    """The same run with the fused step graph and with one kernel call per term: tips and per-effect energies
    agree to round-off accumulated over the run."""
    runs = []
    for fuse in (True, False):
        asm = Assembly(_scene(dim, members, rayleigh))  # 6 elements: one batch of 4 and 2 single
        S = StepSystem(asm, rayleigh_data(asm, [mk for mk in asm.mapped if mk.term.effect not in LINEAR_EFFECTS]),
                       fuse=fuse)
        assert any(ft.fused for ft in S.force_terms) == fuse
        opts = DynamicOptions(dt=2e-3, t_end=0.2, integrator="generalized_alpha", rho_inf=0.9, output_dt=0.02,
                              sensors=[{"name": "tip", "kind": "position", "member": "a", "at": "end"}])
        r = simulate(asm, opts, system=S)
        assert r.status == "completed", r.message
        runs.append(r)
    a, b = runs
    assert a.newton_iterations == b.newton_iterations
    assert np.max(np.abs(a.sensors["tip"] - b.sensors["tip"])) < 1e-9
    for key in ("potential_axial", "potential_bending", "kinetic"):
        scale = max(np.max(np.abs(b.energies[key])), 1e-300)
        assert np.max(np.abs(a.energies[key] - b.energies[key])) < 1e-8 * scale, key


BATCHED = [(k["element"], k["effect"]) for k in kernels.catalogue()
           if k["name"] + registry.BATCH_SUFFIX in k["functions"]]
BATCHED_ENERGY = [(k["element"], k["effect"]) for k in kernels.catalogue()
                  if k["name"] + "_energy" + registry.BATCH_SUFFIX in k["functions"]]


def test_batched_kernels_are_listed():
    assert sorted(BATCHED) == sorted((el, ef) for el in ("cable2d", "cable3d")
                                     for ef in ("elastic_green", "elastic_biot", "elastic_decoupled",
                                                "elastic_decoupled_biot", "axial_decoupled", "axial_decoupled_biot",
                                                "bending"))
    assert sorted(BATCHED_ENERGY) == sorted((el, ef) for el in ("cable2d", "cable3d")
                                            for ef in ("axial_green", "axial_biot", "bending"))
    assert kernels.load_batch("cable2d", "bending", 3) is None and kernels.load_batch("cable2d", "elastic_biot", 3) is None
    assert kernels.load_batch("cable2d", "axial_decoupled", None, "_grad") is None
    assert kernels.load_batch("cable2d", "axial_decoupled", None, "_energy") is None


@pytest.mark.parametrize("element,effect", BATCHED_ENERGY, ids=[f"{el}_{ef}" for el, ef in BATCHED_ENERGY])
def test_batched_energy_equals_the_mapped_energy(element, effect):
    """The outputs' energies per effect: <name>_energy_x4 gives the mapped _energy function's values, whole batches
    and remainders (assembly.map_elements)."""
    from ancf_sym.model.assembly import map_elements
    rng = np.random.default_rng(4)
    n = 2 * registry.BATCH_LANES + 1
    X = np.column_stack([perturbed_state(element, rng, amplitude=0.2, stretch=0.1, angle=0.4 * k) for k in range(n)])
    P = np.array([[0.8, 7.0]] * n).T * (1 + 0.1 * rng.random((2, n)))
    one = kernels.load_energy(element, effect)
    ref = np.asarray(one.map(n)(X, P))
    got = np.asarray(map_elements(one, kernels.load_batch(element, effect, None, "_energy"), n)(X, P))
    assert _rel(got, ref) < 1e-13


@pytest.mark.parametrize("element,effect", BATCHED, ids=[f"{el}_{ef}" for el, ef in BATCHED])
def test_batched_kernel_equals_the_mapped_kernel(element, effect):
    """<name>_x4 (lanes of SIMD vectors) gives the mapped one-element kernel's outputs (FMA contraction on x86-64-v3
    changes the last bits only), and ForceTerm's mapping (whole batches + the rest) covers any element count. The
    fused effects also have a batched _grad companion; the decoupled strain's unfused kernels only the kernel."""
    lanes = registry.BATCH_LANES
    rng = np.random.default_rng(9)
    n = 2 * lanes + 3
    X = np.column_stack([perturbed_state(element, rng, amplitude=0.2, stretch=0.1, angle=0.3 * k) for k in range(n)])
    n_p = len(kernels.parameters(element, effect))
    P = np.array([[0.8, 3.0e3, 7.0][:n_p]] * n).T * (1 + 0.1 * rng.random((n_p, n)))
    ref = [np.asarray(a) for a in kernels.load(element, effect).map(n)(X, P)]
    got = [np.asarray(a) for a in kernels.load_batch(element, effect).map(2)(X[:, :2 * lanes], P[:, :2 * lanes])]
    for a, b in zip(got, ref):
        assert _rel(a, b[:, :a.shape[1]]) < 1e-13
    fused = registry.EFFECTS[(element, effect)].internal
    if fused:
        got = [np.asarray(a) for a in kernels.load_batch(element, effect, None, "_grad").map(2)(X[:, :2 * lanes],
                                                                                               P[:, :2 * lanes])]
        for a, b in zip(got, ref):
            assert _rel(a, b[:, :a.shape[1]]) < 1e-13
    idx = np.arange(n * X.shape[0]).reshape(n, -1)
    parts = [(0, np.arange(n)), (1, np.arange(n))] if fused else [(0, np.arange(n))]
    ft = ForceTerm(element, effect, None, idx, P.T, ("axial", "bending")[:len(parts)], parts)
    for a, b in zip(ft.mapped()(X, P), ref):
        assert _rel(a, b) < 1e-13
    if fused:
        for a, b in zip(ft.mapped_grad()(X, P), ref):
            assert _rel(a, b) < 1e-13
