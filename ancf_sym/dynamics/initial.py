"""Initial velocities a user can write: per member a uniform velocity, a rigid rotation about a point, or a velocity
field along the member; the result is the full vector v0 of DynamicOptions (whose layout the user need not know).

For the nodal coordinates [r, r_x (, r_y, r_z)] of a node at material coordinate s:
- uniform v:                 r' = v,                        r_x' = r_y' = r_z' = 0
- rotation omega about c:    r' = omega x (r - c),          r_x' = omega x r_x (likewise r_y, r_z): no strain rate
- field v(s) with dv/ds:     r' = v(s),                     r_x' = dv/ds(s) (cables; the derivative is the user's)
In 2D omega is the scalar rate about z. Rigid bodies (centre r and unit vectors u: planar u = (cos, sin), spatial
the axes e1, e2, e3) take uniform (r' = v, u' = 0) and rotation (r' = omega x (r - c), u' = omega x u) under
their names. Members not named keep zero velocity; later entries overwrite earlier ones.
A start from a static result is DynamicOptions(q0=static_result.x) (with these velocities or at rest), or
start = "static" (with `release`: supports that hold that statics and not the run, `released_scene`), or a
result.json of an earlier run (from_result: `read_result`). The same per-member velocities as tables (TOML
[[initial]], DynamicOptions.initial): `from_specs`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ancf_sym.scene.builder import SceneError


def _cross(omega, r: np.ndarray) -> np.ndarray:
    """omega x r for rows of r (2D: omega scalar about z)."""
    if r.shape[-1] == 2:
        return float(omega) * np.stack([-r[..., 1], r[..., 0]], axis=-1)
    return np.cross(np.asarray(omega, float), r)


def _member(asm, name: str):
    if name in asm.mesh.bodies:
        return None
    if name not in asm.mesh.members:
        raise SceneError(f"initial velocity: member {name!r} does not exist; members: {sorted(asm.mesh.members)}")
    return asm.mesh.members[name]


def _vector(what: str, v, n: int) -> np.ndarray:
    a = np.asarray(v, float).ravel()
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise SceneError(f"initial velocity: {what} must be {n} finite numbers, got {v!r}")
    return a


def velocities(asm, x: np.ndarray | None = None, uniform: dict | None = None, rotation: dict | None = None,
               field: dict | None = None) -> np.ndarray:
    """v0 (full coordinates) for the configuration x (default the reference state).

    uniform: {member: v}; rotation: {member: (omega, centre)}; field: {member: (v(s), dv/ds(s))}, callables of the
    material coordinate s [m] returning dim-vectors."""
    d = asm.scene.dim
    x = asm.x0 if x is None else np.asarray(x, float)
    v = np.zeros(asm.n)
    for name, vel in (uniform or {}).items():
        mm = _member(asm, name)
        if mm is None:  # a rigid body: its centre moves, its unit vectors do not turn
            o = asm.mesh.bodies[name]
            v[o:o + d] = _vector(f"uniform[{name!r}]", vel, d)
            continue
        V = np.zeros((mm.n_nodes, mm.node_size))
        V[:, :d] = _vector(f"uniform[{name!r}]", vel, d)
        v[mm.offset:mm.offset + V.size] = V.ravel()
    for name, spec in (rotation or {}).items():
        mm = _member(asm, name)
        if not isinstance(spec, (tuple, list)) or len(spec) != 2:
            raise SceneError(f"initial velocity: rotation[{name!r}] must be (omega, centre), got {spec!r}")
        omega = _vector(f"rotation[{name!r}] omega", spec[0], 1 if d == 2 else 3)
        omega = omega[0] if d == 2 else omega
        c = _vector(f"rotation[{name!r}] centre", spec[1], d)
        if mm is None:  # a rigid body turning about c: its centre, then its unit vectors (d components each)
            o = asm.mesh.bodies[name]
            size = len(asm.scene.bodies[name].q0)
            v[o:o + d] = _cross(omega, x[o:o + d] - c)
            v[o + d:o + size] = _cross(omega, x[o + d:o + size].reshape(-1, d)).ravel()
            continue
        X = asm.member_coordinates(x, name)
        V = np.zeros_like(X)
        V[:, :d] = _cross(omega, X[:, :d] - c)
        for k in range(1, mm.node_size // d):  # gradient vectors turn with the body
            V[:, k * d:(k + 1) * d] = _cross(omega, X[:, k * d:(k + 1) * d])
        v[mm.offset:mm.offset + V.size] = V.ravel()
    for name, spec in (field or {}).items():
        mm = _member(asm, name)
        if mm is None:
            raise SceneError(f"initial velocity: field[{name!r}]: {name!r} is a rigid body (use uniform or rotation)")
        if mm.member.element == "beam3d":
            raise SceneError(f"initial velocity: field[{name!r}]: velocity fields are for cables (beam3d: use "
                             "uniform or rotation)")
        if not isinstance(spec, (tuple, list)) or len(spec) != 2 or not all(callable(f) for f in spec):
            raise SceneError(f"initial velocity: field[{name!r}] must be (v(s), dv/ds(s)) callables, got {spec!r}")
        V = np.zeros((mm.n_nodes, mm.node_size))
        for i, s in enumerate(mm.s_node):
            V[i, :d] = _vector(f"field[{name!r}] v({s:g})", spec[0](s), d)
            V[i, d:2 * d] = _vector(f"field[{name!r}] dv/ds({s:g})", spec[1](s), d)
        v[mm.offset:mm.offset + V.size] = V.ravel()
    return v


def check_specs(specs: Any) -> list[dict]:
    """The [[initial]] tables (schema.INITIAL) checked for their form: a list of tables, each naming a member or
    body and giving either a uniform `velocity` or a rotation `omega` (about `centre`, default the origin).
    Names and sizes are checked against the scene by `from_specs`."""
    from ancf_sym.util.checks import check_keys, fail
    from ancf_sym.scene.schema import INITIAL

    if not isinstance(specs, (list, tuple)):
        raise fail("initial", "must be a list of tables (member, velocity | omega, centre)", specs)
    for i, d in enumerate(specs):
        path = f"initial[{i}]"
        if not isinstance(d, dict):
            raise fail(path, "must be a table (member, velocity | omega, centre)", d)
        check_keys(path, d, INITIAL, ("member",))
        INITIAL["member"].check(f"{path}.member", d["member"])
        if ("velocity" in d) == ("omega" in d):
            raise fail(path, "give either velocity (uniform) or omega (rigid rotation)", d)
        if "centre" in d and "omega" not in d:
            raise fail(f"{path}.centre", "belongs to a rotation (omega)", d["centre"])
    names = [d["member"] for d in specs]
    for name in names:
        if names.count(name) > 1:
            raise fail("initial", f"member {name!r} is given more than once", names)
    return list(specs)


def from_specs(asm, x: np.ndarray, specs: list[dict]) -> np.ndarray:
    """v0 (full coordinates) at configuration x from checked [[initial]] tables; errors name initial[i]."""
    from ancf_sym.util.checks import SceneError as _E

    v = np.zeros(asm.n)
    d = asm.scene.dim
    for i, spec in enumerate(specs):
        name = spec["member"]
        try:
            if "velocity" in spec:
                one = velocities(asm, x, uniform={name: spec["velocity"]})
            else:
                omega = spec["omega"]
                omega = [omega] if d == 2 and not isinstance(omega, (list, tuple, np.ndarray)) else omega
                one = velocities(asm, x, rotation={name: (omega, spec.get("centre", [0.0] * d))})
        except _E as exc:
            raise _E(f"initial[{i}]: {exc}") from None
        v += one  # each entry sets only its own member's or body's coordinates
    return v


def static_start(scene) -> np.ndarray:
    """The static equilibrium's coordinates, to start a dynamic run from (pre-loaded, then released)."""
    from ancf_sym.statics.problem import solve_static

    r = solve_static(scene)
    if not r.success:
        raise SceneError(f"analysis.start: the static solve to start from failed with status {r.status!r}")
    return np.asarray(r.x, float).copy()


