"""What the statics' Newton calls converged, stalled or wild (its constants, one home for the Python and the C loop),
a run's record, and the coordinate scales its relative updates are measured in."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ancf_sym.model.assembly import Assembly

STALL = 0.75  # updates contracting by less than this factor make no progress (the 2/3 of a quartic Green energy far out does)
STALL_COUNT = 3  # that many in a row: the updates are round-off
ROUND_OFF = 100.0  # a residual within this factor of eps x max|K| x span is at round-off
NO_PROGRESS = 4  # converging runs set a new smallest update at least every 3 iterations (measured, zig-zags included)
SHIFT, SHIFT_MAX = 1e-4, 1e4  # shifts of an indefinite tangent's diagonal tried (relative to each entry)
SHIFT_BELOW = 1e-3  # updates (relative) below which an indefinite tangent's plain Newton step is taken
EPS = float(np.finfo(float).eps)
WILD = 1e3  # an update of a thousand structure lengths left every physical equilibrium behind: hand over to IPOPT
PYTHON_LOOP = False  # True: KernelNewton iterates in Python even where the C loop (newton_loop) takes the scene (to compare)


@dataclass
class NewtonRun:
    converged: bool
    status: str  # "converged", "round_off", "stalled", "diverged", "not_finite", "max_iter"
    iterations: int
    x: np.ndarray  # full coordinates after the last applied update
    lam: np.ndarray  # multipliers of the StepSystem's kept rows
    increment: float  # last applied update, relative (see module docstring)
    energy_decrement: float  # relative to the load work W
    residual: float  # max |r| at the last evaluated point [N]
    residual_floor: float  # its round-off level eps x max|K| x span [N]
    history: list = field(default_factory=list)  # (increment, decrement) per iteration
    potential: float = math.nan  # at x, where the solve was asked to finish (converged runs; NaN: not evaluated)
    stable: bool | None = None  # there: tangent + finish x max|K_ii| I positive definite (None: not tested)


def coordinate_scales(asm: Assembly) -> np.ndarray:
    """Per coordinate: the longest member length for positions [m], 1 for slopes and other gradients [-]."""
    L = asm.mesh.length_scale
    s = np.ones(asm.n)
    dim = asm.scene.dim
    for mm in asm.mesh.members.values():
        k = np.arange(mm.x0.size)
        s[mm.offset + k[k % mm.node_size < dim]] = L
    for o in asm.mesh.bodies.values():  # a rigid body's centre; its unit axis vectors keep scale 1
        s[o:o + dim] = L
    return s
