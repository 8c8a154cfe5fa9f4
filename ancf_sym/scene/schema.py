"""The user-facing fields, declared once: type, unit, allowed values, one line of meaning.

The Python classes check themselves against these tables (checks.check_fields in their __post_init__), the TOML
reader takes its allowed keys from them, and docs/scenes.md documents them. A test keeps each table equal to its
dataclass's fields.
"""
from __future__ import annotations

from ancf_sym.util.checks import Field

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
    "load_stepping": Field("bool", doc="apply the loads in steps from the start: Newton along the load factor, "
                           "steps of 1 / load_steps (a quarter after a failed one), not only as a fallback"),
    "print_level": Field("int", span=(0, 12), doc="IPOPT's print level (Python API only)", api_only=True),
}

# [analysis] type = "modal": the statics options above (the equilibrium first) and these (ancf_sym.modal)
MODAL_OPTIONS = {
    "modes": Field("int", positive=True, doc="the number of lowest natural modes about the static equilibrium"),
    "damped": Field("bool", doc="also the damped modes' complex eigenvalues (the scene's damping)"),
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
    "sensors": Field("any", doc="what to record: [[analysis.sensors]] tables (SENSOR)"),
    "loads": Field("any", doc="time-dependent point forces: [[analysis.loads]] tables (TIME_LOAD)"),
    "energies": Field("bool", doc="record the energy balance"),
    "record_states": Field("bool", doc="keep every coordinate at the output times (result.states; the command "
                           "line asks for them for its VTK series and animation)"),
    "q0": Field("any", optional=True, doc="initial coordinates (Python API)"),
    "v0": Field("any", optional=True, doc="initial velocities (Python API)"),
    "initial": Field("any", optional=True, doc="initial velocities per member or body: a list of [[initial]] tables"),
    "start": Field("str", choices=("reference", "static"), optional=True,
                   doc="start from the reference state (default) or from the static equilibrium"),
    "release": Field("any", optional=True, doc="with start = \"static\": supports that hold the starting statics "
                     "and are released for the dynamics: labels as in the results (\"pin beam@end\") or indices "
                     "of [[supports]]"),
    "from_result": Field("str", optional=True, doc="start from the state of an earlier result.json (statics: its "
                         "coordinates, at rest; dynamics: its final coordinates and velocities) of the same mesh; a "
                         "relative path is taken from the scene file's folder"),
}

# [[bodies]]: one rigid body and its joints (planar in 2D scenes, spatial in 3D ones)
BODY = {
    "name": Field("str", doc="unique among bodies and members"),
    "mass": Field("number", "kg", positive=True, doc="mass"),
    "inertia": Field("any", "kg m^2", doc="about the centre: a number (2D); 3 principal moments or a 3x3 tensor in "
                     "the body axes (3D)"),
    "position": Field("any", "m", doc="centre of mass in the reference state"),
    "angle": Field("number", "rad", optional=True, doc="2D: the body's x axis in the reference state"),
    "axes": Field("any", optional=True, doc="3D: rows x, y, z of the body axes in world components (default: world)"),
    "force": Field("any", "N", optional=True, doc="dead force at the centre"),
    "revolute": Field("any", optional=True, doc="joint table(s) {point, other; 3D: axis}, or (2D) a ground pivot "
                      "[x, y] (m)"),
    "revolute_body": Field("str", optional=True, doc="2D: the body the revolute point is fixed to (default: ground)"),
    "spherical": Field("any", optional=True, doc="3D: joint table(s) {point, other}, or a ground point [x, y, z] (m)"),
    "prismatic": Field("any", optional=True, doc="joint table(s) {axis, point, other}"),
    "pin": Field("any", optional=True, doc="[[member, at], ...]: member nodes pinned to the body"),
    "rigid": Field("any", optional=True, doc="[[member, at], ...]: member nodes clamped into the body"),
}

# a body's revolute / spherical / prismatic joint: an inline table, or an array of them
BODY_JOINT = {
    "point": Field("any", "m", optional=True, doc="joint point, world, reference state (default the body's centre)"),
    "axis": Field("any", optional=True, doc="3D revolute: the turning axis; prismatic: the sliding axis (world)"),
    "other": Field("str", optional=True, doc="the second body (default: the ground)"),
}

# [[loops]]: a closed member along a path (Scene.loop); the member keys (element, axial, prestrain, ...) as [[members]]
LOOP = {
    "name": Field("str", doc="member name"),
    "path": Field("any", "m", optional=True, doc="pieces [\"line\", a, b] and [\"arc\", centre, radius, angle0, "
                  "sweep] (rad) joining into a loop in the x-y plane"),
    "pulleys": Field("any", "m", optional=True, doc="instead of path: [[centre, radius], ...] counter-clockwise, "
                     "the belt around them"),
    "elements": Field("int", positive=True, doc="elements of equal length (>= 3)"),
    "material": Field("str", doc="a [materials.NAME]"),
    "section": Field("str", doc="a [sections.NAME]"),
}

