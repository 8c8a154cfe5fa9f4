"""Input checks shared by the scene, options, dynamics and control front ends: errors name the field and the value.

Every message reads `<field path>: <what is wrong>, got <value>`, the path as documented in docs/scenes.md
(`members[0].section.area`, `analysis.dt`). Values are shown as the user wrote them (numpy scalars as plain
numbers). Strings are never numbers and booleans are neither numbers nor integers.

The fields of the user-facing objects (Material, Section, StaticOptions, DynamicOptions, ...) are declared once, as
tables of `Field`s in ancf_sym.scene.schema; `check_fields` applies a table to an object, and the TOML reader and the
CLI take their allowed keys from the same tables.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

_MISSING = object()


class SceneError(ValueError):
    """A scene value that cannot be simulated; the message names the field and the value.

    path: the field path the message starts with (None for messages about several fields); front ends that know
    the field under another name (the TOML reader: `materials.steel` for the API's `material`) re-root it."""

    def __init__(self, message: str, path: str | None = None, detail: str | None = None):
        super().__init__(message)
        self.path, self.detail = path, detail

    def rerooted(self, root: str, new_root: str) -> "SceneError":
        """The same error with the path's leading `root` replaced by `new_root`; messages without a path (or
        under another root) get `new_root: ` in front."""
        if self.path is not None and (self.path == root or self.path.startswith((root + ".", root + "["))):
            path = new_root + self.path[len(root):]
            return SceneError(f"{path}: {self.detail}", path, self.detail)
        if self.path is None and root and str(self).startswith((root + ".", root + "[", root + ":")):
            return SceneError(new_root + str(self)[len(root):])  # a message that names its field in the text
        return SceneError(f"{new_root}: {self}", new_root, str(self))


def show(value: Any) -> str:
    """A value as the user would write it: numpy scalars and arrays as plain Python numbers and lists."""
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, (list, tuple)):
        value = type(value)(v.item() if isinstance(v, np.generic) else v for v in value)
    return repr(value)


def fail(path: str, what: str, value: Any = _MISSING) -> SceneError:
    """SceneError `path: what, got value` (without `, got` when no value is given)."""
    detail = what if value is _MISSING else f"{what}, got {show(value)}"
    return SceneError(f"{path}: {detail}", path, detail)


def is_number(value: Any) -> bool:
    """int or float (numpy's too); not bool, not str."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def is_integer(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def number(name: str, value: Any, positive: bool = False, nonneg: bool = False) -> float:
    """A finite float (strings and booleans refused), optionally > 0 or >= 0."""
    if not is_number(value):
        raise fail(name, "must be a number", value)
    v = float(value)
    if not math.isfinite(v):
        raise fail(name, "must be finite", value)
    if positive and v <= 0:
        raise fail(name, "must be positive", value)
    if nonneg and v < 0:
        raise fail(name, "must be non-negative", value)
    return v


def vector(name: str, value: Any, n: int) -> np.ndarray:
    """n finite numbers (a list, tuple or array; strings refused)."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
        raise fail(name, f"must be a vector of {n} numbers", value)
    if type(value) in (list, tuple) and len(value) == n and all(type(v) is float and math.isfinite(v) for v in value):
        return np.array(value, dtype=float)  # (the common case: n finite Python floats, as the loop below gives)
    a = np.asarray(value, dtype=object).ravel()
    if a.size != n:
        raise fail(name, f"must be {n} numbers", value)
    return np.array([number(f"{name}[{i}]", v) for i, v in enumerate(a)])


@dataclass(frozen=True)
class Field:
    """One declared field: kind "number" | "int" | "bool" | "str" | "vector" | "any" | "location" (these two checked
    by their owner; a location is "start", "end", a node index or a material coordinate), unit, bounds (positive,
    nonneg, an open interval `between`, an integer range `span`), allowed `choices`, and whether None is allowed.
    `doc` is the one-line description docs/scenes.md gives."""
    kind: str
    unit: str = ""
    positive: bool = False
    nonneg: bool = False
    between: tuple[float, float] | None = None  # open interval
    span: tuple[int, int] | None = None  # closed integer range
    choices: tuple | None = None
    optional: bool = False  # None allowed (the owner picks a default)
    size: int | None = None  # vectors
    doc: str = ""
    api_only: bool = False  # a Python API option, not a key of scene files

    def check(self, path: str, value: Any) -> Any:
        if value is None:
            if self.optional:
                return None
            raise fail(path, "is required", value)
        if self.kind == "number":
            v = number(path, value, self.positive, self.nonneg)
            if self.between is not None and not self.between[0] < v < self.between[1]:
                raise fail(path, f"must lie in ({self.between[0]:g}, {self.between[1]:g})", value)
            return v
        if self.kind == "int":
            if not is_integer(value):
                raise fail(path, "must be an integer" if not self.positive else "must be a positive integer", value)
            v = int(value)
            if self.positive and v < 1:
                raise fail(path, "must be a positive integer", value)
            if self.span is not None and not self.span[0] <= v <= self.span[1]:
                raise fail(path, f"must be an integer in {self.span[0]}..{self.span[1]}", value)
            if self.choices is not None and v not in self.choices:
                raise fail(path, f"must be one of {', '.join(map(str, self.choices))}", value)
            return v
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise fail(path, "must be true or false", value)
            return bool(value)
        if self.kind == "str":
            if not isinstance(value, str) or not value:
                raise fail(path, "must be a non-empty string"
                           + (f" ({' | '.join(map(str, self.choices))})" if self.choices else ""), value)
            if self.choices is not None and value not in self.choices:
                raise fail(path, f"must be one of {' | '.join(map(str, self.choices))}", value)
            return value
        if self.kind == "vector":
            return vector(path, value, self.size)
        return value


def check_fields(obj: Any, table: Mapping[str, Field], prefix: str) -> None:
    """Check (and normalise: ints to floats for numbers, numpy bools to bool) the declared fields of a dataclass
    instance in place; the first bad one raises SceneError naming `prefix.field`."""
    for name, spec in table.items():
        v = spec.check(f"{prefix}.{name}", getattr(obj, name))
        object.__setattr__(obj, name, v)  # also on frozen dataclasses


def check_keys(path: str, given: Mapping, allowed, required=()) -> None:
    """Refuse keys that are not allowed (naming them and the allowed ones) and missing required keys."""
    allowed = tuple(allowed)
    for k in given:
        if k not in allowed:
            raise fail(f"{path}.{k}" if path else str(k), f"unknown key (allowed: {', '.join(allowed)})", given[k])
    for k in required:
        if k not in given:
            raise fail(f"{path}.{k}" if path else k, "missing (required)")


def table_type(d: Mapping, keys_by_type: Mapping[str, tuple], default: str) -> str:
    """The `type` of a typed TOML table ([[contacts]], [[drives]]); unknown types and keys refused, naming the
    allowed ones."""
    kind = d.get("type", default)
    if kind not in keys_by_type:
        raise SceneError(f"type must be one of {sorted(keys_by_type)}, got {kind!r}")
    unknown = sorted(set(d) - set(keys_by_type[kind]))
    if unknown:
        raise SceneError(f"unknown key {unknown[0]!r} (allowed for type = {kind!r}: {', '.join(keys_by_type[kind])})")
    return kind
