"""casadi_buffers.bind: a Function evaluated in place on bound numpy arrays.

The buffer path and an ordinary call `f(*args)` run the same instructions (the compiled kernel's C code, or the same
SX/MX virtual machine) on the same double inputs, so their results are identical, not merely close: the tests
compare them exactly. A binding that read the wrong memory (wrong order, stale array, copy) gives different numbers.
"""
from __future__ import annotations

import gc

import casadi as ca
import numpy as np
import pytest

from ancf_sym import kernels
from ancf_sym.util.casadi_buffers import bind


def _called(f: ca.Function, args: list[np.ndarray]) -> list[np.ndarray]:
    """f called normally; each output's nonzeros in column-major order (what a bound result array holds)."""
    out = f(*[ca.DM(a.reshape(f.size_in(i), order="F")) for i, a in enumerate(args)])
    out = out if isinstance(out, (list, tuple)) else [out]
    return [np.asarray(ca.DM(o).nonzeros()) for o in out]


@pytest.fixture
def mapped_kernel():
    """The compiled cable2d elastic_green kernel mapped over 7 elements: (q[8 x 7], p[n x 7]) -> (E, G, H)."""
    k = kernels.load("cable2d", "elastic_green")
    f = k.map(7)
    rng = np.random.default_rng(1)
    X = np.linspace(0.0, 1.0, 8)[None, :] * (1.0 + 0.05 * rng.standard_normal((7, 8)))  # (N, nd) == (nd, N) F-order
    P = np.ones((7, f.size_in(1)[0]))
    res = (np.zeros(7), np.zeros((7, 8)), np.zeros((7, 8, 8)))
    return f, X, P, res


def test_results_equal_the_ordinary_call(mapped_kernel):
    f, X, P, res = mapped_kernel
    buf, ev = bind(f, (X, P), res)
    ev()
    for got, ref in zip(res, _called(f, [X.ravel(), P.ravel()])):
        np.testing.assert_array_equal(got.ravel(), ref)
    assert np.abs(res[2]).max() > 0  # (the Hessian of a strained element is not zero: the call did write)


def test_arrays_are_used_in_place_without_copies(mapped_kernel):
    """Writing an input array in place and evaluating again updates the same result arrays (no copy on either
    side); the buffer keeps exactly the caller's arrays."""
    f, X, P, res = mapped_kernel
    buf, ev = bind(f, (X, P), res)
    ids = [id(r) for r in res]
    ev()
    first = [r.copy() for r in res]
    X[:] *= 1.01  # stretch every element by 1 %
    ev()
    assert [id(r) for r in res] == ids
    assert not np.array_equal(res[0], first[0])
    for got, ref in zip(res, _called(f, [X.ravel(), P.ravel()])):
        np.testing.assert_array_equal(got.ravel(), ref)
    args, outs = buf.bound_arrays
    assert args[0] is X and args[1] is P and all(a is b for a, b in zip(outs, res))


def test_rebinding_a_pooled_buffer_and_sparse_outputs():
    """A buffer bound anew (as the graph cache's pool does) writes into the new arrays only; a sparse output is
    bound as its nonzeros."""
    x = ca.SX.sym("x", 3)
    f = ca.Function("f", [x], [ca.diag(x * x)], ["x"], ["D"])  # 3 x 3 with 3 nonzeros
    a, r = np.array([1.0, 2.0, 3.0]), np.zeros(3)
    pair = bind(f, (a,), (r,))
    a2, r2 = np.array([4.0, 5.0, 6.0]), np.zeros(3)
    buf, ev = bind(f, (a2,), (r2,), pair)
    assert buf is pair[0]
    ev()
    np.testing.assert_array_equal(r2, [16.0, 25.0, 36.0])
    np.testing.assert_array_equal(r, 0.0)


def test_rebinding_with_some_of_the_same_arrays():
    """A pooled buffer bound again with some of the arrays it holds (not set again) and some new ones reads and
    writes exactly the arrays of the last binding: the kept ones in place, the new ones instead of the old."""
    x, y = ca.SX.sym("x", 2), ca.SX.sym("y", 2)
    f = ca.Function("f", [x, y], [x * y, x + y])
    a, b, r, s = np.array([1.0, 2.0]), np.array([3.0, 4.0]), np.zeros(2), np.zeros(2)
    pair = bind(f, (a, b), (r, s))
    b2, s2 = np.array([5.0, 6.0]), np.zeros(2)
    buf, ev = bind(f, (a, b2), (r, s2), pair)
    a[:] = [7.0, 8.0]
    ev()
    np.testing.assert_array_equal(r, [35.0, 48.0])
    np.testing.assert_array_equal(s2, [12.0, 14.0])
    np.testing.assert_array_equal(s, 0.0)
    assert buf.bound_arrays == ((a, b2), (r, s2))


def test_buffer_keeps_temporaries_alive():
    """CasADi holds raw pointers only: arrays created in the call must live as long as the buffer."""
    x = ca.SX.sym("x", 4)
    f = ca.Function("f", [x], [2 * x])
    buf, ev = bind(f, (np.arange(4.0),), (np.zeros(4),))
    gc.collect()
    [np.ones(4) * 7 for _ in range(100)]  # (would reuse freed memory)
    ev()
    np.testing.assert_array_equal(buf.bound_arrays[1][0], [0.0, 2.0, 4.0, 6.0])


@pytest.mark.parametrize("bad, err, words", [
    (np.zeros(5), ValueError, "input 0 (x) has 5 numbers, expected 4"),
    (np.zeros(4, dtype=np.float32), TypeError, "input 0 (x) must be a contiguous float64 numpy array, got float32"),
    (np.zeros(8)[::2], TypeError, "not contiguous"),
    ([0.0, 0.0, 0.0, 0.0], TypeError, "got list"),
])
def test_bad_arrays_named_before_binding(bad, err, words):
    x = ca.SX.sym("x", 4)
    f = ca.Function("f", [x], [2 * x], ["x"], ["y"])
    with pytest.raises(err) as e:
        bind(f, (bad,), (np.zeros(4),))
    assert words in str(e.value)
    with pytest.raises(ValueError, match="output 0 \\(y\\) has 3 numbers"):
        bind(f, (np.zeros(4),), (np.zeros(3),))
    with pytest.raises(ValueError, match="2 inputs given, it has 1"):
        bind(f, (np.zeros(4), np.zeros(4)), (np.zeros(4),))
