"""Load the compiled element kernels (built by `pip install .` from generated/) as casadi Functions.

Each kernel is (q, p) -> (energy, gradient, hessian) for one (element, effect); `parameters` names the entries
of p. The functions come from the shared libraries installed in ancf_sym/_kernels: there is no fallback to a
symbolic or interpreted version, a missing library is an error that says how to build it.
"""
from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from ancf_sym import registry

KERNEL_DIR = Path(__file__).resolve().parent / "_kernels"


class KernelError(ValueError):
    """Bad kernel request or bad kernel input; the message names the argument and its value."""


def _check_names(element: str, effect: str) -> registry.Effect:
    if element not in registry.ELEMENTS:
        raise KernelError(f"element={element!r} is not an element; known: {sorted(registry.ELEMENTS)}")
    eff = registry.EFFECTS.get((element, effect))
    if eff is None:
        known = sorted(e for (el, e) in registry.EFFECTS if el == element)
        raise KernelError(f"effect={effect!r} is not an effect of element {element!r}; known: {known}")
    return eff


@functools.lru_cache(maxsize=None)
def library_path(name: str) -> Path:
    hits = sorted(KERNEL_DIR.glob(f"{name}.*so")) + sorted(KERNEL_DIR.glob(f"{name}.so"))
    if not hits:
        raise FileNotFoundError(
            f"compiled kernel library for {name!r} not found in {KERNEL_DIR}; the kernels are compiled when the "
            f"package is installed: run `pip install .` from the project root (not an editable install)")
    return hits[0]


class Kernel(ca.Function):
    """A compiled kernel that checks numeric inputs before they reach C (sizes, finiteness, positive lengths)."""

    def __init__(self, f: ca.Function, element: str, effect: str, params: tuple[str, ...], library: Path):
        super().__init__(f)
        self.element, self.effect, self.params, self.library = element, effect, params, library

    def __call__(self, *args, **kwargs):
        """k(q, p) with numbers (lists, NumPy arrays, DMs) returns NumPy: a float for a scalar output (the
        energy), else a 2-D array of the output's shape (the gradient a column (n, 1), as CasADi's own, so that it
        mixes with the outputs of the mapped and companion kernels; the Hessian (n, n)). With CasADi symbols (MX,
        SX) it returns symbols, as any casadi.Function."""
        named = dict(zip(("q", "p"), args), **kwargs)
        if set(named) == {"q", "p"} and len(args) + len(kwargs) == 2:
            check_inputs(self.element, self.effect, named["q"], named["p"])
        out = super().__call__(*args, **kwargs)
        if kwargs or not all(isinstance(o, ca.DM) for o in (out if isinstance(out, (tuple, list)) else [out])):
            return out  # symbolic, or CasADi's keyword form (a dict of DMs)
        return tuple(_to_numpy(o) for o in out) if isinstance(out, (tuple, list)) else _to_numpy(out)


def _to_numpy(x: ca.DM) -> float | np.ndarray:
    """A DM as NumPy: a float if 1 x 1, else its dense 2-D array."""
    a = x.full()
    return float(a[0, 0]) if a.shape == (1, 1) else a


