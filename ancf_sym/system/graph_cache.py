"""Compiled step graphs cached by scene structure, in the process.

A StepSystem's graphs bake in the pattern of the equations (elements, kernels, gathers, sparsity) and a few values
(mass matrix, fixed coordinates, damping, penalties, constraints, scales); element parameters (E, section, lengths),
constant and time loads, the step size and the initial state are inputs. `structure_key` is an exact key of what is baked in,
so runs that differ only in the inputs share the graphs (and the integrators' step and chunk functions, and the
buffers those allocate).
"""
from __future__ import annotations

import itertools

import casadi as ca
import numpy as np

from ancf_sym.contact import laws as contact
from ancf_sym.util import setup_cache
from ancf_sym.util.casadi_buffers import pooled
from ancf_sym.model.assembly import MAPPED_CALLS, clear_kernel_buffers
from ancf_sym.system.interface import StepSystemView


# structure id (structure_id: a number per exact structure key) -> the StepSystem's compiled functions (and the
# in-graph factor, buffers)
SYSTEM_GRAPHS: dict = {}
_STRUCTURE_IDS: dict = {}
_NEXT_ID = itertools.count()
# (structure id, scheme, Newton options, in-graph factor, further iterations) -> alpha step and chunk functions
ALPHA_GRAPHS: dict = {}
# (scene structure spec, damping, options) -> a StepSystem's structural attributes (StepSystem._STRUCTURE_ATTRS)
STEP_TEMPLATES: dict = {}
# functions that depend on no scene (the alpha steps' scalar Newton logic, by options): built once per process,
# like the kernels they sit between, and kept by clear_graph_cache
SCHEME_FUNCTIONS: dict = {}


def clear_graph_cache() -> None:
    """Forget the compiled step graphs and the cached numeric set-up (ancf_sym.util.setup_cache) of this process (the
    next run of every structure builds them again; the scene-independent SCHEME_FUNCTIONS stay)."""
    SYSTEM_GRAPHS.clear()
    STEP_TEMPLATES.clear()
    _STRUCTURE_IDS.clear()
    ALPHA_GRAPHS.clear()
    MAPPED_CALLS.clear()
    clear_kernel_buffers()
    setup_cache.clear()


def water_key(asm):
    from ancf_sym.system.water import key

    return key(asm)


def structure_id(S: StepSystemView) -> int:
    """The number of the system's structure (structure_key) in this process: the key of SYSTEM_GRAPHS and
    ALPHA_GRAPHS (numbers are never reused, also after clear_graph_cache: a system kept from before refers to no
    later structure's graphs)."""
    key = structure_key(S)
    sid = _STRUCTURE_IDS.get(key)
    if sid is None:
        sid = _STRUCTURE_IDS[key] = next(_NEXT_ID)
    return sid


def structure_key(S: StepSystemView) -> tuple:
    """What the compiled graphs bake in: the pattern of the equations (elements, kernels, gathers, sparsity),
    and the values that are constants of the graphs (mass matrix, fixed coordinates, Rayleigh and strain-rate
    damping, penalties, constraints, scales). Element parameters (E, section, lengths), constant and time
    loads, the step size and the initial state are inputs: runs that differ only in those share the graphs.

    An exact key (ancf_sym.util.setup_cache.array_key: the inputs themselves, no digest): the partition, the reduced
    mass matrix and the kernel calls come from the set-up cache and stand in by their own keys (the exact inputs
    they were made of: the constraint rows, the mass inputs, every nonlinear term's elements, coordinates and
    lengths), so a second run of a structure walks none of their arrays."""
    asm, r, d = S.asm, S.rayleigh, S.drives
    return setup_cache.array_key(
        asm.n, S.nf, S.mc, S.linsol, S.fuse, S.part, S.M, S.span, S.length_scale, bool(np.any(asm.Q)),
        [lbl for *_, lbl in S.lin_energy], S.force_calls, [ft.P.shape for ft in S.force_terms],
        [mk.P.shape for mk in S.nonlinear],
        None if r is None else (r.alpha, r.beta, {k: np.asarray(v, float) for k, v in r.element_weight.items()}),
        S.strain_rate, asm.penalty, S.cons,
        contact.dissipation_calls(asm.mesh),  # contact damping/friction: parameters baked into the graph
        None if d is None else (d.nw, d.row, d.wk, d.i, d.j, d.coef, d.torques),  # drive rows' pattern (their
        water_key(asm))  # (lines in water: coefficients and current baked into the graph)
    # time functions are inputs)


def keep_template(key: tuple, attrs: dict) -> None:
    """Keep a StepSystem's structural attributes for the systems of the same structure spec (at most
    setup_cache.LIMIT structures: a sweep over many starts again)."""
    if len(STEP_TEMPLATES) >= setup_cache.LIMIT:
        STEP_TEMPLATES.clear()
    STEP_TEMPLATES[key] = attrs


def pooled_buffer(graphs: dict, key, f: ca.Function, owner) -> tuple:
    """f.buffer() from the structure's pool (a buffer of a large graph takes ~10 ms to allocate at 1000 elements:
    a second run of the structure reuses the buffer of a finished run); it returns to the pool when `owner` is
    collected. The caller binds every argument and result anew."""
    return pooled(graphs.setdefault("buffers", {}).setdefault(key, []), f, owner)
