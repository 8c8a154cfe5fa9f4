"""ancf_sym: ANCF cables and beams with symbolic energies, exact derivatives and compiled C kernels.

Pipeline (the README's layout): scene -> mesh -> terms (only the effects asked for) -> assembly over
mapped compiled kernels -> solvers (statics: IPOPT; dynamics) -> results.
"""
import os

# CasADi's wheel bundles its own OpenBLAS next to NumPy's; with both spinning threads on a small machine a 256x256
# eigen-decomposition took 2.2 s instead of 0.018 s. Acts only if NumPy is not loaded yet; an explicit setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from .scene import Material, Scene, SceneError, Section
from .statics import StaticOptions, StaticResult, solve_static
from .dynamics import DynamicOptions, DynamicResult, run_dynamics, simulate
from . import initial
from .modal import ModalResult, linearize, modal_analysis

__all__ = ["Material", "Scene", "SceneError", "Section", "StaticOptions", "StaticResult", "solve_static",
           "DynamicOptions", "DynamicResult", "run_dynamics", "simulate",
           "modal_analysis", "linearize", "ModalResult"]
__version__ = "0.1.0"
