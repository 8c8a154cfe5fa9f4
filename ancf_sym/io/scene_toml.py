"""Read a scene from a TOML file: `load_scene(path) -> (Scene, analysis)`.

The file mirrors the Python API (docs/scenes.md has the full schema and an annotated example):

    [scene]              name, dim, gravity
    [materials.NAME]     E, density, G | poisson
    [sections.NAME]      area, I | Iy, Iz, J, b, h   or  shape = "circle", diameter   or  shape = "rectangle", b, h
    [[members]]          name, points | arc = {centre, radius, angle0, sweep} | {through}, elements, material,
                         section, element, axial, bending, torsion, gravity, beam_method, gauss, y_axis
    [[supports]]         type = "clamp" | "pin" | "slope", member, at, method, penalty
    [[joints]]           type = "hinge" | "rigid", a = [member, at], b = [member, at], method, penalty, axis
    [[loads]]            type = "force" | "distributed" | "moment" | "tension", member, at, value
    [[masses]]           member, at, mass (a point mass: mass matrix and weight)
    [[dampings]]         type = "rayleigh" (alpha, beta, members) | "strain_rate" (axial, bending, members)
    [[loops]]            name, path = [["line", a, b], ["arc", centre, radius, angle0, sweep], ...] or
                         pulleys = [[centre, radius], ...], elements, material, section, and the member keys
    [[bodies]]           name, mass, inertia, position, force, pin = [[member, at], ...], rigid = [...];
                         2D: angle, revolute = [x, y] (pivot; fixed to the body revolute_body = NAME instead of the
                         ground); 3D: axes; revolute / prismatic (2D, 3D), spherical (3D) = {point, axis, other}
                         (or an array of such tables; a ground point [x, y(, z)] for revolute in 2D and spherical)
    [[drives]]           type = "angle" (body, angle | omega, relative_to, angle0) | "position" (member, at | body,
                         position) | "torque" (body, torque); motions: numbers or [[t, [a0, a1, ...]], ...]
    [[contacts]]         type = "ground" (normal, level) | "circle" (centre, radius, axis), member, stiffness, hertz,
                         thickness, damping, mu, eps, gauss, method (read here, by _contact)
    [analysis]           type = "statics" (tol, max_iter, load_steps, escape_saddle, load_stepping) | "dynamics"
                         (passed through; start = "static", release, from_result, [[analysis.initial]] member,
                         velocity | omega, centre; [[analysis.sensors]], [[analysis.loads]]) | "modal" (modes,
                         damped, and the statics options of its equilibrium)

Everything is checked before any solving. Every error is a SceneError whose message starts with the TOML path of
the offending field (array indices count from 0), e.g. "members[1].elements: must be a positive integer, got 0".
"""
from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Any

from ancf_sym.util.checks import check_keys, fail, number, table_type, vector
from ancf_sym.model.mesh import build_mesh
from ancf_sym.scene.builder import Material, Scene, SceneError, Section
from ancf_sym.scene.schema import ARC, BODY, BODY_JOINT, LOOP, MATERIAL, MODAL_OPTIONS, POINT_MASS, SECTION, STATIC_OPTIONS
from ancf_sym.statics.problem import StaticOptions
from ancf_sym.model.terms import scene_terms

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

TOP_KEYS = ("scene", "materials", "sections", "members", "loops", "supports", "joints", "loads", "masses",
            "dampings", "contacts", "bodies", "drives", "water", "analysis")
SCENE_KEYS = ("name", "dim", "gravity")
SECTION_KEYS = {None: tuple(SECTION), "circle": ("diameter",), "rectangle": ("b", "h")}
MEMBER_KEYS = tuple(inspect.signature(Scene.member).parameters)[1:]  # the keywords of Scene.member
SUPPORT_TYPES = ("clamp", "pin", "slope")
JOINT_TYPES = ("hinge", "rigid")
LOAD_TYPES = ("force", "distributed", "moment", "tension")
DAMPINGS = {"rayleigh": "rayleigh", "strain_rate": "strain_rate_damping"}  # [[dampings]] type -> the Scene method
METHODS = ("exact", "penalty")
ANALYSIS_TYPES = ("statics", "dynamics", "modal")
STATICS_OPTIONS = tuple(k for k, f in STATIC_OPTIONS.items() if not f.api_only)


# -- typed readers: each names the TOML path of what it reads -------------------------------------------------------

_fail = fail


def _table(path: str, v: Any) -> dict:
    if not isinstance(v, dict):
        raise _fail(path, "must be a table", v)
    return v


