"""Scene parameters addressed by their TOML path (``materials.steel.E``, ``loads[1].value[0]``).

A path names one real number of the scene document. Integers that count things (element counts), strings
(strain names, methods) and booleans are choices, not parameters: a path naming one is refused, as is a path
that names nothing, with the path and the value in the message.
"""
from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass
from typing import Any

_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_\-]*)((?:\[\d+\])*)")
_INDEX = re.compile(r"\[(\d+)\]")
# Keys whose integer values count or select things; integer values elsewhere are real numbers written without a point.
_COUNT_KEYS = {"dim", "elements", "n", "n_elements", "steps", "modes", "order", "points", "quadrature", "iterations"}


@dataclass(frozen=True)
class ParameterPath:
    text: str
    keys: tuple  # str for a table key, int for an array index


def parse_path(text: str) -> ParameterPath:
    """Split ``a.b[1].c`` into keys ('a', 'b', 1, 'c'); a malformed path is a ValueError naming it."""
    if not isinstance(text, str) or not text:
        raise ValueError(f"parameter path {text!r}: expected a TOML path such as 'materials.steel.E'")
    keys: list = []
    for part in text.split("."):
        m = _TOKEN.fullmatch(part)
        if m is None:
            raise ValueError(f"parameter path {text!r}: malformed part {part!r} "
                             "(expected name or name[index], e.g. 'loads[1].value[0]')")
        keys.append(m.group(1))
        keys.extend(int(i) for i in _INDEX.findall(m.group(2)))
    return ParameterPath(text, tuple(keys))


def _walk(doc: dict, path: ParameterPath) -> tuple[Any, Any]:
    """The container holding the last key, and that key; a missing step is a KeyError naming the path."""
    node: Any = doc
    where = ""
    for k in path.keys[:-1]:
        node = _step(node, k, path, where)
        where = f"{where}[{k}]" if isinstance(k, int) else (f"{where}.{k}" if where else k)
    _step(node, path.keys[-1], path, where)  # existence check
    return node, path.keys[-1]


def _step(node: Any, k: Any, path: ParameterPath, where: str) -> Any:
    if isinstance(k, int):
        if not isinstance(node, list):
            raise KeyError(f"parameter path {path.text!r}: {where or 'the scene'} is not an array")
        if k >= len(node):
            raise KeyError(f"parameter path {path.text!r}: {where} has {len(node)} entries, index {k} names nothing")
        return node[k]
    if not isinstance(node, dict):
        raise KeyError(f"parameter path {path.text!r}: {where or 'the scene'} is not a table")
    if k not in node:
        names = ", ".join(sorted(map(str, node))) or "none"
        raise KeyError(f"parameter path {path.text!r}: {where + '.' if where else ''}{k} names nothing "
                       f"(keys there: {names})")
    return node[k]


def get_parameter(doc: dict, path: str | ParameterPath) -> float:
    """The real number at ``path`` in a scene document; refuses choices (counts, names, flags) and non-numbers."""
    p = path if isinstance(path, ParameterPath) else parse_path(path)
    node, k = _walk(doc, p)
    v = node[k]
    last_name = next((key for key in reversed(p.keys) if isinstance(key, str)), "")
    if isinstance(v, bool) or isinstance(v, str):
        raise ValueError(f"parameter path {p.text!r} = {v!r}: a choice, not a differentiable number")
    if isinstance(v, int) and last_name in _COUNT_KEYS:
        raise ValueError(f"parameter path {p.text!r} = {v!r}: a count, not a differentiable number")
    if not isinstance(v, (int, float)):
        raise ValueError(f"parameter path {p.text!r}: names a {type(v).__name__}, not one number "
                         "(index it, e.g. 'loads[0].value[1]')")
    if not math.isfinite(float(v)):
        raise ValueError(f"parameter path {p.text!r} = {v!r}: not finite")
    return float(v)


def with_parameter(doc: dict, path: str | ParameterPath, value: float) -> dict:
    """A deep copy of the scene document with the number at ``path`` replaced by ``value`` (checked as above)."""
    p = path if isinstance(path, ParameterPath) else parse_path(path)
    get_parameter(doc, p)
    out = copy.deepcopy(doc)
    node, k = _walk(out, p)
    node[k] = float(value)
    return out
