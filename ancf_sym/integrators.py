"""Compatibility import path: the step system, Newton's method and the alpha schemes live in ancf_sym.dynamics
(step_system, newton, schemes, alpha, ...); the reduced coordinates in ancf_sym.reduced."""
from .assembly import LINEAR_EFFECTS
from .dynamics.alpha import AlphaIntegrator
from .dynamics.damping import RayleighData, StiffnessDamping, StrainRateData
from .dynamics.graph_cache import clear_graph_cache
from .dynamics.integrator import StepOutcome, initial_acceleration
from .dynamics.newton import Counters, Factor, NewtonOptions, NewtonOutcome, newton
from .dynamics.schemes import Scheme
from .dynamics.step_system import StepSystem
from .reduced import Partition, partition

__all__ = ["LINEAR_EFFECTS", "AlphaIntegrator", "Counters", "Factor", "NewtonOptions", "NewtonOutcome", "Partition",
           "RayleighData", "Scheme", "StepOutcome", "StepSystem", "StiffnessDamping", "StrainRateData",
           "clear_graph_cache", "initial_acceleration", "newton", "partition"]