def _array_of_tables(path: str, v: Any) -> list:
    if not isinstance(v, list) or not all(isinstance(e, dict) for e in v):
        raise _fail(path, f"must be an array of tables ([[{path}]])", v)
    return v


_keys = check_keys
_number = number


def _str(path: str, v: Any, choices=None) -> str:
    if not isinstance(v, str) or not v:
        raise _fail(path, "must be a non-empty string" + (f" ({' | '.join(choices)})" if choices else ""), v)
    if choices is not None and v not in choices:
        raise _fail(path, f"must be one of {' | '.join(choices)}", v)
    return v


_vector = vector


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


def _api(path: str, call, *args, root: str | None = None, **kw):
    """Call the Python API, which checks the values (ancf_sym.scene.schema); its SceneError names the field under the
    API's name `root` (e.g. `material.E`), re-rooted here to the TOML path (`materials.steel.E`). Errors under
    another root are prefixed with the path."""
    try:
        return call(*args, **kw)
    except SceneError as exc:
        raise exc.rerooted(root or "", path) from None


# -- sections of the file --------------------------------------------------------------------------------------------

def _material(path: str, d: Any) -> Material:
    d = _table(path, d)
    _keys(path, d, MATERIAL, ("E", "density"))
    return _api(path, Material, root="material", **d)


def _section(path: str, d: Any) -> Section:
    d = _table(path, d)
    shape = d.get("shape")
    if shape is not None:
        _str(f"{path}.shape", shape, ("circle", "rectangle"))
    allowed = SECTION_KEYS[shape] + (("shape",) if shape else ())
    required = {None: ("area",), "circle": ("diameter",), "rectangle": ("b", "h")}[shape]
    _keys(path, d, allowed, required)
    kw = {k: v for k, v in d.items() if k != "shape"}
    if shape == "circle":
        return _api(path, Section.circle, kw["diameter"], root="section")
    if shape == "rectangle":
        return _api(path, Section.rectangle, kw["b"], kw["h"], root="section")
    return _api(path, Section, root="section", **kw)


def _named(path: str, v: Any, table: dict, what: str) -> Any:
    name = _str(path, v)
    if name not in table:
        raise _fail(path, f"names no {what}; defined: {sorted(table) or 'none'}", v)
    return table[name]


def _member(scene: Scene, path: str, d: dict, materials: dict, sections: dict) -> None:
    """Names resolved here (material, section); every value checked by Scene.member (axial = "none" included), or
    by Scene.arc for a curved member (arc = {centre, radius, angle0, sweep} or {through}, instead of points)."""
    _keys(path, d, MEMBER_KEYS + ("arc",), ("name", "elements", "material", "section"))
    if ("points" in d) == ("arc" in d):
        raise _fail(path, "give points (a straight or polyline member) or arc (a curved one), not both or neither")
    name = _str(f"{path}.name", d["name"])
    kw = {k: v for k, v in d.items() if k not in ("name", "points", "arc")}
    kw["material"] = _named(f"{path}.material", d["material"], materials, "material ([materials.NAME])")
    kw["section"] = _named(f"{path}.section", d["section"], sections, "section ([sections.NAME])")
    if "arc" in d:
        arc = _table(f"{path}.arc", d["arc"])
        _keys(f"{path}.arc", arc, ARC)
        _api(path, scene.arc, name, root=f"members[{name!r}]", **kw, **arc)
        return
    _api(path, scene.member, name, d["points"], root=f"members[{name!r}]", **kw)


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
    _api(f"{path}.at", call, member, at, root=f"{kind}.at", **kw)  # the API checks the node range


def _joint_end(scene: Scene, path: str, v: Any) -> tuple[str, Any]:
    if not isinstance(v, list) or len(v) != 2:
        raise _fail(path, "must be [member, at], e.g. [\"beam\", \"end\"]", v)
    member = _member_name(scene, f"{path}[0]", v[0])
    return member, _at(f"{path}[1]", v[1], node_only=True)


def _joint(scene: Scene, path: str, d: dict) -> None:
    _keys(path, d, ("type", "a", "b", "method", "penalty", "axis"), ("type", "a", "b"))
    kind = _str(f"{path}.type", d["type"], JOINT_TYPES)
    a, b = _joint_end(scene, f"{path}.a", d["a"]), _joint_end(scene, f"{path}.b", d["b"])
    if "axis" in d and kind != "hinge":
        raise _fail(f"{path}.axis", "is for hinges (the rotation a beam3d hinge leaves free)", d["axis"])
    kw = {"axis": d["axis"]} if "axis" in d else {}
    _api(path, scene.hinge if kind == "hinge" else scene.rigid, a, b, root=kind, **_method(path, d), **kw)


