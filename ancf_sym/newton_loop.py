"""The kernel Newton loop of statics as one compiled call: the binding of csrc/newton_loop.c.

KernelNewton's loop (statics_newton: full Newton steps by LAPACK's banded Cholesky, the banded LU and diagonal
shifts where the tangent is not positive definite, the convergence, stall, round-off and divergence tests) spends
most of a small problem's iteration in Python and numpy: ~55-65 us per iteration against ~8-15 us of kernels and
LAPACK on 6 - 18 elements. The C loop runs every iteration in one call. It links to nothing: the compiled kernels
(CasADi's calling convention, the 4-lane batched `_x4` functions where the evaluation uses them), LAPACK's dpbtrf,
dpbtrs and dgbsv (the pointers SciPy exports in scipy.linalg.cython_lapack) and Python's signal check reach it as
function pointers, bound here once per KernelNewton (the Biot start's evaluation is another one). It works on the
evaluation's own buffers (ReducedEvaluation's kernel inputs and outputs) and on KernelNewton's arrays (x, dz, p,
norms), so both hold the last iteration's values afterwards, as after the Python loop.

Scenes it takes: no penalty springs, a band within BAND_LIMIT and at least one free coordinate (decided once per
KernelNewton; the others keep the Python loop). Where the Python loop would turn to a sparse factorisation (a band
the LU finds singular and no shift repairs) the C loop stops and that solve runs again in Python, from its start.

Ctrl-C: the loop calls Python's signal check (PyErr_CheckSignals; the library is loaded with the GIL held) before
every iteration, so an interrupt stops a solve between two iterations at any mesh size, as in the Python loop.
"""
from __future__ import annotations

import ctypes
import functools
from ctypes import POINTER, c_char_p, c_double, c_int, c_longlong, c_void_p, py_object

import numpy as np
from scipy.linalg import cython_lapack

from . import kernels, registry

LIBRARY = "newton_loop"  # csrc/newton_loop.c, compiled by setup.py into ancf_sym/_kernels
STATUS = ("converged", "round_off", "stalled", "diverged", "not_finite", "max_iter")
SINGULAR = 6  # the Python loop's sparse fallback is needed: run the solve in Python
LOCAL_MAX = 64  # element-local columns the C loop holds per element


class _Constants(ctypes.Structure):
    _fields_ = [(k, c_double) for k in ("stall", "round_off", "shift", "shift_max", "shift_below", "wild")] + \
               [("stall_count", c_longlong), ("no_progress", c_longlong)]


class _Term(ctypes.Structure):
    _fields_ = [("f", c_void_p)] + [(k, c_longlong) for k in ("lanes", "N", "nd", "np", "nlocal")] + \
               [(k, c_void_p) for k in ("idx", "X", "P", "E", "G", "H", "ldst", "lsrc", "arg", "res", "iw", "w")]


class _Problem(ctypes.Structure):
    _fields_ = [(k, c_longlong) for k in ("nf", "n", "bw", "nterms")] + [("terms", c_void_p)] + \
               [(k, c_void_p) for k in ("gather", "roots", "c", "f_lin", "f_lin_full", "scale")] + \
               [("span", c_double)] + [(k, c_void_p) for k in ("E", "G", "H", "real", "gpos", "hband")] + \
               [(k, c_longlong) for k in ("ne", "nreal", "ng", "nh", "sum_block")] + \
               [(k, c_void_p) for k in ("g", "band", "ab", "fac", "lu", "d", "r", "sol", "dz_try", "xt", "tmp",
                                        "x", "dz", "p", "norms", "xfull", "xtry", "ipiv",
                                        "dpbtrf", "dpbtrs", "dgbsv", "check_signals")] + \
               [("k", _Constants)]


class _Run(ctypes.Structure):
    _fields_ = [("x0", c_void_p)] + [(k, c_double) for k in ("tol", "work", "load", "max_step")] + \
               [("max_iter", c_longlong)] + [(k, c_void_p) for k in ("hist", "x_out", "x_eval")] + \
               [(k, c_longlong) for k in ("status", "iterations", "nhist", "evaluations", "indefinite", "shifted")] + \
               [(k, c_double) for k in ("inc", "dec", "floor", "energy", "mu", "prev_inc", "ev_energy")]


@functools.lru_cache(maxsize=1)
def _library() -> ctypes.PyDLL:
    lib = ctypes.PyDLL(str(kernels.library_path(LIBRARY)))  # PyDLL: the GIL held, for the signal check
    lib.nl_solve.argtypes, lib.nl_solve.restype = [POINTER(_Problem), POINTER(_Run)], c_int
    lib.nl_sum.argtypes, lib.nl_sum.restype = [c_void_p, c_longlong, c_longlong], c_double
    return lib


