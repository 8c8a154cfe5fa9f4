"""util.sparsity.gather_sum: out[t] sums the source entries aimed at t, left to right in source order, whether a
level of the sum is a gather of every target or an update of the few targets with that many terms."""
import casadi as ca
import numpy as np

from ancf_sym.util import sparsity


def test_gather_sum_is_the_ordered_sum_bit_for_bit():
    """Targets with 0 to 12 terms (most with 1-2, a few with many: the levels past the second update a small subset)
    and dropped entries (-1): every output equals the left-to-right sum in source order exactly (the same floating
    point additions in the same order), and the sum of the terms to round-off (1e-12 relative)."""
    rng = np.random.default_rng(0)
    n_out = 400
    counts = np.where(rng.random(n_out) < 0.9, rng.integers(0, 3, n_out), rng.integers(3, 13, n_out))
    target = rng.permutation(np.concatenate([np.repeat(np.arange(n_out), counts), -np.ones(50, dtype=int)]))
    vals = rng.normal(size=len(target)) * 10.0 ** rng.integers(-8, 8, len(target))
    parts = np.split(vals, [100, 700])
    x = [ca.MX.sym(f"v{k}", len(p)) for k, p in enumerate(parts)]
    f = ca.Function("f", x, [sparsity.gather_sum(x, target, n_out)])
    got = np.asarray(f(*parts)).ravel()
    ref = np.zeros(n_out)
    seen = np.zeros(n_out, bool)
    for v, t in zip(vals, target):  # left to right in source order
        if t >= 0:
            ref[t] = v if not seen[t] else ref[t] + v
            seen[t] = True
    assert np.array_equal(got, ref)
    assert np.allclose(got, np.bincount(target[target >= 0], vals[target >= 0], minlength=n_out), rtol=1e-12,
                       atol=0)
    assert np.count_nonzero(counts > 2) * sparsity.GATHER_SUBSET < n_out  # (levels 3.. took the subset updates)