def _body(scene: Scene, path: str, d: dict) -> None:
    """A rigid body (Scene.body: planar in a 2D scene, spatial in a 3D one); its joints come after all bodies."""
    _keys(path, d, BODY, ("name", "mass", "inertia", "position"))
    name = _str(f"{path}.name", d["name"])
    kw = {k: d[k] for k in ("angle", "force", "axes") if k in d}
    _api(path, scene.body, name, d["mass"], d["inertia"], d["position"], root="body", **kw)


def _joint_tables(path: str, v: Any) -> list[tuple[str, dict]]:
    """A 3D body joint given as one inline table or an array of them: [(path, table), ...]."""
    if isinstance(v, dict):
        return [(path, v)]
    if isinstance(v, list) and v and all(isinstance(e, dict) for e in v):
        return [(f"{path}[{k}]", e) for k, e in enumerate(v)]
    raise _fail(path, "must be a table {point, axis, other} or an array of them", v)


def _body_joints(scene: Scene, path: str, d: dict) -> None:
    """Joints of one body: to the ground or other bodies (all bodies exist by now), pins and rigid ties to member
    nodes."""
    name = d["name"]
    if scene.dim == 3 and "angle" in d:
        raise _fail(f"{path}.angle", "is planar; a spatial body takes axes (3 rows x, y, z)", d["angle"])
    if scene.dim == 2 and "spherical" in d:
        raise _fail(f"{path}.spherical", "is for spatial bodies (3D scenes)", d["spherical"])
    if "revolute_body" in d:  # (2D) the pivot fixed to that body: revolute = [x, y] or the body's centre
        rev = d.get("revolute")
        if scene.dim == 3 or isinstance(rev, dict) or (isinstance(rev, list) and rev and isinstance(rev[0], dict)):
            raise _fail(f"{path}.revolute_body", "goes with a planar revolute = [x, y] (or write revolute = "
                        "{point, other})", d["revolute_body"])
        d = {**d, "revolute": {"other": _str(f"{path}.revolute_body", d["revolute_body"]),
                               **({"point": d["revolute"]} if "revolute" in d else {})}}
    for kind in ("spherical", "revolute", "prismatic"):
        if kind not in d:
            continue
        v = d[kind]
        if kind != "prismatic" and isinstance(v, list) and v and not isinstance(v[0], dict):
            if kind == "revolute" and scene.dim == 3:
                raise _fail(f"{path}.revolute", "in 3D must be a table {point, axis, other} (the axis is required)", v)
            v = {"point": v}  # a ground point
        with_axis = kind == "prismatic" or (kind == "revolute" and scene.dim == 3)
        for jpath, t in _joint_tables(f"{path}.{kind}", v):
            _keys(jpath, t, BODY_JOINT, ("axis",) if with_axis else ())
            if "axis" in t and not with_axis:
                raise _fail(f"{jpath}.axis", f"a {'planar ' if scene.dim == 2 else ''}{kind} joint has no axis",
                            t["axis"])
            kw = {k: t[k] for k in ("point", "axis", "other") if k in t}
            _api(jpath, getattr(scene, kind), name, root=kind, **kw)
    for kind, call in (("pin", scene.pin_body), ("rigid", scene.rigid_body)):
        ends = d.get(kind, [])
        if not isinstance(ends, list):
            raise _fail(f"{path}.{kind}", "must be a list of [member, at]", ends)
        for k, end in enumerate(ends):
            member, at = _joint_end(scene, f"{path}.{kind}[{k}]", end)
            _api(f"{path}.{kind}[{k}]", call, name, member, at)