def check_release(release: Any) -> list:
    """`release` checked for its form: a non-empty list of support labels ("pin beam@end", as the results name
    them) or indices of the scene's supports; `released_scene` checks them against the scene."""
    from ancf_sym.util.checks import fail, is_integer

    if isinstance(release, (str, int)) and not isinstance(release, bool):
        release = [release]
    if not isinstance(release, (list, tuple)) or not release:
        raise fail("analysis.release", "must be a list of support labels (\"pin beam@end\") or [[supports]] "
                   "indices", release)
    for i, r in enumerate(release):
        if not (isinstance(r, str) and r) and not is_integer(r):
            raise fail(f"analysis.release[{i}]", "must be a support label (\"pin beam@end\") or an index of "
                       "[[supports]]", r)
    return list(release)


def support_label(s) -> str:
    """A support's label, as the results' constraint forces name it (ancf_sym.model.constraints)."""
    return f"{s.kind} {s.member}@{s.at}"


def released_scene(scene, release: list):
    """A copy of the scene without the supports `release` names (labels or indices; errors name
    analysis.release[i] and list the supports there are)."""
    import copy

    from ancf_sym.util.checks import fail, is_integer

    labels = [support_label(s) for s in scene.supports]
    drop = set()
    for i, r in enumerate(release):
        if is_integer(r):
            if not 0 <= r < len(labels):
                raise fail(f"analysis.release[{i}]", f"the scene has supports 0..{len(labels) - 1}: {labels}", r)
            drop.add(int(r))
        elif r in labels:
            drop.add(labels.index(r))
        else:
            raise fail(f"analysis.release[{i}]", f"names no support; supports: {labels}", r)
    out = copy.copy(scene)
    out.supports = [s for k, s in enumerate(scene.supports) if k not in drop]
    return out


def read_result(path, n: int, field: str = "analysis.from_result") -> tuple[np.ndarray, np.ndarray | None]:
    """(coordinates, velocities or None) of a result.json written by `ancf-sym run` (statics: "x"; dynamics: the
    final "x" and "v"), refused unless they are n finite numbers (the same mesh); errors name `field`."""
    import json
    from pathlib import Path

    from ancf_sym.util.checks import fail

    p = Path(path)
    try:
        doc = json.loads(p.read_text())
    except FileNotFoundError:
        raise fail(field, "no such file", str(p)) from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise fail(field, f"cannot read it as a result.json ({exc})", str(p)) from None
    if not isinstance(doc, dict) or not isinstance(doc.get("x"), list):
        raise fail(field, "is not a result.json with coordinates \"x\" (written by ancf-sym run)", str(p))
    if doc.get("success") is False:
        raise fail(field, f"is a failed run (status {doc.get('status')!r}); start from a successful one", str(p))
    out = []
    for key in ("x", "v"):
        if key not in doc:
            out.append(None)
            continue
        a = np.asarray([np.nan if v is None else v for v in doc[key]], dtype=float) \
            if isinstance(doc[key], list) else None
        if a is None or a.ndim != 1 or a.size != n:
            size = a.size if a is not None else doc[key]
            raise fail(field, f"{key!r} has {size} coordinates, this scene's mesh {n} (the result is of another "
                       "mesh: same members, elements, bodies and order needed)", str(p))
        if not np.all(np.isfinite(a)):
            raise fail(field, f"{key!r} has non-finite entries", str(p))
        out.append(a)
    return out[0], out[1]
