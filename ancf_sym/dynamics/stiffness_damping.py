"""Rayleigh stiffness damping beta K_el(q_n) in the time-step schemes: the elastic tangent taken at the start of each
step and kept in the step system (shared by the alpha and collocation integrators)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ancf_sym.dynamics.newton import Counters
from ancf_sym.system.damping import rayleigh_matrix
from ancf_sym.system.step_system import StepSystem


class StiffnessDamping:
    """Rayleigh beta K_el: the elastic tangent at the start of each step, kept in system.kel (shared by the alpha and
    collocation integrators)."""

    def __init__(self, system: StepSystem, counters: Counters):
        self.S, self.counters = system, counters
        self.f = None
        if system.kel_sparsity is not None:
            xf = ca.MX.sym("x", system.nf)
            self.f = ca.Function("kel", [xf], [system.forces_pf(xf, ca.DM(system.par))[2]])

    @property
    def active(self) -> bool:
        return self.f is not None

    def update(self, q: np.ndarray) -> None:
        if self.f is not None:
            self.S.kel[:] = np.asarray(self.f(q)).ravel()
            self.counters.residuals += 1

    def matrix(self):
        return rayleigh_matrix(self.S, self.S.kel)