def _loop(scene: Scene, path: str, d: dict, materials: dict, sections: dict) -> None:
    """A closed member (Scene.loop) along `path` pieces or around `pulleys` (closed.belt_path)."""
    from ancf_sym.scene import closed

    member_keys = tuple(k for k in MEMBER_KEYS if k not in ("points", "elements", "material", "section"))
    _keys(path, d, tuple(LOOP) + member_keys, ("name", "elements", "material", "section"))
    name = _str(f"{path}.name", d["name"])
    if ("path" in d) == ("pulleys" in d):
        raise _fail(path, "give path (pieces) or pulleys (a belt around them), not both or neither")
    if "pulleys" in d:
        pul = d["pulleys"]
        if not isinstance(pul, list) or len(pul) < 2 or not all(isinstance(p, list) and len(p) == 2 for p in pul):
            raise _fail(f"{path}.pulleys", "must be >= 2 entries [centre, radius], centre = [x, y]", pul)
        pulleys = [(tuple(_vector(f"{path}.pulleys[{i}][0]", c, 2)), _number(f"{path}.pulleys[{i}][1]", R,
                                                                               positive=True))
                   for i, (c, R) in enumerate(pul)]
        pieces = _api(f"{path}.pulleys", closed.belt_path, pulleys)
    else:
        pieces = d["path"]
        if not isinstance(pieces, list) or not pieces:
            raise _fail(f"{path}.path", "must be a list of pieces [\"line\", a, b] | [\"arc\", centre, radius, "
                        "angle0, sweep]", pieces)
        pieces = [tuple(p) if isinstance(p, list) else p for p in pieces]
    kw = {k: v for k, v in d.items() if k not in ("name", "path", "pulleys", "elements", "material", "section")}
    kw["material"] = _named(f"{path}.material", d["material"], materials, "material ([materials.NAME])")
    kw["section"] = _named(f"{path}.section", d["section"], sections, "section ([sections.NAME])")
    _api(path, scene.loop, name, pieces, d["elements"], root=f"members[{name!r}]", **kw)


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
    if kind == "moment":  # the API's moment.at / moment.moment are this table's at / value
        try:
            call(member, at, value)
        except SceneError as exc:
            raise (exc.rerooted("moment.moment", vpath) if (exc.path or "").startswith("moment.moment")
                   else exc.rerooted("moment", path)) from None
    else:
        _api(f"{path}.at", call, member, at, value, root=f"{kind}.at")


def _mass(scene: Scene, path: str, d: dict) -> None:
    """A point mass (Scene.point_mass, schema.POINT_MASS): member, at, mass [kg]."""
    _keys(path, d, POINT_MASS, tuple(POINT_MASS))
    member = _member_name(scene, f"{path}.member", d["member"])
    at = _at(f"{path}.at", d["at"], node_only=False)
    POINT_MASS["mass"].check(f"{path}.mass", d["mass"])
    _api(f"{path}.at", scene.point_mass, member, at, d["mass"], root="point_mass.at")


def _damping(scene: Scene, path: str, d: dict) -> None:
    """Dynamics only: Scene.rayleigh (alpha [1/s], beta [s]) or Scene.strain_rate_damping (axial [N s],
    bending [N m^2 s]), which check the values; members (default all) is an array of member names."""
    if "type" not in d:
        raise _fail(f"{path}.type", "missing (required: rayleigh | strain_rate)")
    kind = _str(f"{path}.type", d["type"], tuple(DAMPINGS))
    method = DAMPINGS[kind]
    fields = tuple(k for k in inspect.signature(getattr(Scene, method)).parameters if k not in ("self", "members"))
    _keys(path, d, ("type", "members") + fields, ("type",))
    if not any(f in d for f in fields):
        raise _fail(path, f"give {' and/or '.join(fields)} (a {kind} damping without coefficients)")
    if "members" in d and (not isinstance(d["members"], list) or not d["members"]):
        raise _fail(f"{path}.members", "must be a non-empty array of member names", d["members"])
    _api(path, getattr(scene, method), root=method, **{k: v for k, v in d.items() if k != "type"})


# -- [[contacts]] and [[drives]]: a table type and the keyword arguments of the scene's method -----------------

_CONTACT_SHARED = ("type", "member", "stiffness", "hertz", "thickness", "damping", "mu", "eps", "gauss", "method")
CONTACT_KEYS = {"ground": _CONTACT_SHARED + ("normal", "level"),
             "circle": _CONTACT_SHARED + ("centre", "radius", "axis", "body")}
_CONTACT_NOT_NUMBERS = ("type", "member", "normal", "method", "centre", "axis", "body")


