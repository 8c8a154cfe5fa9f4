"""Compiled step graphs cached by scene structure, in the process.

A StepSystem's graphs bake in the pattern of the equations (elements, kernels, gathers, sparsity) and a few values
(mass matrix, fixed coordinates, damping, penalties, constraints, scales); element parameters (E, section, lengths),
constant and time loads, the step size and the initial state are inputs. `structure_key` hashes what is baked in,
so runs that differ only in the inputs share the graphs (and the integrators' step and chunk functions, and the
buffers those allocate).
"""
from __future__ import annotations

import hashlib
import weakref
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np
import scipy.sparse as sp

from .. import contact, setup_cache
from ..assembly import MAPPED_CALLS

if TYPE_CHECKING:
    from .step_system import StepSystem

# structure key -> the StepSystem's compiled functions (and the in-graph factor, buffers)
SYSTEM_GRAPHS: dict = {}
# (structure key, scheme, Newton options, in-graph factor, further iterations) -> alpha step and chunk functions
ALPHA_GRAPHS: dict = {}
# functions that depend on no scene (the alpha steps' scalar Newton logic, by options): built once per process,
# like the kernels they sit between, and kept by clear_graph_cache
SCHEME_FUNCTIONS: dict = {}


def clear_graph_cache() -> None:
    """Forget the compiled step graphs and the cached numeric set-up (ancf_sym.setup_cache) of this process (the
    next run of every structure builds them again; the scene-independent SCHEME_FUNCTIONS stay)."""
    SYSTEM_GRAPHS.clear()
    ALPHA_GRAPHS.clear()
    MAPPED_CALLS.clear()
    setup_cache.clear()


_SCALARS = frozenset((str, int, float, bool, type(None), np.float64, np.int64, np.bool_))


def structure_key(S: "StepSystem") -> str:
    """What the compiled graphs bake in: the pattern of the equations (elements, kernels, gathers, sparsity),
    and the values that are constants of the graphs (mass matrix, fixed coordinates, Rayleigh and strain-rate
    damping, penalties, constraints, scales). Element parameters (E, section, lengths), constant and time
    loads, the step size and the initial state are inputs: runs that differ only in those share the graphs."""
    h = hashlib.sha256()
    upd = h.update

    def add(*xs):  # (the exact scalar types and arrays first: most items are those)
        for x in xs:
            t = type(x)
            if t in _SCALARS:
                upd(repr(x).encode())
            elif t is np.ndarray:
                upd(repr((x.dtype.str, x.shape)).encode())
                upd(np.ascontiguousarray(x).tobytes())
            elif isinstance(x, (list, tuple)):
                upd(b"[")
                add(*x)
                upd(b"]")
            elif isinstance(x, dict):
                add(*sorted(x.items(), key=lambda kv: repr(kv[0])))
            elif sp.issparse(x):
                x = x if x.format == "csc" else x.tocsc()
                add(x.shape, x.indptr, x.indices, x.data)
            elif isinstance(x, np.ndarray):
                add(np.asarray(x))
            elif hasattr(x, "__dict__") and not isinstance(x, type):
                add(type(x).__name__, dict(vars(x)))
            else:
                upd(repr(x).encode())
    asm = S.asm
    add(asm.n, S.nf, S.mc, S.linsol, S.fuse, S._gather, S.part.c, S.M, S.span,
        S.length_scale, bool(np.any(asm.Q)), [lbl for *_, lbl in S._lin_energy])
    add([(ft.element, ft.effect, ft.gauss, ft.idx, ft.P.shape, ft.labels, ft.sources) for ft in S.force_terms])
    add([(mk.term.element, mk.term.effect, mk.term.gauss, mk.term.idx, mk.P.shape, mk.term.label)
         for mk in S.nonlinear])
    r = S.rayleigh
    add(None if r is None else (r.alpha, r.beta, {k: np.asarray(v, float) for k, v in r.element_weight.items()}))
    add(S.strain_rate, asm.penalty, S.cons)
    add(contact.dissipation_calls(asm.mesh))  # contact damping/friction: parameters baked into the graph
    d = S.drives  # drive rows' pattern (their time functions are inputs)
    add(None if d is None else (d.nw, d.row, d.wk, d.i, d.j, d.coef, d.torques))
    return h.hexdigest()


def pooled_buffer(graphs: dict, key, f: ca.Function, owner) -> tuple:
    """f.buffer() from the structure's pool (a buffer of a large graph takes ~10 ms to allocate at 1000 elements:
    a second run of the structure reuses the buffer of a finished run); it returns to the pool when `owner` is
    collected. The caller binds every argument and result anew."""
    pool = graphs.setdefault("buffers", {}).setdefault(key, [])
    be = pool.pop() if pool else f.buffer()
    weakref.finalize(owner, pool.append, be)
    return be
