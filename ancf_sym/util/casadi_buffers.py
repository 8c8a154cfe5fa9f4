"""Evaluate a CasADi Function in place on numpy arrays, through its buffer interface.

`Function.buffer()` gives a (FunctionBuffer, evaluate) pair; once each input and output is bound to a numpy array,
`evaluate()` reads the inputs and writes the outputs in those arrays with no conversion or allocation, which for a
small kernel is most of the cost of `f(*args)`. `bind` is the one place that binds them, and it checks the arrays
first: CasADi reads raw memory, so a wrong dtype or a strided view would be read as garbage rather than raise.

The hot path calls the returned `evaluate` directly (it is CasADi's own callable, nothing wraps it).
"""
from __future__ import annotations

import weakref
from typing import Callable, Sequence

import casadi as ca
import numpy as np

Evaluate = Callable[[], None]
BufferPair = tuple[ca.FunctionBuffer, Evaluate]
_F64 = np.dtype(np.float64)  # (native byte order)


def _sizes(f: ca.Function) -> tuple[int, int, int, int]:
    """(n_in, n_out, nnz_in, nnz_out) of f, asked of CasADi once per Function object (~1 us each call) and kept on
    it: a run binds the same cached functions again."""
    try:
        return f.ancf_sym_sizes
    except AttributeError:
        f.ancf_sym_sizes = sizes = (f.n_in(), f.n_out(), f.nnz_in(), f.nnz_out())
        return sizes


def _check(f: ca.Function, kind: str, arrays: Sequence[np.ndarray]) -> None:
    """Contiguous float64 arrays of exactly the nonzeros of inputs/outputs 0.. (kind "input" or "output")."""
    n_in = kind == "input"
    n_i, n_o, nnz_i, nnz_o = _sizes(f)
    n = n_i if n_in else n_o
    if len(arrays) > n:
        raise ValueError(f"{f.name()}: {len(arrays)} {kind}s given, it has {n}")
    for a in arrays:
        if not (isinstance(a, np.ndarray) and a.dtype == _F64 and a.flags.c_contiguous):
            break
    else:  # (one call for the total: nnz_in(i) costs ~5 us each; CasADi itself refuses a buffer that is too small)
        if len(arrays) == n and sum(a.size for a in arrays) == (nnz_i if n_in else nnz_o):
            return
    for i, a in enumerate(arrays):  # name the offending array
        name = f.name_in(i) if n_in else f.name_out(i)
        if not isinstance(a, np.ndarray) or a.dtype != _F64 or not a.flags.c_contiguous:
            what = type(a).__name__ if not isinstance(a, np.ndarray) else \
                f"{a.dtype} array" + ("" if a.flags.c_contiguous else " (not contiguous)")
            raise TypeError(f"{f.name()}: {kind} {i} ({name}) must be a contiguous float64 numpy array, got {what}")
        nnz = f.nnz_in(i) if n_in else f.nnz_out(i)
        if a.size != nnz:
            raise ValueError(f"{f.name()}: {kind} {i} ({name}) has {a.size} numbers, expected {nnz} (its nonzeros)")


def bind(f: ca.Function, args: Sequence[np.ndarray], res: Sequence[np.ndarray],
         buffer: BufferPair | None = None) -> BufferPair:
    """Bind inputs 0.. of f to `args` and outputs 0.. to `res`; return (buffer, evaluate).

    f: the Function (its sizes check the arrays). args, res: contiguous float64 arrays holding exactly the
    nonzeros of each input/output in column-major order (a dense (m, n) input is an (n, m) C array, or flat);
    fewer than f.n_in()/f.n_out() leaves the rest unbound (inputs read as zero, outputs not written).
    buffer: a pair from `f.buffer()` to bind anew (e.g. one reused from a pool); a new one by default.

    The arrays are used in place, never copied: write inputs with `a[:] = ...`, and read results after
    `evaluate()`. Keep the returned buffer alive while evaluating (`evaluate` does not hold it); it keeps the
    bound arrays alive."""
    _check(f, "input", args)
    _check(f, "output", res)
    buf, evaluate = f.buffer() if buffer is None else buffer
    # (a pooled buffer keeps the arrays it was bound to: those bound again at the same place are not set again)
    old_args, old_res = getattr(buf, "bound_arrays", ((), ()))
    for i, a in enumerate(args):
        if i >= len(old_args) or old_args[i] is not a:
            buf.set_arg(i, memoryview(a))
    for i, r in enumerate(res):
        if i >= len(old_res) or old_res[i] is not r:
            buf.set_res(i, memoryview(r))
    buf.bound_arrays = (tuple(args), tuple(res))  # CasADi holds raw pointers: the buffer keeps their owners alive
    return buf, evaluate


def pooled(pool: list, f: ca.Function, owner: object) -> BufferPair:
    """f.buffer() from `pool` (a buffer of a collected owner), else a new one; it returns to the pool when `owner`
    is collected. The caller binds every argument and result anew (`bind`), or keeps the pooled arrays it put in
    the pool with it."""
    be = pool.pop() if pool else f.buffer()
    weakref.finalize(owner, pool.append, be)
    return be