# [[initial]]: the initial velocity of one member or body (dynamics)
INITIAL = {
    "member": Field("str", doc="member or body name"),
    "velocity": Field("any", "m/s", optional=True, doc="uniform velocity (dim numbers)"),
    "omega": Field("any", "rad/s", optional=True, doc="rigid rotation: rate about z (2D) or 3 numbers (3D)"),
    "centre": Field("any", "m", optional=True, doc="the rotation's fixed point (default the origin)"),
}


def _kind(f: Field) -> str:
    k = {"number": "number", "int": "integer", "bool": "true/false", "str": "string", "any": "table/array",
         "location": "string/integer/number"}[f.kind]
    lim = [("> 0" if f.kind == "number" else ">= 1")] if f.positive else []
    lim += [f"in ({f.between[0]:g}, {f.between[1]:g})"] if f.between else []
    lim += [f"{f.span[0]}..{f.span[1]}"] if f.span else []
    return k + (" " + ", ".join(lim) if lim else "") + (", optional" if f.optional else "")


def fields_table(table: dict) -> str:
    """A declared table as the markdown table docs/scenes.md gives (a test keeps the page equal to this)."""
    rows = ["| key | type | unit | meaning |", "|---|---|---|---|"]
    rows += [f"| `{k}` | {_kind(f)} | {f.unit or '-'} | {f.doc} |" for k, f in table.items()]
    return "\n".join(rows) + "\n"


def analysis_table() -> str:
    """The [analysis] keys as the markdown table in docs/scenes.md (a test keeps the page equal to this)."""
    rows = ["| key | analysis | type | unit | meaning |", "|---|---|---|---|---|"]
    for kind, table in (("statics", STATIC_OPTIONS), ("modal", MODAL_OPTIONS), ("dynamics", DYNAMIC_OPTIONS)):
        rows += [f"| `{k}` | {kind} | {_kind(f)} | {f.unit or '-'} | {f.doc} |" for k, f in table.items()]
    return "\n".join(rows) + "\n"


# [[analysis.sensors]]: what a dynamic run records at its output times (ancf_sym.dynamics.sensors)
SENSOR = {
    "name": Field("str", optional=True, doc="key of the recorded series (default `<kind>_<member>_<at>`); unique"),
    "kind": Field("str", choices=("position", "displacement", "velocity", "strain", "curvature", "coordinates",
                                  "body"),
                  doc="position / displacement (from the reference) [m] or velocity [m/s] of a centreline point "
                  "(dim components); strain \\|r_x\\| - 1 [-]; curvature \\|r_x x r_xx\\| / \\|r_x\\|^3 [1/m]; "
                  "coordinates: all nodal coordinates of a node; body: a rigid body's x, y [m], angle [rad], "
                  "angular velocity [rad/s] (3D: centre, angular velocity, axes e1, e2, e3)"),
    "member": Field("str", doc="member name (kind = body: body name)"),
    "at": Field("location", optional=True, doc="\"start\", \"end\" (default), a node index (integer) or a material "
                "coordinate in m (float; not for coordinates)"),
}

# [[analysis.loads]]: a time-dependent point force F(t) = factor(t) force (ancf_sym.dynamics.time_loads)
TIME_LOAD = {
    "member": Field("str", doc="member name"),
    "at": Field("location", optional=True, doc="\"start\", \"end\" (default), a node index (integer) or a material "
                "coordinate in m (float)"),
    "force": Field("any", "N", doc="force vector (dim numbers), scaled by the factor"),
    "history": Field("any", "[s, -]", doc="[[t, factor], ...] with increasing t: the factor is linear between "
                     "them and holds the first / last value before / after"),
}

# [[masses]]: a point mass at a member point (Scene.point_mass)
POINT_MASS = {
    "member": Field("str", doc="member name"),
    "at": Field("location", doc="\"start\", \"end\", a node index (integer) or a material coordinate in m (float)"),
    "mass": Field("number", "kg", positive=True, doc="mass: in the mass matrix through the interpolation weights "
                  "at that point; its weight (scene gravity) acts there as a dead force"),
}

# [[members]] arc = {...}: a curved member, a circular arc in the x-y plane (Scene.arc), instead of points
ARC = {
    "centre": Field("any", "m", optional=True, doc="centre [x, y]"),
    "radius": Field("number", "m", positive=True, optional=True, doc="radius"),
    "angle0": Field("number", "rad", optional=True, doc="angle of the start point about the centre, from x"),
    "sweep": Field("number", "rad", optional=True, doc="angle swept from the start, > 0 counter-clockwise, "
                   "0 < \\|sweep\\| < 2 pi"),
    "through": Field("any", "m", optional=True, doc="instead of the four above: [start, a point between, end]"),
}
