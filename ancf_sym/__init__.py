"""ancf_sym: ANCF cables and beams with symbolic energies, exact derivatives and compiled C kernels.

The data flow, one package per stage (docs/code_map.md): scene (what the user describes) -> model (mesh, one
energy term per effect asked for, assembly over mapped compiled kernels, reduced coordinates) -> system (the step
system statics and dynamics share) -> statics (Newton on the exact tangent, IPOPT where Newton alone does not
converge) / modal / dynamics / control -> io (result.json, plots, VTK) and the command line.
"""
import os

# CasADi's wheel bundles its own OpenBLAS next to NumPy's; with both spinning threads on a small machine a 256x256
# eigen-decomposition took 2.2 s instead of 0.018 s. Acts only if NumPy is not loaded yet; an explicit setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import importlib
import importlib.util

__version__ = "0.1.0"

# The public names are imported on first use (PEP 562): `import ancf_sym` costs nothing, so the command line
# answers --version at once and handles a Ctrl-C that arrives while NumPy, CasADi or Matplotlib load.
_PUBLIC = {"Material": "scene", "Scene": "scene", "SceneError": "scene", "Section": "scene",
           "StaticOptions": "statics", "StaticResult": "statics", "solve_static": "statics",
           "DynamicOptions": "dynamics", "DynamicResult": "dynamics", "run_dynamics": "dynamics",
           "simulate": "dynamics", "modal_analysis": "modal", "linearize": "modal", "ModalResult": "modal",
           "calibrate": "sensitivity", "calibrate_frequencies": "sensitivity", "sensitivities": "sensitivity"}
__all__ = list(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(f".{_PUBLIC[name]}", __name__), name)
    elif not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f".{name}", __name__)  # a submodule: ancf_sym.dynamics.initial, ancf_sym.kernels
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))
