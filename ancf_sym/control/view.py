"""What a control result and its resimulation read of the problem that made them, and the resimulation of the
result: typed as protocols, so that result.py and resimulation.py need not import the problem (which imports
them)."""
from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from ancf_sym.scene.builder import Scene


class ControlProblemView(Protocol):
    scene: Scene
    asm: Any  # the ControlAssembly (the scene's assembly with the point masses)
    part: Any  # the reduced coordinates' partition
    controls: list
    channels: list  # support channels by name
    force_names: list  # controlled forces by name
    n: int  # scene coordinates
    nf: int  # free unknowns
    nc: int  # support channels
    nF: int  # controlled forces
    nu: int  # controls per instant
    K: int  # intervals
    s: int  # collocation stages
    tab: Any  # the collocation tableau
    tau: np.ndarray  # collocation points in [0, 1]
    B: Any  # force input matrix
    Tr: Any  # the support channels' translation of the coordinates
    modes: Any  # the end-rest modes
    q_start: np.ndarray
    q_end: np.ndarray
    start_values: Any
    end_values: Any
    build_s: float
    solver_build_s: float
    f_function: Any
    chan_axis: Any
    chan_support: Any
    chan_vector: Any
    full: Any
    probe: Any
    unpack: Any
    node_times: Any
    point_times: Any
    kernel_times: Any
    violation: Any
    violations: Any


class ControlResultView(Protocol):
    Z: np.ndarray
    q_free: Any
    v_free: Any
    point: Any
    control_in_interval: Any
