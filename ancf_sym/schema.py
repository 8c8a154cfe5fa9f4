"""The user-facing fields, declared once: type, unit, allowed values, one line of meaning.

The Python classes check themselves against these tables (checks.check_fields in their __post_init__), the TOML
reader takes its allowed keys from them, and docs/scenes.md documents them. A test keeps each table equal to its
dataclass's fields.
"""
from __future__ import annotations

from .checks import Field

MATERIAL = {
    "E": Field("number", "Pa", positive=True, doc="Young's modulus"),
    "density": Field("number", "kg/m^3", positive=True, doc="mass density"),
    "G": Field("number", "Pa", positive=True, optional=True, doc="shear modulus (or poisson, not both)"),
    "poisson": Field("number", "", between=(-1.0, 0.5), optional=True, doc="Poisson ratio (default 0.3)"),
}

SECTION = {
    "area": Field("number", "m^2", positive=True, doc="cross-section area"),
    "I": Field("number", "m^4", positive=True, optional=True, doc="second moment, sets Iy and Iz"),
    "Iy": Field("number", "m^4", positive=True, optional=True, doc="second moment about the section's y axis"),
    "Iz": Field("number", "m^4", positive=True, optional=True, doc="second moment about the section's z axis"),
    "J": Field("number", "m^4", positive=True, optional=True, doc="torsion constant (default Iy + Iz)"),
    "b": Field("number", "m", positive=True, optional=True, doc="width along y (beam3d)"),
    "h": Field("number", "m", positive=True, optional=True, doc="height along z (beam3d)"),
}

STATIC_OPTIONS = {
    "tol": Field("number", between=(0.0, 1.0), optional=True,
                 doc="relative convergence tolerance (docs/statics.md; default 1e-10)"),
    "max_iter": Field("int", positive=True, doc="IPOPT iterations per attempt"),
    "load_steps": Field("int", positive=True, doc="continuation steps of the fallback"),
    "escape_saddle": Field("bool", doc="leave an unstable equilibrium along its negative mode"),
    "print_level": Field("int", span=(0, 12), doc="IPOPT's print level (Python API only)", api_only=True),
}

# the fields DynamicOptions checks by kind; "any" fields are checked by DynamicOptions itself (integrator names,
# sensors, loads, Newton options, initial states) and listed so that the TOML reader knows every key
DYNAMIC_OPTIONS = {
    "dt": Field("number", "s", positive=True, doc="time step (adaptive: the first step)"),
    "t_end": Field("number", "s", doc="end time"),
    "integrator": Field("str", doc="generalized_alpha, hht, newmark, radau or gauss (and aliases)"),
    "t_start": Field("number", "s", doc="start time"),
    "rho_inf": Field("number", doc="generalized-alpha spectral radius at infinite frequency, in [0, 1]"),
    "alpha": Field("number", doc="HHT alpha, in [-1/3, 0]"),
    "beta": Field("number", doc="Newmark beta"),
    "gamma": Field("number", doc="Newmark gamma"),
    "stages": Field("int", span=(1, 4), optional=True, doc="collocation stages"),
    "adaptive": Field("bool", doc="adaptive time steps"),
    "tol": Field("number", "m", positive=True, optional=True, doc="adaptive: local error tolerance"),
    "dt_min": Field("number", "s", positive=True, optional=True, doc="smallest step before giving up"),
    "dt_max": Field("number", "s", positive=True, optional=True, doc="adaptive: largest step"),
    "output_every": Field("int", positive=True, optional=True, doc="record every k accepted steps"),
    "output_dt": Field("number", "s", positive=True, optional=True, doc="record at t_start + k output_dt"),
    "output_times": Field("any", "s", optional=True, doc="record at these times"),
    "newton": Field("any", doc="Newton options table"),
    "sensors": Field("any", doc="what to record"),
    "loads": Field("any", doc="time-dependent loads"),
    "energies": Field("bool", doc="record the energy balance"),
    "q0": Field("any", optional=True, doc="initial coordinates (Python API)"),
    "v0": Field("any", optional=True, doc="initial velocities (Python API)"),
}


def _kind(f: Field) -> str:
    k = {"number": "number", "int": "integer", "bool": "true/false", "str": "string", "any": "table/array"}[f.kind]
    lim = [("> 0" if f.kind == "number" else ">= 1")] if f.positive else []
    lim += [f"in ({f.between[0]:g}, {f.between[1]:g})"] if f.between else []
    lim += [f"{f.span[0]}..{f.span[1]}"] if f.span else []
    return k + (" " + ", ".join(lim) if lim else "") + (", optional" if f.optional else "")


def analysis_table() -> str:
    """The [analysis] keys as the markdown table in docs/scenes.md (a test keeps the page equal to this)."""
    rows = ["| key | analysis | type | unit | meaning |", "|---|---|---|---|---|"]
    for kind, table in (("statics", STATIC_OPTIONS), ("dynamics", DYNAMIC_OPTIONS)):
        rows += [f"| `{k}` | {kind} | {_kind(f)} | {f.unit or '-'} | {f.doc} |" for k, f in table.items()]
    return "\n".join(rows) + "\n"
