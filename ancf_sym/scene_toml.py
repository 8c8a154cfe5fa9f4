"""Read a scene from a TOML file: `load_scene(path) -> (Scene, analysis)`.

The file mirrors the Python API (docs/scenes.md has the full schema and an annotated example):

    [scene]              name, dim, gravity
    [materials.NAME]     E, density, G | poisson
    [sections.NAME]      area, I | Iy, Iz, J, b, h   or  shape = "circle", diameter   or  shape = "rectangle", b, h
    [[members]]          name, points, elements, material, section, element, axial, bending, torsion, gravity,
                         beam_method, gauss, y_axis
    [[supports]]         type = "clamp" | "pin" | "slope", member, at, method, penalty
    [[joints]]           type = "hinge" | "rigid", a = [member, at], b = [member, at], method, penalty
    [[loads]]            type = "force" | "distributed" | "moment" | "tension", member, at, value
    [[dampings]]         type = "rayleigh" (alpha, beta, members) | "strain_rate" (axial, bending, members)
    [[bodies]]           name, mass, inertia, position, angle, force, revolute = [x, y] (ground pivot),
                         pin = [[member, at], ...], rigid = [[member, at], ...] (planar rigid bodies)
    [[contacts]]         type = "ground", member, stiffness, hertz, normal, level, thickness, damping, mu, eps,
                         gauss, method (ancf_sym.contact.from_toml)
    [analysis]           type = "statics" (tol, max_iter, load_steps, escape_saddle) | "dynamics" (passed through)

Everything is checked before any solving. Every error is a SceneError whose message starts with the TOML path of
the offending field (array indices count from 0), e.g. "members[1].elements: must be a positive integer, got 0".
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from . import contact
from .mesh import build_mesh
from .scene import AXIAL, BEAM_METHODS, ELEMENT_KINDS, Material, Scene, SceneError, Section
from .terms import scene_terms

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

TOP_KEYS = ("scene", "materials", "sections", "members", "supports", "joints", "loads", "dampings", "contacts",
            "bodies", "analysis")
BODY_KEYS = ("name", "mass", "inertia", "position", "angle", "force", "revolute", "pin", "rigid")
SCENE_KEYS = ("name", "dim", "gravity")
MATERIAL_KEYS = ("E", "density", "G", "poisson")
SECTION_KEYS = {None: ("area", "I", "Iy", "Iz", "J", "b", "h"), "circle": ("diameter",), "rectangle": ("b", "h")}
MEMBER_KEYS = ("name", "points", "elements", "material", "section", "element", "axial", "bending", "torsion",
               "gravity", "beam_method", "gauss", "y_axis", "prestrain")
SUPPORT_TYPES = ("clamp", "pin", "slope")
JOINT_TYPES = ("hinge", "rigid")
LOAD_TYPES = ("force", "distributed", "moment", "tension")
DAMPING_FIELDS = {"rayleigh": ("alpha", "beta"), "strain_rate": ("axial", "bending")}
METHODS = ("exact", "penalty")
ANALYSIS_TYPES = ("statics", "dynamics")
STATICS_OPTIONS = ("tol", "max_iter", "load_steps", "escape_saddle")


# -- typed readers: each names the TOML path of what it reads -------------------------------------------------------

def _fail(path: str, msg: str, value: Any = None, show: bool = True) -> SceneError:
    return SceneError(f"{path}: {msg}" + (f", got {value!r}" if show else ""))


def _table(path: str, v: Any) -> dict:
    if not isinstance(v, dict):
        raise _fail(path, "must be a table", v)
    return v


def _array_of_tables(path: str, v: Any) -> list:
    if not isinstance(v, list) or not all(isinstance(e, dict) for e in v):
        raise _fail(path, f"must be an array of tables ([[{path}]])", v)
    return v


def _keys(path: str, d: dict, allowed, required=()) -> None:
    for k in d:
        if k not in allowed:
            raise _fail(f"{path}.{k}" if path else k, f"unknown key (allowed: {', '.join(allowed)})", d[k])
    for k in required:
        if k not in d:
            raise _fail(f"{path}.{k}" if path else k, "missing (required)", show=False)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(path: str, v: Any, positive: bool = False) -> float:
    if not _is_number(v):
        raise _fail(path, "must be a number", v)
    if not math.isfinite(v):
        raise _fail(path, "must be finite", v)
    if positive and v <= 0:
        raise _fail(path, "must be positive", v)
    return float(v)


def _pos_int(path: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise _fail(path, "must be a positive integer", v)
    return v


def _bool(path: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise _fail(path, "must be true or false", v)
    return v


def _str(path: str, v: Any, choices=None) -> str:
    if not isinstance(v, str) or not v:
        raise _fail(path, "must be a non-empty string" + (f" ({' | '.join(choices)})" if choices else ""), v)
    if choices is not None and v not in choices:
        raise _fail(path, f"must be one of {' | '.join(choices)}", v)
    return v


def _vector(path: str, v: Any, n: int) -> list[float]:
    if not isinstance(v, list) or len(v) != n:
        raise _fail(path, f"must be an array of {n} numbers", v)
    return [_number(f"{path}[{i}]", x) for i, x in enumerate(v)]


def _at(path: str, v: Any, node_only: bool) -> Any:
    """'start' | 'end' | node index (integer) | material coordinate [m] (float; loads only)."""
    if v in ("start", "end") or (isinstance(v, int) and not isinstance(v, bool)):
        return v
    if not node_only and isinstance(v, float):
        return _number(path, v)
    raise _fail(path, "must be \"start\", \"end\", a node index (integer)"
                + ("" if node_only else " or a material coordinate in metres (float)"), v)


def _check_finite(path: str, v: Any) -> None:
    """TOML allows nan and inf: refuse them anywhere in the file (also in tables passed through unread)."""
    if isinstance(v, float) and not math.isfinite(v):
        raise _fail(path or "(top)", "must be finite", v)
    if isinstance(v, dict):
        for k, x in v.items():
            _check_finite(f"{path}.{k}" if path else k, x)
    elif isinstance(v, list):
        for i, x in enumerate(v):
            _check_finite(f"{path}[{i}]", x)


def _api(path: str, call, *args, **kw):
    """Call the Scene API; its SceneError (already naming the value) is prefixed with the TOML path."""
    try:
        return call(*args, **kw)
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None


# -- sections of the file --------------------------------------------------------------------------------------------

def _material(path: str, d: Any) -> Material:
    d = _table(path, d)
    _keys(path, d, MATERIAL_KEYS, ("E", "density"))
    if "G" in d and "poisson" in d:
        raise _fail(path, "give G or poisson, not both", {"G": d["G"], "poisson": d["poisson"]})
    kw = {k: _number(f"{path}.{k}", d[k], positive=k != "poisson") for k in d}
    if "poisson" in kw and not -1 < kw["poisson"] < 0.5:
        raise _fail(f"{path}.poisson", "must lie in (-1, 0.5)", d["poisson"])
    return _api(path, Material, **kw)


def _section(path: str, d: Any) -> Section:
    d = _table(path, d)
    shape = d.get("shape")
    if shape is not None:
        _str(f"{path}.shape", shape, ("circle", "rectangle"))
    allowed = SECTION_KEYS[shape] + (("shape",) if shape else ())
    required = {None: ("area",), "circle": ("diameter",), "rectangle": ("b", "h")}[shape]
    _keys(path, d, allowed, required)
    kw = {k: _number(f"{path}.{k}", v, positive=True) for k, v in d.items() if k != "shape"}
    if shape == "circle":
        return _api(path, Section.circle, kw["diameter"])
    if shape == "rectangle":
        return _api(path, Section.rectangle, kw["b"], kw["h"])
    return _api(path, Section, **kw)


def _named(path: str, v: Any, table: dict, what: str) -> Any:
    name = _str(path, v)
    if name not in table:
        raise _fail(path, f"names no {what}; defined: {sorted(table) or 'none'}", v)
    return table[name]


def _member(scene: Scene, path: str, d: dict, materials: dict, sections: dict) -> None:
    _keys(path, d, MEMBER_KEYS, ("name", "points", "elements", "material", "section"))
    name = _str(f"{path}.name", d["name"])
    if name in scene.members:
        raise _fail(f"{path}.name", "repeats an earlier member's name", name)
    pts = d["points"]
    if not isinstance(pts, list) or len(pts) < 2:
        raise _fail(f"{path}.points", f"must be an array of >= 2 points of {scene.dim} numbers", pts)
    points = [_vector(f"{path}.points[{i}]", p, scene.dim) for i, p in enumerate(pts)]
    kw: dict[str, Any] = {
        "elements": _pos_int(f"{path}.elements", d["elements"]),
        "material": _named(f"{path}.material", d["material"], materials, "material ([materials.NAME])"),
        "section": _named(f"{path}.section", d["section"], sections, "section ([sections.NAME])"),
    }
    if "element" in d:
        kw["element"] = _str(f"{path}.element", d["element"], ELEMENT_KINDS)
    if "axial" in d:
        axial = _str(f"{path}.axial", d["axial"], AXIAL + ("none",))
        kw["axial"] = None if axial == "none" else axial
    for flag in ("bending", "torsion", "gravity"):
        if flag in d:
            kw[flag] = _bool(f"{path}.{flag}", d[flag])
    if "beam_method" in d:
        kw["beam_method"] = _str(f"{path}.beam_method", d["beam_method"], BEAM_METHODS)
    if "gauss" in d:
        g = _pos_int(f"{path}.gauss", d["gauss"])
        if g not in (3, 4, 5, 7):
            raise _fail(f"{path}.gauss", "must be one of 3, 4, 5, 7", g)
        kw["gauss"] = g
    if "y_axis" in d:
        kw["y_axis"] = _vector(f"{path}.y_axis", d["y_axis"], 3)
    if "prestrain" in d:
        kw["prestrain"] = _number(f"{path}.prestrain", d["prestrain"])
    _api(path, scene.member, name, points, **kw)


def _member_name(scene: Scene, path: str, v: Any) -> str:
    return _named(path, v, scene.members, "member").name


def _method(path: str, d: dict) -> dict:
    kw = {}
    if "method" in d:
        kw["method"] = _str(f"{path}.method", d["method"], METHODS)
    if "penalty" in d:
        v = d["penalty"]
        if isinstance(v, list):
            if len(v) != 2:
                raise _fail(f"{path}.penalty", "must be a factor or [position factor, slope factor]", v)
            kw["penalty"] = tuple(_number(f"{path}.penalty[{i}]", x, positive=True) for i, x in enumerate(v))
        else:
            kw["penalty"] = _number(f"{path}.penalty", v, positive=True)
    return kw


def _support(scene: Scene, path: str, d: dict) -> None:
    _keys(path, d, ("type", "member", "at", "method", "penalty"), ("type", "member"))
    kind = _str(f"{path}.type", d["type"], SUPPORT_TYPES)
    member = _member_name(scene, f"{path}.member", d["member"])
    at = _at(f"{path}.at", d.get("at", "start"), node_only=True)
    kw = _method(path, d)
    call = {"clamp": scene.clamp, "pin": scene.pin, "slope": scene.fix_slope}[kind]
    _api(f"{path}.at", call, member, at, **kw)  # the API checks the node range


def _joint_end(scene: Scene, path: str, v: Any) -> tuple[str, Any]:
    if not isinstance(v, list) or len(v) != 2:
        raise _fail(path, "must be [member, at], e.g. [\"beam\", \"end\"]", v)
    member = _member_name(scene, f"{path}[0]", v[0])
    return member, _at(f"{path}[1]", v[1], node_only=True)


def _joint(scene: Scene, path: str, d: dict) -> None:
    _keys(path, d, ("type", "a", "b", "method", "penalty"), ("type", "a", "b"))
    kind = _str(f"{path}.type", d["type"], JOINT_TYPES)
    a, b = _joint_end(scene, f"{path}.a", d["a"]), _joint_end(scene, f"{path}.b", d["b"])
    _api(path, scene.hinge if kind == "hinge" else scene.rigid, a, b, **_method(path, d))


def _body(scene: Scene, path: str, d: dict) -> None:
    """A rigid body and its joints: revolute to the ground at a point, pins and rigid ties to member nodes."""
    _keys(path, d, BODY_KEYS, ("name", "mass", "inertia", "position"))
    name = _str(f"{path}.name", d["name"])
    _api(path, scene.body, name, d["mass"], d["inertia"], d["position"], d.get("angle", 0.0), d.get("force"))
    if "revolute" in d:
        _api(path, scene.revolute, name, _vector(f"{path}.revolute", d["revolute"], 2))
    for kind, call in (("pin", scene.pin_body), ("rigid", scene.rigid_body)):
        ends = d.get(kind, [])
        if not isinstance(ends, list):
            raise _fail(f"{path}.{kind}", "must be a list of [member, at]", ends)
        for k, end in enumerate(ends):
            member, at = _joint_end(scene, f"{path}.{kind}[{k}]", end)
            _api(path, call, name, member, at)


def _load(scene: Scene, path: str, d: dict) -> None:
    _keys(path, d, ("type", "member", "at", "value"), ("type",))
    kind = _str(f"{path}.type", d["type"], LOAD_TYPES)
    fields = ("type", "member", "value") + (() if kind == "distributed" else ("at",))
    _keys(path, d, fields, fields)
    member = _member_name(scene, f"{path}.member", d["member"])
    vpath, v = f"{path}.value", d["value"]
    if kind == "distributed":
        _api(path, scene.distributed, member, _vector(vpath, v, scene.dim))
        return
    at = _at(f"{path}.at", d["at"], node_only=kind != "force")
    if kind == "force":
        value = _vector(vpath, v, scene.dim)
    elif kind == "moment":
        value = _number(vpath, v) if scene.dim == 2 else _vector(vpath, v, 3)
    else:
        value = _number(vpath, v)
    call = {"force": scene.force, "moment": scene.moment, "tension": scene.tension}[kind]
    # the API checks the node range / material coordinate (and, for moments, the components it can carry)
    _api(path if kind == "moment" else f"{path}.at", call, member, at, value)


def _damping(scene: Scene, path: str, d: dict) -> None:
    """Dynamics only: Scene.rayleigh (alpha [1/s], beta [s]) or Scene.strain_rate_damping (axial [N s],
    bending [N m^2 s]); members (default all) is a list of member names."""
    if "type" not in d:
        raise _fail(f"{path}.type", "missing (required: rayleigh | strain_rate)", show=False)
    kind = _str(f"{path}.type", d["type"], tuple(DAMPING_FIELDS))
    fields = DAMPING_FIELDS[kind]
    _keys(path, d, ("type", "members") + fields, ("type",))
    if not any(f in d for f in fields):
        raise _fail(path, f"give {' and/or '.join(fields)} (a {kind} damping without coefficients)", show=False)
    kw: dict[str, Any] = {}
    for f in fields:
        if f in d:
            v = _number(f"{path}.{f}", d[f])
            if v < 0:
                raise _fail(f"{path}.{f}", "must be >= 0", d[f])
            kw[f] = v
    if "members" in d:
        m = d["members"]
        if not isinstance(m, list) or not m:
            raise _fail(f"{path}.members", "must be a non-empty array of member names", m)
        kw["members"] = [_member_name(scene, f"{path}.members[{i}]", v) for i, v in enumerate(m)]
    if kind == "rayleigh" and kw.get("alpha"):  # (what the dynamics would refuse, refused now)
        if "members" in kw:
            raise _fail(f"{path}.members", "alpha (mass-proportional) acts on the whole scene: give members only "
                        "with beta", d["members"])
        other = {dd.alpha for dd in scene.dampings if dd.kind == "rayleigh" and dd.alpha} - {kw["alpha"]}
        if other:
            raise _fail(f"{path}.alpha", f"the scene has one mass-proportional alpha; an earlier damping gives "
                        f"{other.pop()!r}", d["alpha"])
    _api(path, scene.rayleigh if kind == "rayleigh" else scene.strain_rate_damping, **kw)


def _analysis(d: Any) -> dict:
    d = _table("analysis", d)
    kind = _str("analysis.type", d.get("type", "statics"), ANALYSIS_TYPES)
    if kind == "dynamics":  # the dynamics solver reads (and checks) its own options
        return {**d, "type": "dynamics"}
    _keys("analysis", d, ("type",) + STATICS_OPTIONS)
    out: dict[str, Any] = {"type": "statics"}
    if "tol" in d:
        out["tol"] = _number("analysis.tol", d["tol"], positive=True)
    for k in ("max_iter", "load_steps"):
        if k in d:
            out[k] = _pos_int(f"analysis.{k}", d[k])
    if "escape_saddle" in d:
        out["escape_saddle"] = _bool("analysis.escape_saddle", d["escape_saddle"])
    return out


def scene_from_dict(doc: dict, default_name: str = "scene") -> tuple[Scene, dict]:
    """The scene and the analysis table of a parsed TOML document (see the module docstring)."""
    _check_finite("", doc)
    _keys("", doc, TOP_KEYS, ("scene", "members"))
    sd = _table("scene", doc["scene"])
    _keys("scene", sd, SCENE_KEYS, ("dim",))
    dim = sd["dim"]
    if isinstance(dim, bool) or dim not in (2, 3):
        raise _fail("scene.dim", "must be 2 or 3", dim)
    name = _str("scene.name", sd["name"]) if "name" in sd else default_name
    gravity = _vector("scene.gravity", sd["gravity"], dim) if "gravity" in sd else None
    scene = _api("scene", Scene, dim=dim, gravity=gravity, name=name)

    materials = {k: _material(f"materials.{k}", v) for k, v in _table("materials", doc.get("materials", {})).items()}
    sections = {k: _section(f"sections.{k}", v) for k, v in _table("sections", doc.get("sections", {})).items()}
    members = _array_of_tables("members", doc["members"])
    if not members:
        raise _fail("members", "must define at least one [[members]] table", show=False)
    for i, d in enumerate(members):
        _member(scene, f"members[{i}]", d, materials, sections)
    for i, d in enumerate(_array_of_tables("supports", doc.get("supports", []))):
        _support(scene, f"supports[{i}]", d)
    for i, d in enumerate(_array_of_tables("joints", doc.get("joints", []))):
        _joint(scene, f"joints[{i}]", d)
    for i, d in enumerate(_array_of_tables("loads", doc.get("loads", []))):
        _load(scene, f"loads[{i}]", d)
    for i, d in enumerate(_array_of_tables("dampings", doc.get("dampings", []))):
        _damping(scene, f"dampings[{i}]", d)
    for i, d in enumerate(_array_of_tables("contacts", doc.get("contacts", []))):
        _api(f"contacts[{i}]", contact.from_toml, scene, d)
    for i, d in enumerate(_array_of_tables("bodies", doc.get("bodies", []))):
        _body(scene, f"bodies[{i}]", d)

    # dry run of the mesh and the energy terms (numpy only, no kernels): what they refuse, refuse now
    _api("members", lambda: scene_terms(build_mesh(scene)))
    analysis = _analysis(doc.get("analysis", {"type": "statics"}))
    if analysis["type"] == "statics":
        _api("supports", scene.validate_for_statics)
    return scene, analysis


def load_scene(path: str | Path) -> tuple[Scene, dict]:
    """(Scene, analysis dict) from a TOML file; SceneError (naming the TOML path of the field) on bad input.

    The scene name defaults to the file's stem. analysis: {"type": "statics", tol?, max_iter?, load_steps?,
    escape_saddle?} (StaticOptions fields) or the [analysis] table as written for "dynamics"."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise SceneError(f"{p}: scene file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{p}: cannot read the scene file: {exc}") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{p}: not valid TOML: {exc}") from None
    return scene_from_dict(doc, default_name=p.stem)
