"""The decoupled strain's fused elastic kernels (elastic_decoupled[_biot] = axial_decoupled[_biot] + bending, one
kernel chained through the stretches |r_x(0)|, L_D, |r_x(L)|: codegen.forms.stretch_kernel) compute the sum of the
two separate kernels, scalar and 4-lane batched, and the statics and dynamics that call them give the answers of
the separate calls.

Tolerances: the fused and the separate kernels evaluate the same exact derivatives with different operation orders
(~2000-4000 floating operations each, every output a sum of products of O(1) slopes and the stiffnesses). Their
round-off is a few hundred ulps of the magnitudes summed, ~1e-13 relative to the largest of them; 1e-11 of that
magnitude leaves a factor ~100 for cancellation inside the sums (an output smaller than its terms), and a wrong
term (a missing chain-rule part, e.g. the length's share of the Hessian, is of the order of the axial stiffness
itself) is 1e9 times larger."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry
from ancf_sym.util import setup_cache
from ancf_sym.model.assembly import Assembly
from ancf_sym.statics import StaticOptions, StaticProblem
from ancf_sym.study.statics_studies import zhang_scene

from helpers import perturbed_state

REL = 1e-11
PAIRS = [(el, f"elastic_{s}", f"axial_{s}", g) for el in ("cable2d", "cable3d")
         for s in registry.FUSED_STRETCH_STRAINS for g in registry.GAUSS_ORDERS]
IDS = [f"{el}_{ef}_g{g}" for el, ef, _, g in PAIRS]


def _states(element: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n stretched (up to 30 %) and curved (tangents turned by up to ~1 rad) element states, and p = (L, EA, EI)
    with EA/EI ~ 1e2 - 1e5 (both effects' shares visible in every output)."""
    rng = np.random.default_rng(seed)
    X = np.column_stack([perturbed_state(element, rng, amplitude=a, stretch=s, angle=0.9)
                         for a, s in zip(rng.uniform(0.05, 0.3, n), rng.uniform(-0.1, 0.3, n))])
    P = np.vstack([rng.uniform(0.5, 1.0, n), 10 ** rng.uniform(3, 6, n), rng.uniform(1.0, 10.0, n)])
    return X, P


def _check(fused, separate, what: str) -> None:
    """fused == sum of the separate outputs to REL of the largest magnitude summed (see the module docstring)."""
    scale = max(float(np.max(np.abs(a))) for a in separate)
    err = float(np.max(np.abs(fused - sum(separate))))
    assert err <= REL * scale, f"{what}: {err:.3g} > {REL} x {scale:.3g}"


@pytest.mark.parametrize("element,effect,axial,gauss", PAIRS, ids=IDS)
def test_fused_equals_axial_plus_bending(element, effect, axial, gauss):
    assert registry.EFFECTS[(element, effect)].parts == (axial, "bending")
    assert registry.fused_effect(element, ("bending", axial)) == effect
    n = 2 * registry.BATCH_LANES
    X, P = _states(element, n, gauss)
    kf, ka, kb = (kernels.load(element, ef, gauss) for ef in (effect, axial, "bending"))
    fused = [np.asarray(o) for o in kf.map(n)(X, P)]
    parts = [[np.asarray(o) for o in k.map(n)(X, P[rows])] for k, rows in ((ka, [0, 1]), (kb, [0, 2]))]
    for i, name in enumerate(("energy", "gradient", "hessian")):
        for e in range(n):  # per element: the Hessian's scale is the element's own
            cols = slice(e * fused[i].shape[1] // n, (e + 1) * fused[i].shape[1] // n)
            _check(fused[i][:, cols], [pa[i][:, cols] for pa in parts], f"{name}, element {e}")
    e2, g2 = (np.asarray(o) for o in kernels.load_grad(element, effect, gauss).map(n)(X, P))
    _check(e2, [pa[0] for pa in parts], "_grad energy")
    _check(g2, [pa[1] for pa in parts], "_grad gradient")
    _check(np.asarray(kernels.load_energy(element, effect, gauss).map(n)(X, P)), [pa[0] for pa in parts], "_energy")
    batch = kernels.load_batch(element, effect, gauss)
    if gauss != registry.DEFAULT_GAUSS:
        assert batch is None  # batched at the default order only (registry.batched)
        return
    lanes = registry.BATCH_LANES
    for b, ref in ((batch, fused), (kernels.load_batch(element, effect, gauss, "_grad"), fused[:2])):
        got = [np.asarray(o) for o in b.map(n // lanes)(X, P)]
        for i, (a, r) in enumerate(zip(got, ref)):
            _check(a, [r, 0 * r], f"batched output {i}")


def _statics(monkeypatch, fuse: bool, strain: str, n: int, gauss: int):
    """solve_static of the zhang_cantilever setting with the fused kernel or with the two separate ones (the
    decoupled fusions hidden from registry.fused_effect), each on a newly built problem."""
    setup_cache.clear()
    if not fuse:
        orig = registry.fused_effect
        monkeypatch.setattr(registry, "fused_effect", lambda el, effs: None if any(
            e.startswith("axial_decoupled") for e in effs) else orig(el, effs))
    try:
        prob = StaticProblem(Assembly(zhang_scene(strain, n, gauss)))
        r = prob.solve(StaticOptions(), None)
        effects = {ft.effect for ft in prob.light.ev.fts}
        assert ("elastic_decoupled" in effects) == fuse and ("axial_decoupled" in effects) != fuse, effects
        if prob._biot is not None:  # the start: the same calls with the rod's Biot strain (member_effects.START_EFFECTS)
            start = {ft.effect for ft in prob._biot.ev.fts}
            assert start == ({"elastic_decoupled_biot"} if fuse else {"axial_decoupled_biot", "bending"}), start
        return r
    finally:
        monkeypatch.undo()
        setup_cache.clear()


@pytest.mark.parametrize("n,gauss", [(3, 3), (3, 5), (6, 3), (6, 5), (12, 3), (12, 5)])
def test_zhang_cantilever_decoupled_same_as_separate_kernels(monkeypatch, n, gauss):
    """Paper 000's cantilever (3 m, decoupled strain): the fused kernel's solve reaches the separate kernels' tip
    to 1e-12 m (both converge to the same discrete equilibrium; Newton's last update is quadratic in the error, so
    what is left between them is the kernels' round-off, ~1e-14 relative, through the tangent), with the same
    status, path and iterations."""
    a, b = (_statics(monkeypatch, fuse, "decoupled", n, gauss) for fuse in (True, False))
    assert a.status == b.status and a.success and a.iterations == b.iterations and a.path == b.path
    assert np.max(np.abs(np.asarray(a.tip("beam")) - np.asarray(b.tip("beam")))) < 1e-12