def _contact(scene: Scene, d: dict) -> Any:
    """A [[contacts]] table: type = "ground" (Scene.contact_ground) or "circle" (a fixed drum, Scene.contact_drum)
    and the keyword arguments of that method."""
    kind = table_type(d, CONTACT_KEYS, "ground")
    if "member" not in d:
        raise SceneError("member: missing (the member whose centre line touches the obstacle)")
    for k, v in d.items():
        if k not in _CONTACT_NOT_NUMBERS and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise SceneError(f"{k} must be a number, got {v!r}")
    kw = {k: v for k, v in d.items() if k != "type"}
    if "gauss" in kw and isinstance(kw["gauss"], float) and kw["gauss"].is_integer():
        kw["gauss"] = int(kw["gauss"])
    if kind == "circle":
        for key in ("centre", "radius"):
            if key not in kw and not (key == "centre" and "body" in kw):
                raise SceneError(f"{key}: missing (a circle contact needs the drum's centre, or the body carrying "
                                 "it, and radius)")
        kw.setdefault("centre", None)
        return scene.contact_drum(**kw)
    return scene.contact_ground(**kw)


DRIVE_KEYS = {"angle": ("type", "name", "body", "relative_to", "angle", "omega", "angle0"),
             "position": ("type", "name", "member", "at", "body", "position"),
             "torque": ("type", "name", "body", "torque")}


def _drive(scene: Scene, d: dict) -> Any:
    """A [[drives]] table: type = "angle" (Scene.drive), "position" (Scene.drive_position) or "torque"
    (Scene.torque), with that method's keyword arguments; motions as numbers or [[t, [a0, a1, ...]], ...]."""
    kind = table_type(d, DRIVE_KEYS, "angle")
    kw = {k: v for k, v in d.items() if k != "type"}
    if kind == "position":
        return scene.drive_position(**kw)
    if "body" not in kw:
        raise SceneError("body: missing (the body the drive acts on)")
    return scene.torque(**kw) if kind == "torque" else scene.drive(**kw)


def _water(scene: Scene, d: Any) -> Any:
    """The [water] table: density, depth, surface, current, waves = {...}, seabed = {...}, lines.NAME = {...}."""
    from ancf_sym.scene.water import WATER_KEYS, set_water
    if not isinstance(d, dict):
        raise fail("water", "must be a table", d)
    check_keys("water", d, WATER_KEYS)
    return set_water(scene, **d)


class Analysis(dict):
    """The [analysis] table as written (a dict: result.json echoes it) and `options`, the option object it decodes to,
    decoded once here: StaticOptions (statics, and a modal analysis's equilibrium) or DynamicOptions."""

    def __init__(self, table: dict, options: Any):
        super().__init__(table)
        self.options = options


def _analysis(d: Any) -> Analysis:
    d = _table("analysis", d)
    kind = _str("analysis.type", d.get("type", "statics"), ANALYSIS_TYPES)
    if kind == "dynamics":  # checked now by the dynamics options (sensors and loads against the scene later)
        from ancf_sym.dynamics import options_from_dict
        opts = _api("analysis", options_from_dict, d, root="analysis")
        return Analysis({**d, "type": "dynamics"}, opts)
    modal = tuple(MODAL_OPTIONS) if kind == "modal" else ()  # (modal: the statics options for its equilibrium too)
    _keys("analysis", d, ("type",) + STATICS_OPTIONS + modal)
    kw = {k: v for k, v in d.items() if k not in ("type",) + modal}
    opts = _api("analysis", StaticOptions, root="analysis", **kw)  # checks the values (ancf_sym.scene.schema)
    extra = {k: MODAL_OPTIONS[k].check(f"analysis.{k}", d[k]) for k in modal if k in d}
    return Analysis({"type": kind, **kw, **extra}, opts)


