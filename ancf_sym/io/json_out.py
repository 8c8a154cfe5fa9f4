"""result.json of a static solve: status, times, energies per effect, node positions, solver stats, constraints.

Layout (all lengths in m, energies in J, forces in N):

    {"format": "ancf_sym.statics/1", "scene": {"name", "file", "dim", "members": {name: {element, elements,
     length, effects}}}, "analysis": {...}, "status", "success", "wall_s": {"solve", "total"},
     "energies": {axial, bending, gravity, loads, ...}, "potential", "strain_energy",
     "solver": {"solved_by" (who produced the answer, with its own status), "path", "iterations" (Newton +
                IPOPT, all attempts), "attempts": [{method, status, iterations}], "stable"},
     "constraint_violation", "constraint_forces": {label: [...]}, "constraint_forces_sign": "...",
     "members": {name: {"nodes": [[x, y(, z)], ...], "slopes": [...], "tip": [...]}},
     "kernels": [{label, element, effect, gauss, elements}], "x": [all coordinates]}

Non-finite numbers are written as null (the file is strict JSON).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ancf_sym.contact import exact as contact_exact, gap as contact_gap, summary as contact
from ancf_sym.statics.problem import StaticResult

FORMAT = "ancf_sym.statics/1"
# written into result.json beside the values, so that the file says what its numbers mean (docs/scenes.md)
CONSTRAINT_FORCES_SIGN = ("per label, one value per constraint row (position rows x, y(, z) first, then slope rows): "
                          "the force [N] the structure exerts ON the support (the support's reaction on the "
                          "structure is its negative); for a joint, the force member a exerts on member b; slope "
                          "rows: the moment-like multiplier [N m] of the fixed slope direction. Exact constraints: "
                          "the Lagrange multipliers; penalty: the penalty spring forces")


def json_ready(v):
    """numpy -> Python, NaN/inf -> None, recursively (arrays and lists of floats in one NumPy pass)."""
    if isinstance(v, dict):
        return {str(k): json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        fast = _float_array(v)
        if fast is not None:
            return fast
        return [json_ready(x) for x in (v.tolist() if isinstance(v, np.ndarray) else v)]
    if isinstance(v, (np.bool_, bool)):
        return bool(v)
    if isinstance(v, (np.integer, int)):
        return int(v)
    if isinstance(v, (np.floating, float)):
        return float(v) if math.isfinite(v) else None
    return v


def _float_array(v) -> list | None:
    """v as nested lists of Python floats (non-finite ones None) if it is a rectangular array of floats; else None
    (ints stay ints, anything else goes the general way)."""
    first = v
    while isinstance(first, (list, tuple)) and len(first):
        first = first[0]
    if isinstance(v, np.ndarray):
        if v.dtype.kind != "f" or v.size == 0:
            return None
        a = v
    elif not isinstance(first, (float, np.floating)):
        return None
    else:
        try:
            a = np.asarray(v)
        except ValueError:  # ragged
            return None
        if a.dtype.kind != "f":  # strings, None, dicts, bools: the general way
            return None
    finite = np.isfinite(a)
    if finite.all():
        return a.tolist()
    o = a.astype(object)
    o[~finite] = None
    return o.tolist()


def static_result_dict(result: StaticResult, scene_file: str | Path | None = None, analysis: dict | None = None,
                       wall_total: float | None = None) -> dict:
    """The JSON document of a static result (see the module docstring)."""
    asm = result.assembly
    scene = asm.scene
    members = {}
    for name, m in scene.members.items():
        effects = list(dict.fromkeys(t.label for t in asm.terms if name in _members_of(asm, t)))
        members[name] = {"element": m.element, "elements": m.elements, "length": m.length, "effects": effects}
    doc = {
        "format": FORMAT,
        "scene": {"name": scene.name, "file": str(Path(scene_file).resolve()) if scene_file else None,
                  "dim": scene.dim, "members": members},
        "analysis": analysis or {"type": "statics"},
        "status": result.status,
        "success": result.success,
        "wall_s": {"solve": result.wall_s, "total": wall_total},
        "energies": result.energies,
        "potential": result.potential if result.success else None,
        "strain_energy": result.strain_energy,
        "solver": {"solved_by": result.solved_by, "path": result.path, "iterations": result.iterations,
                   "attempts": result.attempts, "stable": result.stable},
        "constraint_violation": result.constraint_violation,
        "constraint_forces": {k: np.asarray(v) for k, v in result.constraint_forces.items()},
        "constraint_forces_sign": CONSTRAINT_FORCES_SIGN,
        # per contact: min_gap [m], normal_force [N], the true smallest gap between the points (contact.gap); exact
        # ones also per point gaps and forces (the multipliers)
        "contacts": contact.report(asm, result.x)
        + [{**r, **g} for r, g in zip(contact_exact.report(asm, result.x, result.constraint_forces.get("contact")),
                                      contact_gap.report(asm, result.x, "exact"))],
        # (arrays, as StaticResult.to_dict's lists: converted once, by json_ready)
        "members": {name: {"nodes": result.nodes(name), "slopes": result.slopes(name), "tip": result.tip(name)}
                    for name in asm.mesh.members},
        "kernels": [{"label": t.label, "element": t.element, "effect": t.effect, "gauss": t.gauss,
                     "elements": int(t.idx.shape[0])} for t in asm.terms],
        "x": np.asarray(result.x, float),  # all coordinates: a later run starts from them (analysis.from_result)
    }
    return json_ready(doc)


def _members_of(asm, term) -> set:
    """Names of the members whose coordinates a term touches."""
    first = term.idx[:, 0]
    return {name for name, mm in asm.mesh.members.items()
            if np.any((first >= mm.offset) & (first < mm.offset + mm.x0.size))}


def write_json(path: str | Path, doc: dict, clean: bool = True) -> Path:
    """Strict JSON, one key per line; a list of numbers on one line, a list of such lists one row per line (json's
    indenting encoder is pure Python: ~3 s for a 150 000-node result; this writes with json's C encoder).
    clean=False: doc is already json_ready's output (static_result_dict), not converted twice."""
    path = Path(path)
    path.write_text(_dumps(json_ready(doc) if clean else doc, 0) + "\n")
    return path


def _dumps(v, level: int) -> str:
    pad, inner = " " * level, " " * (level + 1)
    if isinstance(v, dict):
        if not v:
            return "{}"
        items = [f"{inner}{json.dumps(k)}: {_dumps(x, level + 1)}" for k, x in v.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(v, list) and v and isinstance(v[0], dict):
        return "[\n" + ",\n".join(inner + _dumps(x, level + 1) for x in v) + "\n" + pad + "]"
    text = json.dumps(v, allow_nan=False)
    if isinstance(v, list) and len(v) > 1 and '"' not in text and "{" not in text and \
            text.count("[") == len(v) + 1:  # rows of numbers (every item a list, none deeper): one row per line
        return "[\n" + inner + text[1:-1].replace("], [", "],\n" + inner + "[") + "\n" + pad + "]"
    return text
