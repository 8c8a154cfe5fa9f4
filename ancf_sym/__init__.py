"""ancf_sym: ANCF cables and beams with symbolic energies, exact derivatives and compiled C kernels.

Pipeline (see DESIGN in the README): scene -> mesh -> terms (only the effects asked for) -> assembly over
mapped compiled kernels -> solvers (statics: IPOPT; dynamics) -> results.
"""
from .scene import Material, Scene, SceneError, Section
from .statics import StaticOptions, StaticResult, solve_static
from .dynamics import DynamicOptions, DynamicResult, run_dynamics, simulate

__all__ = ["Material", "Scene", "SceneError", "Section", "StaticOptions", "StaticResult", "solve_static",
           "DynamicOptions", "DynamicResult", "run_dynamics", "simulate"]
__version__ = "0.1.0"