def scene_from_dict(doc: dict, default_name: str = "scene", base: str | Path | None = None) -> tuple[Scene, Analysis]:
    """The scene and the analysis table of a parsed TOML document (see the module docstring); relative paths in it
    (analysis.from_result) are taken from the folder `base` (the scene file's; default the working folder)."""
    _check_finite("", doc)
    _keys("", doc, TOP_KEYS, ("scene",))
    sd = _table("scene", doc["scene"])
    _keys("scene", sd, SCENE_KEYS, ("dim",))
    # Scene checks dim, name and gravity (errors under the API's own scene.* paths, which are the file's)
    scene = _api("scene", Scene, root="scene", dim=sd["dim"], gravity=sd.get("gravity"),
                 name=sd.get("name", default_name))

    materials = {k: _material(f"materials.{k}", v) for k, v in _table("materials", doc.get("materials", {})).items()}
    sections = {k: _section(f"sections.{k}", v) for k, v in _table("sections", doc.get("sections", {})).items()}
    members = _array_of_tables("members", doc.get("members", []))
    if not members and not doc.get("loops") and not doc.get("bodies"):
        raise _fail("members", "must define at least one [[members]], [[loops]] or [[bodies]] table")
    for i, d in enumerate(members):
        _member(scene, f"members[{i}]", d, materials, sections)
    for i, d in enumerate(_array_of_tables("loops", doc.get("loops", []))):
        _loop(scene, f"loops[{i}]", d, materials, sections)
    for i, d in enumerate(_array_of_tables("supports", doc.get("supports", []))):
        _support(scene, f"supports[{i}]", d)
    for i, d in enumerate(_array_of_tables("joints", doc.get("joints", []))):
        _joint(scene, f"joints[{i}]", d)
    for i, d in enumerate(_array_of_tables("loads", doc.get("loads", []))):
        _load(scene, f"loads[{i}]", d)
    for i, d in enumerate(_array_of_tables("masses", doc.get("masses", []))):
        _mass(scene, f"masses[{i}]", d)
    for i, d in enumerate(_array_of_tables("dampings", doc.get("dampings", []))):
        _damping(scene, f"dampings[{i}]", d)
    bodies = _array_of_tables("bodies", doc.get("bodies", []))
    for i, d in enumerate(bodies):
        _body(scene, f"bodies[{i}]", d)
    for i, d in enumerate(bodies):  # joints may name any body, earlier or later
        _body_joints(scene, f"bodies[{i}]", d)
    for i, d in enumerate(_array_of_tables("contacts", doc.get("contacts", []))):  # (after the bodies: a circle
        _api(f"contacts[{i}]", _contact, scene, d)                         # may be carried by one)
    if "water" in doc:  # (after the members: it names them, and adds the seabed's ground contacts)
        _api("water", _water, scene, doc["water"], root="water")
    for i, d in enumerate(_array_of_tables("drives", doc.get("drives", []))):
        _api(f"drives[{i}]", _drive, scene, d)

    # dry run of the mesh and the energy terms (numpy only, no kernels): what they refuse, refuse now
    _api("members", lambda: scene_terms(build_mesh(scene)))
    analysis = _analysis(doc.get("analysis", {"type": "statics"}))
    if analysis["type"] == "statics":
        _api("supports", scene.validate_for_statics)
    elif analysis["type"] == "modal":  # (a free structure: its modes about the unloaded reference)
        _api("supports", scene.validate_for_statics, allow_free=True)
    for i, d in enumerate(analysis.get("initial") or []):  # (their form is checked with the analysis)
        if d["member"] not in scene.members and d["member"] not in scene.bodies:
            raise _fail(f"analysis.initial[{i}].member", f"names no member or body; members: {sorted(scene.members)}"
                        f", bodies: {sorted(scene.bodies)}", d["member"])
    if analysis.get("start") == "static":
        _api("analysis.start", scene.validate_for_statics)
    for kind in ("sensors", "loads"):  # members and locations against the scene now (their form: the analysis)
        for i, d in enumerate(analysis.get(kind) or []):
            path = f"analysis.{kind}[{i}]"
            if d.get("kind") == "body":
                if d["member"] not in scene.bodies:
                    raise _fail(f"{path}.member", f"names no body; bodies: {sorted(scene.bodies)}", d["member"])
                continue
            _member_name(scene, f"{path}.member", d["member"])
            scene.check_at(d["member"], d.get("at", "end"), node_only=d.get("kind") == "coordinates",
                           field_name=f"{path}.at")
            if kind == "loads":
                _vector(f"{path}.force", d["force"], scene.dim)
    if analysis.get("release") is not None:  # (its form checked with the analysis, its labels here)
        from ancf_sym.dynamics.initial import check_release, released_scene
        released_scene(scene, check_release(analysis["release"]))
    if analysis.get("from_result") is not None:  # read now: a file of another mesh is refused before any work
        from ancf_sym.dynamics.initial import read_result
        src = Path(analysis["from_result"])
        src = src if src.is_absolute() or base is None else Path(base) / src
        read_result(src, build_mesh(scene).n)
        analysis["from_result"] = analysis.options.from_result = str(src)
    return scene, analysis


def load_scene(path: str | Path) -> tuple[Scene, Analysis]:
    """(Scene, Analysis) from a TOML file; SceneError (naming the TOML path of the field) on bad input.

    The scene name defaults to the file's stem. The Analysis is the [analysis] table as a dict ({"type": "statics",
    tol?, max_iter?, load_steps?, escape_saddle?, load_stepping?}, the table as written for "dynamics", "modal" with
    modes?, damped?) and its decoded `options` (StaticOptions or DynamicOptions)."""
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
    return scene_from_dict(doc, default_name=p.stem, base=p.parent)
