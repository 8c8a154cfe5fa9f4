"""What the graph builders of the step system read of it: the step system as its helpers (forces, damping,
graph_cache, water) see it. They take it as this protocol and return what they build (the step system keeps
it), so they need not import the step system that imports them."""
from __future__ import annotations

from typing import Any, Protocol

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.model.assembly import Assembly
from ancf_sym.model.reduced import Partition


class StepSystemView(Protocol):
    asm: Assembly
    part: Partition
    E: sp.csc_matrix  # x = E y + c
    pos: np.ndarray  # unknown of each coordinate (-1: fixed)
    nf: int  # unknowns
    mc: int  # kept constraint rows (and drive rows)
    cons: Any  # the kept exact rows (None: none)
    drives: Any  # the drives' rows and forces (None: none)
    linsol: str
    fuse: bool  # a cable's axial and bending terms fused into one kernel
    span: float
    length_scale: float
    M: sp.csc_matrix  # reduced mass matrix
    nonlinear: list  # the assembly's mapped kernels of nonlinear terms
    force_calls: Any  # the kernel calls of the force graphs (fused where possible)
    force_terms: list
    par: np.ndarray  # the kernels' parameters: an input of the compiled graphs
    lin: np.ndarray  # the linear potentials' coefficients: an input of the energy graph
    lin_energy: list  # (idx, G, constant, label) per linear term
    rayleigh: Any  # RayleighData or None
    strain_rate: Any  # StrainRateData or None
    kel: np.ndarray  # the elastic tangent's values at the step's start (Rayleigh beta K_el)
    kel_sparsity: ca.Sparsity | None
    damp_force_f: ca.Function | None
    damp_force_maps: dict

    def x_full_mx(self, xf: ca.MX) -> ca.MX: ...

    def mass_mx(self, u: ca.MX) -> ca.MX: ...

    def mass_dm(self) -> ca.DM: ...