def _as_numeric(x: Any, name: str = "input") -> np.ndarray | None:
    if isinstance(x, (ca.MX, ca.SX)):
        return None
    try:
        return np.asarray(ca.DM(x) if isinstance(x, ca.DM) else x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise KernelError(f"{name}: cannot read {x!r} as numbers: {exc}") from None


def check_inputs(element: str, effect: str, q: Any, p: Any) -> None:
    """Raise KernelError naming the argument if q or p has the wrong size, is not finite or has L <= 0."""
    eff = _check_names(element, effect)
    nq, n_p = registry.input_size(element, effect), len(eff.params)
    for name, x, n in (("q", q, nq), ("p", p, n_p)):
        if isinstance(x, (ca.MX, ca.SX)):
            if x.numel() != n:
                raise KernelError(f"{name} of {element}/{effect} must have {n} entries, got shape {x.shape}")
            continue
        a = _as_numeric(x, name)
        if a.ndim > 2 or (a.ndim == 2 and 1 not in a.shape):
            raise KernelError(f"{name} of {element}/{effect} must be a vector of {n} entries, got shape {a.shape}")
        if a.size != n:
            raise KernelError(f"{name} of {element}/{effect} must have {n} entries {'(' + ', '.join(eff.params) + ')' if name == 'p' else ''}, "
                              f"got {a.size} (shape {a.shape})")
        if not np.all(np.isfinite(a)):
            bad = np.flatnonzero(~np.isfinite(a.ravel()))[0]
            dofs = registry.ELEMENTS[element].dof_names
            label = eff.params[bad] if name == "p" else (dofs[bad] if bad < len(dofs) else f"input {bad}")
            raise KernelError(f"{name}[{bad}] ({label}) of {element}/{effect} is not finite: {a.ravel()[bad]}")
        if name == "p" and a.ravel()[eff.params.index("L")] <= 0:
            raise KernelError(f"p: element length L must be positive, got L={a.ravel()[eff.params.index('L')]}")


@functools.lru_cache(maxsize=None)
def _load(element: str, effect: str, gauss: int | None) -> Kernel:
    eff = _check_names(element, effect)
    if gauss is not None and gauss not in eff.gauss:
        raise KernelError(f"gauss={gauss!r}: {element}/{effect} is generated for orders {list(eff.gauss) or 'none (exact)'}")
    name = registry.kernel_name(element, effect, gauss)
    lib = library_path(registry.library_name(element, effect))
    return Kernel(ca.external(name, str(lib)), element, effect, eff.params, lib)


def load(element: str, effect: str, gauss: int | None = None) -> Kernel:
    """Compiled kernel (q, p) -> (energy, gradient, hessian) of one effect on one element.

    q: (ndof,) nodal coordinates [m, -]; p: parameters in the order of `parameters(element, effect)`.
    gauss: quadrature order (default 5 for quadrature effects; see `registry.EFFECTS[...].gauss`).
    """
    return _load(element, effect, gauss)


@functools.lru_cache(maxsize=None)
def load_energy(element: str, effect: str, gauss: int | None = None) -> ca.Function:
    """(q, p) -> energy alone, with its compiled reverse-mode companion (for CasADi/IPOPT graphs that need it)."""
    _check_names(element, effect)
    name = registry.kernel_name(element, effect, gauss) + "_energy"
    return ca.external(name, str(library_path(registry.library_name(element, effect))))


@functools.lru_cache(maxsize=None)
def load_grad(element: str, effect: str, gauss: int | None = None) -> ca.Function:
    """(q, p) -> (energy, gradient) without the Hessian's work: the residual of modified Newton iterations."""
    _check_names(element, effect)
    name = registry.kernel_name(element, effect, gauss)
    return ca.external(name + "_grad", str(library_path(registry.library_name(element, effect))))


@functools.lru_cache(maxsize=None)
def load_rows(element: str, effect: str, gauss: int | None = None) -> ca.Function:
    """A dissipation kernel's (z, p) -> (force, [df/dq, df/dv]) (z = [q; v]): the force dD/dv and the rows of its
    Hessian the dynamics' step uses, without the q-q block's work."""
    eff = _check_names(element, effect)
    if not eff.rates:
        raise KernelError(f"{element}/{effect} is not a dissipation kernel (no {registry.ROWS_SUFFIX} companion)")
    name = registry.kernel_name(element, effect, gauss) + registry.ROWS_SUFFIX
    return ca.external(name, str(library_path(registry.library_name(element, effect))))


@functools.lru_cache(maxsize=None)
def load_batch(element: str, effect: str, gauss: int | None = None, companion: str = "") -> ca.Function | None:
    """The batched kernel (companion "") or its "_grad" / "_energy" companion evaluating registry.BATCH_LANES
    elements per call in SIMD lanes: (q[nd x lanes], p[np x lanes]) -> the outputs of the one-element function
    mapped over the lanes; None where none is generated (registry.batched: the fused elastic effects' kernel and
    _grad, the cables' axial and bending _energy, at the default quadrature order)."""
    _check_names(element, effect)
    if not registry.has_batch(element, effect, gauss, companion):
        return None
    name = registry.kernel_name(element, effect, gauss) + companion + registry.BATCH_SUFFIX
    return ca.external(name, str(library_path(registry.library_name(element, effect))))


@functools.lru_cache(maxsize=None)
def load_hvp(element: str, effect: str) -> ca.Function:
    """(q, p, v) -> (H v, d(H v)/dq), third derivatives of the energy contracted with v (cable elastic effects,
    default quadrature): what an exact Lagrangian Hessian needs when grad U sits inside constraints."""
    _check_names(element, effect)
    if not registry.has_third_derivatives(element, effect, None):
        raise KernelError(f"{element}/{effect} has no third-derivative companion; available for cables' "
                          f"{list(registry.THIRD_DERIVATIVE_EFFECTS)}")
    name = registry.kernel_name(element, effect)
    return ca.external(name + "_hvp", str(library_path(registry.library_name(element, effect))))


def parameters(element: str, effect: str) -> tuple[str, ...]:
    """Names of the entries of p, in order."""
    return _check_names(element, effect).params


@functools.lru_cache(maxsize=None)
def _mass_function(element: str) -> ca.Function:
    if element not in registry.ELEMENTS:
        raise KernelError(f"element={element!r} is not an element; known: {sorted(registry.ELEMENTS)}")
    return ca.external(f"{element}_mass", str(library_path("ancf_mass")))


def mass_matrix(element: str, p: Any) -> np.ndarray:
    """Constant element mass matrix; p as `mass_parameters(element)` (cable: L, rhoA; beam3d: L, b, h, rho)."""
    names = registry.MASS_PARAMS.get(element)
    f = _mass_function(element)
    a = _as_numeric(p, "p").ravel()
    if a.size != len(names):
        raise KernelError(f"p of {element} mass must have {len(names)} entries {names}, got {a.size}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise KernelError(f"p of {element} mass must be positive and finite {names}, got {a.tolist()}")
    return np.asarray(f(a))


@functools.lru_cache(maxsize=None)
def load_band(kind: str, w: int, m: int) -> ca.Function:
    """A banded LDL^T kernel (ancf_sym.codegen.band): kind "fwd" or "bwd", half-bandwidth w, m columns per call."""
    if (w, m) not in registry.BAND_LDL or kind not in ("fwd", "bwd"):
        raise KernelError(f"no banded LDL^T kernel {kind!r} with w={w}, m={m}; built: {list(registry.BAND_LDL)}")
    return ca.external(registry.band_name(kind, w, m), str(library_path(registry.BAND_LIBRARY)))


def mass_parameters(element: str) -> tuple[str, ...]:
    return registry.MASS_PARAMS[element]


@functools.lru_cache(maxsize=1)
def manifest() -> dict:
    return json.loads((KERNEL_DIR / "manifest.json").read_text())


def catalogue() -> list[dict]:
    """Every kernel: element, effect, gauss order, inputs, outputs, parameter names, library path, C flags."""
    out = []
    for k in manifest()["kernels"]:
        if k["element"] is None:
            continue
        out.append({
            "name": k["name"], "element": k["element"], "effect": k["effect"], "gauss": k["gauss"],
            "inputs": {"q": registry.input_size(k["element"], k["effect"]), "p": k["params"]},
            "outputs": ["energy", "gradient", "hessian"], "description": registry.EFFECTS[(k["element"], k["effect"])].description,
            "library": str(library_path(k["library"])), "cflags": k["cflags"], "functions": k["functions"],
        })
    return out


@functools.lru_cache(maxsize=None)
def load_direction(element: str, effect: str, gauss: int | None = None) -> ca.Function:
    """(q, p, dq, dp) -> (de, dg, dH): the forward derivative of the kernel's energy, gradient and Hessian along
    (dq, dp) (registry.PARAMETER_DIRECTION_EFFECTS: where scene numbers enter the parameters nonlinearly)."""
    _check_names(element, effect)
    if not registry.has_parameter_direction(element, effect, gauss):
        raise KernelError(f"{element}/{effect} (gauss {gauss}) has no parameter-direction companion; available for "
                          f"{list(registry.PARAMETER_DIRECTION_EFFECTS)} (beams at the default order)")
    name = registry.kernel_name(element, effect, gauss) + registry.PARAMETER_DIRECTION_SUFFIX
    return ca.external(name, str(library_path(registry.direction_library(element, effect))))


@functools.lru_cache(maxsize=None)
def _mass_direction_function(element: str) -> ca.Function:
    if element != "beam3d":
        raise KernelError(f"{element}: its mass is linear in rhoA (no mass direction companion)")
    return ca.external("beam3d_mass" + registry.PARAMETER_DIRECTION_SUFFIX,
                       str(library_path("ancf_mass" + registry.PARAMETER_DIRECTION_SUFFIX)))


def mass_matrix_direction(element: str, p: Any, dp: Any) -> np.ndarray:
    """d(element mass matrix) along dp at p (beam3d: p = L, b, h, rho)."""
    f = _mass_direction_function(element)
    return np.asarray(f(_as_numeric(p, "p").ravel(), _as_numeric(dp, "dp").ravel()))
