"""The kernel Newton loop of statics as one compiled call: the binding of csrc/newton_loop.c.

KernelNewton's loop (statics.newton: full Newton steps by LAPACK's banded Cholesky, the banded LU and diagonal
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
from ctypes import c_char_p, c_double, c_int, c_longlong, c_void_p, py_object

import numpy as np
from scipy.linalg import cython_lapack

from ancf_sym import kernels, registry
from ancf_sym.statics import criteria as sn

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
    _fields_ = [("x0", c_void_p)] + [(k, c_double) for k in ("tol", "work", "load", "max_step", "finish")] + \
               [("max_iter", c_longlong)] + [(k, c_void_p) for k in ("hist", "x_out", "x_eval")] + \
               [(k, c_longlong) for k in ("status", "iterations", "nhist", "evaluations", "indefinite", "shifted",
                                          "stable")] + \
               [(k, c_double) for k in ("inc", "dec", "floor", "energy", "mu", "prev_inc", "ev_energy", "potential")]


@functools.lru_cache(maxsize=1)
def _library() -> ctypes.PyDLL:
    lib = ctypes.PyDLL(str(kernels.library_path(LIBRARY)))  # PyDLL: the GIL held, for the signal check
    lib.nl_solve.argtypes, lib.nl_solve.restype = [c_void_p, c_void_p], c_int  # (_Problem, _Run)
    lib.nl_sum.argtypes, lib.nl_sum.restype = [c_void_p, c_longlong, c_longlong], c_double
    return lib


@functools.lru_cache(maxsize=None)
def _kernel_library(path: str) -> ctypes.CDLL:
    return ctypes.CDLL(path)


@functools.lru_cache(maxsize=None)
def _kernel(element: str, effect: str, gauss: int | None, batched: bool) -> tuple[int, tuple[int, ...]]:
    """(address of the compiled kernel, its work sizes (arg, res, iw, w)): the function casadi.external loads."""
    lib = _kernel_library(str(kernels.library_path(registry.library_name(element, effect))))
    name = registry.kernel_name(element, effect, gauss) + (registry.BATCH_SUFFIX if batched else "")
    sizes = [c_longlong() for _ in range(4)]
    getattr(lib, name + "_work")(*(ctypes.byref(s) for s in sizes))
    return ctypes.cast(getattr(lib, name), c_void_p).value, tuple(s.value for s in sizes)


@functools.lru_cache(maxsize=1)
def _check_signals() -> int:
    return ctypes.cast(ctypes.pythonapi.PyErr_CheckSignals, c_void_p).value


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


class _Block:
    """Arrays side by side in one allocation: one address to ask numpy for (~1.5 us each), the others offsets."""

    def __init__(self, dtype, sizes: dict):
        self.at, total = {}, 0
        for name, m in sizes.items():
            self.at[name] = (total, int(m))
            total += int(m)
        self.array = np.zeros(max(total, 1), dtype)
        self.base = self.array.ctypes.data

    def __getitem__(self, name: str) -> np.ndarray:
        o, m = self.at[name]
        return self.array[o:o + m]

    def ptr(self, name: str) -> int:
        return self.base + self.array.itemsize * self.at[name][0]


class CompiledLoop:
    """One KernelNewton's loop in C, every pointer and array bound once. `run` returns (status, the run's
    figures) or None where the solve must run in Python (see the module docstring). KernelNewton's x, dz, p and
    norms become views of the loop's buffer (the C loop writes them, the Python loop too)."""

    def __init__(self, newton):
        R, ev = newton.S, newton.ev
        nf, n, bw = R.nf, len(R.part.pos), ev.bw
        self.newton, self.nf, self.n = newton, nf, n
        calls = [(ft, N, _i64(idx), X, P, local)
                 for ft, N, (idx, X, P, _, _, local) in zip(ev.fts, ev.padded, ev.calls)]
        fns = [_kernel(ft.element, ft.effect, ft.gauss, registry.has_batch(ft.element, ft.effect, ft.gauss))
               for ft, *_ in calls]
        sz_arg, sz_res, sz_iw, sz_w = (max([f[1][i] for f in fns] + [least]) for i, least in enumerate((2, 3, 1, 1)))
        vec, full = ("d", "r", "sol", "dz_try", "xt", "x", "dz", "p", "f_lin", "scale"), \
            ("xfull", "xtry", "x_eval", "x0", "x_out", "c", "f_lin_full")
        F = self._f = _Block(np.float64, {
            "g": nf + 1, "band": (bw + 1) * nf + 1, "ab": (bw + 1) * nf, "lu": (3 * bw + 1) * nf, "norms": 5,
            "tmp": max(n, nf, ev.E.size), "w": sz_w, **{k: nf for k in vec}, **{k: n for k in full}})
        locals_ = {f"{k}{t}": len(c[5][0]) for t, c in enumerate(calls) if c[5] is not None for k in ("dst", "src")}
        I = self._i = _Block(np.int64, {"gather": n, "roots": nf, "ipiv": nf // 2 + 1, "iw": sz_iw, **locals_})
        for B, name, a in ((F, "c", R.part.c), (F, "f_lin", R.f_lin), (F, "f_lin_full", R.f_lin_full),
                           (F, "scale", newton.scale), (I, "gather", R.gather), (I, "roots", R.part.roots)):
            B[name][:] = a
        for name in ("x", "dz", "p", "norms"):  # KernelNewton's arrays move into the buffer
            F[name][:] = getattr(newton, name)
            setattr(newton, name, F[name])

        terms = (_Term * len(calls))()
        arg, res = (c_void_p * sz_arg)(), (c_void_p * sz_res)()  # (one kernel call at a time: shared work)
        e0 = g0 = h0 = 0  # the outputs' places in the evaluation's E, G, H (ReducedEvaluation._bind: side by side)
        E, G, H = (a.ctypes.data for a in (ev.E, ev.G, ev.H))
        for t, (ft, N, idx, X, P, local), (f, _) in zip(range(len(calls)), calls, fns):
            T = terms[t]
            lanes = registry.BATCH_LANES if registry.has_batch(ft.element, ft.effect, ft.gauss) else 1
            assert N % lanes == 0, "padded to whole batches (statics.evaluation's padding)"
            T.f, T.lanes, T.N, T.nd, T.np = f, lanes, N, ft.nd, P.shape[1]
            T.idx, T.X, T.P = idx.ctypes.data, X.ctypes.data, P.ctypes.data
            T.E, T.G, T.H = E + 8 * e0, G + 8 * g0, H + 8 * h0
            e0, g0, h0 = e0 + N, g0 + N * ft.nd, h0 + N * ft.nd * ft.nd
            if local is not None:
                I[f"dst{t}"][:], I[f"src{t}"][:] = local
                T.nlocal, T.ldst, T.lsrc = len(local[0]), I.ptr(f"dst{t}"), I.ptr(f"src{t}")
            T.arg, T.res, T.iw, T.w = ctypes.addressof(arg), ctypes.addressof(res), I.ptr("iw"), F.ptr("w")
        real = None if ev.real is None else _i64(ev.real)
        gpos, hband = _i64(ev.gpos), _i64(ev.hband)
        # every array and ctypes object the C side points into
        self._keep = [calls, terms, arg, res, ev.E, ev.G, ev.H, real, gpos, hband]
        self.g, self.x_eval, self._x0, self._x = F["g"], F["x_eval"], F["x0"], F["x_out"]
        P = self.problem = _Problem(
            nf=nf, n=n, bw=bw, nterms=len(calls), terms=ctypes.addressof(terms),
            gather=I.ptr("gather"), roots=I.ptr("roots"), span=float(newton.span), E=E, G=G, H=H,
            real=None if real is None else real.ctypes.data, gpos=gpos.ctypes.data, hband=hband.ctypes.data,
            ne=ev.E.size, nreal=0 if real is None else real.size, ng=ev.G.size, nh=ev.H.size,
            sum_block=sum_block(), fac=F.ptr("lu"),  # (the LU's storage holds the Cholesky factor too: never both)
            ipiv=I.ptr("ipiv"), dpbtrf=_lapack("dpbtrf"), dpbtrs=_lapack("dpbtrs"), dgbsv=_lapack("dgbsv"),
            check_signals=_check_signals(),
            k=_Constants(stall=sn.STALL, round_off=sn.ROUND_OFF, shift=sn.SHIFT, shift_max=sn.SHIFT_MAX,
                         shift_below=sn.SHIFT_BELOW, wild=sn.WILD, stall_count=sn.STALL_COUNT,
                         no_progress=sn.NO_PROGRESS),
            **{k: F.ptr(k) for k in ("c", "f_lin", "f_lin_full", "scale", "g", "band", "ab", "lu", "tmp", "norms",
                                     "xfull", "xtry", "x", "dz", "p", "d", "r", "sol", "dz_try", "xt")})
        self._hist = np.zeros(0)
        self._run = _Run(x0=F.ptr("x0"), x_out=F.ptr("x_out"), x_eval=F.ptr("x_eval"))
        self._solve = _library().nl_solve
        self._p, self._r = ctypes.addressof(P), ctypes.addressof(self._run)

    def run(self, x_full: np.ndarray, tol: float, max_iter: int, work: float, load: float, max_step: float,
            finish: float = 0.0):
        """The loop from x_full: None where the Python loop must run this solve, else (status, iterations, x,
        increment, decrement, residual floor, history, potential, stable). finish > 0: a converged run also
        evaluates the answer, its potential and whether its tangent + finish x max |K_ii| I is positive definite
        (True / False, None where the diagonal is zero); else NaN and None. (Its cost around the C call is ~5 us:
        every pointer but the history's is fixed.)"""
        run, max_iter = self._run, max(int(max_iter), 0)
        self._x0[:] = x_full
        if self._hist.size < 2 * max_iter:
            self._hist = np.zeros(2 * max_iter)
            run.hist = self._hist.ctypes.data
        run.tol, run.work, run.load, run.max_step, run.max_iter = tol, work, load, max_step, max_iter
        run.finish = finish
        run.status = run.evaluations = -1  # (a run under way: both set by the C loop)
        try:
            status = self._solve(self._p, self._r)
        finally:  # (also after Ctrl-C): the evaluation and KernelNewton hold the loop's last values
            if run.status >= 0:
                nw, ev = self.newton, self.newton.ev
                ev.at, ev.energy, ev.g, ev.pen_hessian = self.x_eval.copy(), run.ev_energy, self.g[:self.nf].copy(), None
                nw.energy, nw.mu, nw.prev_inc, nw.trial, nw.load = run.energy, run.mu, run.prev_inc, None, load
        if status == SINGULAR:
            return None
        h = self._hist[:2 * run.nhist].tolist()
        return (STATUS[status], run.iterations, self._x.copy(), run.inc, run.dec, run.floor, [*zip(h[::2], h[1::2])],
                run.potential, None if run.stable < 0 else bool(run.stable))

    @property
    def counts(self) -> dict:
        """The last run's kernel evaluations, tangents found not positive definite, and shifted steps taken."""
        r = self._run
        return {"evaluations": r.evaluations, "indefinite": r.indefinite, "shifted": r.shifted}


def compiled_loop(newton) -> CompiledLoop | None:
    """The C loop for a KernelNewton, None where its evaluation needs the Python loop: penalty springs, a band
    wider than BAND_LIMIT, no free coordinate, element-local columns beyond LOCAL_MAX, a contact step limit
    (penalty drums, ancf_sym.contact.steps)."""
    ev = newton.ev
    if ev.pen is not None or ev.hband is None or newton.S.nf == 0 or newton.step_limit is not None:
        return None
    if any(local is not None and len(local[0]) > LOCAL_MAX for *_, local in ev.calls):
        return None
    return CompiledLoop(newton)