@functools.lru_cache(maxsize=None)
def _kernel_library(path: str) -> ctypes.CDLL:
    return ctypes.CDLL(path)


def _kernel(element: str, effect: str, gauss: int | None, batched: bool) -> tuple[int, tuple[int, ...]]:
    """(address of the compiled kernel, its work sizes (arg, res, iw, w)): the function casadi.external loads."""
    lib = _kernel_library(str(kernels.library_path(registry.library_name(element, effect))))
    name = registry.kernel_name(element, effect, gauss) + (registry.BATCH_SUFFIX if batched else "")
    sizes = [c_longlong() for _ in range(4)]
    getattr(lib, name + "_work")(*(ctypes.byref(s) for s in sizes))
    return ctypes.cast(getattr(lib, name), c_void_p).value, tuple(s.value for s in sizes)


@functools.lru_cache(maxsize=None)
def _lapack(name: str) -> int:
    """Address of SciPy's LAPACK routine (scipy.linalg.cython_lapack; Fortran convention, arguments by pointer)."""
    capsule = cython_lapack.__pyx_capi__[name]
    api = ctypes.pythonapi
    api.PyCapsule_GetName.argtypes, api.PyCapsule_GetName.restype = [py_object], c_char_p
    api.PyCapsule_GetPointer.argtypes, api.PyCapsule_GetPointer.restype = [py_object, c_char_p], c_void_p
    return api.PyCapsule_GetPointer(capsule, api.PyCapsule_GetName(capsule))


@functools.lru_cache(maxsize=1)
def sum_block() -> int:
    """How np.sum adds a long contiguous array on this numpy: one pairwise sum (0), or pairwise sums of buffered
    blocks of np.getbufsize() entries (numpy 1.x). The C loop sums alike, so both loops compare the same potentials
    and decrements to the last bit."""
    lib, b = _library(), int(np.getbufsize())
    n = 3 * b + 5
    k = np.arange(n)
    a = np.sin(0.7 * k) * 10.0 ** (k % 13 - 6)
    for block in (0, b):
        if lib.nl_sum(a.ctypes.data, n, block) == float(a.sum()):
            return block
    return 0


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _ptr(a: np.ndarray | None) -> int | None:
    return None if a is None else a.ctypes.data


