"""gather_sum with targets that sum many entries (a body's coordinates in the contact blocks of every element on
its drum): the sparse-product path sums the same entries as the gathers; the belt's contact tangents are the same
with it as with gathers only."""
import os
import sys

import casadi as ca
import numpy as np

from ancf_sym.util import sparsity


def _sum(target, vals, n_out):
    x = ca.MX.sym("x", len(vals))
    f = ca.Function("g", [x], [sparsity.gather_sum([x], target, n_out)])
    return np.asarray(f(vals)).ravel()


def test_heavy_targets_sum_like_numpy():
    rng = np.random.default_rng(1)
    n_out, n_src = 40, 600
    # targets 0..2 take ~100 entries each (heavy), the rest a few, some dropped (-1)
    target = np.where(rng.random(n_src) < 0.5, rng.integers(0, 3, n_src), rng.integers(-1, n_out, n_src))
    vals = rng.standard_normal(n_src)
    ref = np.zeros(n_out)
    np.add.at(ref, target[target >= 0], vals[target >= 0])
    assert np.bincount(target[target >= 0]).max() > sparsity.GATHER_LEVELS  # the product path runs
    # the same terms summed in another order: round-off of ~100 unit terms, far below 1e-12
    assert np.allclose(_sum(target, vals, n_out), ref, rtol=0, atol=1e-12)


def test_belt_contact_tangents_unchanged(monkeypatch):
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples"))
    import belt_drive as BD

    from ancf_sym.model.assembly import Assembly
    from ancf_sym.system import damping
    from ancf_sym.system.step_system import StepSystem
    from ancf_sym.util.sparsity import dm

    asm = Assembly(BD.scene(0.15, 20.0, 20.0, 24))
    S = StepSystem.for_scene(asm)
    x = S.reduce(BD.start(asm, 0.15, 24, None))
    v = 0.3 * np.random.default_rng(0).standard_normal(S.nf)
    xf, vf = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
    X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
    outs = {}
    for levels in (10**9, sparsity.GATHER_LEVELS):  # gathers only; the product for the body's coordinates
        monkeypatch.setattr(sparsity, "GATHER_LEVELS", levels)
        f = ca.Function("c", [xf, vf], list(damping.contact_dissipation_mx(S, X, V)))
        outs[levels] = [np.asarray(ca.densify(o)) for o in f(x, v)]
    for a, b in zip(*outs.values()):
        # the same terms, possibly summed in another order: round-off relative to the largest entry
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