class CompiledLoop:
    """One KernelNewton's loop in C, every pointer and array bound once. `run` returns (status, the run's
    figures) or None where the solve must run in Python (see the module docstring)."""

    def __init__(self, newton):
        from . import statics_newton as sn  # (its constants: one home)
        R, ev = newton.S, newton.ev
        nf, n, bw = R.nf, len(R.part.pos), ev.bw
        self.newton, self.nf, self.n = newton, nf, n
        keep = self._keep = []  # every array and ctypes object the C side points into

        def hold(a):
            keep.append(a)
            return _ptr(a)

        terms = (_Term * len(ev.calls))()
        e0 = g0 = h0 = 0  # the outputs' places in the evaluation's E, G, H (ReducedEvaluation._bind: side by side)
        for t, ft, N, (idx, X, P, _, _, local) in zip(terms, ev.fts, ev._n, ev.calls):
            batched = registry.has_batch(ft.element, ft.effect, ft.gauss)
            lanes = registry.BATCH_LANES if batched else 1
            assert N % lanes == 0, "padded to whole batches (statics_eval._padded)"
            t.f, (sz_arg, sz_res, sz_iw, sz_w) = _kernel(ft.element, ft.effect, ft.gauss, batched)
            t.lanes, t.N, t.nd, t.np = lanes, N, ft.nd, P.shape[1]
            t.idx, t.X, t.P = hold(_i64(idx)), _ptr(X), _ptr(P)
            t.E, t.G, t.H = (a.ctypes.data + a.itemsize * o for a, o in ((ev.E, e0), (ev.G, g0), (ev.H, h0)))
            e0, g0, h0 = e0 + N, g0 + N * ft.nd, h0 + N * ft.nd * ft.nd
            if local is not None:
                t.nlocal, t.ldst, t.lsrc = len(local[0]), hold(_i64(local[0])), hold(_i64(local[1]))
            arg, res = (c_void_p * max(sz_arg, 2))(), (c_void_p * max(sz_res, 3))()
            t.arg, t.res = ctypes.addressof(arg), ctypes.addressof(res)
            t.iw, t.w = hold(np.zeros(max(sz_iw, 1), np.int64)), hold(np.zeros(max(sz_w, 1)))
            keep += [arg, res, X, P]
        keep += [terms, ev.E, ev.G, ev.H]

        f64 = lambda m: np.zeros(max(m, 1))  # noqa: E731 (work arrays)
        self.g, self.x_eval = f64(nf + 1), np.zeros(n)
        real = None if ev._real is None else _i64(ev._real)
        lu = f64((3 * bw + 1) * nf)  # the banded LU's storage, also the Cholesky factor's (never both at once)
        P = self.problem = _Problem(
            nf=nf, n=n, bw=bw, nterms=len(terms), terms=ctypes.addressof(terms),
            gather=hold(_i64(R._gather)), roots=hold(_i64(R.part.roots)), c=hold(np.ascontiguousarray(R.part.c, float)),
            f_lin=hold(np.ascontiguousarray(R.f_lin, float)), f_lin_full=hold(np.ascontiguousarray(R.f_lin_full, float)),
            scale=hold(np.ascontiguousarray(newton.scale, float)), span=float(newton.span),
            E=_ptr(ev.E), G=_ptr(ev.G), H=_ptr(ev.H), real=hold(real), gpos=hold(_i64(ev._gpos)),
            hband=hold(_i64(ev._hband)), ne=ev.E.size, nreal=0 if real is None else real.size, ng=ev.G.size,
            nh=ev.H.size, sum_block=sum_block(),
            g=hold(self.g), band=hold(f64((bw + 1) * nf + 1)), ab=hold(f64((bw + 1) * nf)),
            fac=hold(lu), lu=_ptr(lu), d=hold(f64(nf)), r=hold(f64(nf)),
            sol=hold(f64(nf)), dz_try=hold(f64(nf)), xt=hold(f64(nf)), tmp=hold(f64(max(n, nf, ev.E.size))),
            x=_ptr(newton.x), dz=_ptr(newton.dz), p=_ptr(newton.p), norms=_ptr(newton.norms),
            xfull=hold(f64(n)), xtry=hold(f64(n)), ipiv=hold(np.zeros(nf, np.intc)),
            dpbtrf=_lapack("dpbtrf"), dpbtrs=_lapack("dpbtrs"), dgbsv=_lapack("dgbsv"),
            check_signals=ctypes.cast(ctypes.pythonapi.PyErr_CheckSignals, c_void_p).value,
            k=_Constants(stall=sn.STALL, round_off=sn.ROUND_OFF, shift=sn.SHIFT, shift_max=sn.SHIFT_MAX,
                         shift_below=sn.SHIFT_BELOW, wild=sn.WILD, stall_count=sn.STALL_COUNT,
                         no_progress=sn.NO_PROGRESS))
        self._run = _Run(x_eval=_ptr(self.x_eval))
        self._hist = np.zeros(0)
        self._solve = _library().nl_solve
        self._args = (ctypes.byref(P), ctypes.byref(self._run))

    def run(self, x_full: np.ndarray, tol: float, max_iter: int, work: float, load: float, max_step: float):
        """The loop from x_full: None where the Python loop must run this solve, else (status, iterations, x,
        increment, decrement, residual floor, history)."""
        nw, ev, run = self.newton, self.newton.ev, self._run
        x0 = np.ascontiguousarray(x_full, dtype=float)
        max_iter = max(int(max_iter), 0)
        if self._hist.size < 2 * max_iter:
            self._hist = np.zeros(2 * max_iter)
        x = np.empty(self.n)
        run.x0, run.tol, run.work, run.load, run.max_step = x0.ctypes.data, tol, work, load, max_step
        run.max_iter, run.hist, run.x_out = max_iter, self._hist.ctypes.data, x.ctypes.data
        run.status = -1
        try:
            status = self._solve(*self._args)
        finally:  # (also after Ctrl-C): the evaluation and KernelNewton hold the loop's last values
            if run.status >= 0:
                ev.at, ev.energy, ev.g, ev._pen = self.x_eval.copy(), run.ev_energy, self.g[:self.nf].copy(), None
                nw.energy, nw._mu, nw._prev_inc, nw._trial, nw.load = run.energy, run.mu, run.prev_inc, None, load
        if status == SINGULAR:
            return None
        h = self._hist[:2 * run.nhist].tolist()
        return (STATUS[status], run.iterations, x, run.inc, run.dec, run.floor, list(zip(h[0::2], h[1::2])))


    @property
    def counts(self) -> dict:
        """The last run's kernel evaluations, tangents found not positive definite, and shifted steps taken."""
        r = self._run
        return {"evaluations": r.evaluations, "indefinite": r.indefinite, "shifted": r.shifted}


def compiled_loop(newton) -> CompiledLoop | None:
    """The C loop for a KernelNewton, None where its evaluation needs the Python loop: penalty springs, a band
    wider than BAND_LIMIT, no free coordinate, element-local columns beyond LOCAL_MAX."""
    ev = newton.ev
    if ev.pen is not None or ev._hband is None or newton.S.nf == 0:
        return None
    if any(local is not None and len(local[0]) > LOCAL_MAX for *_, local in ev.calls):
        return None
    return CompiledLoop(newton)


