"""result.json of a static solve: status, times, energies per effect, node positions, solver stats, constraints.

Layout (all lengths in m, energies in J, forces in N):

    {"format": "ancf_sym.statics/1", "scene": {"name", "file", "dim", "members": {name: {element, elements,
     length, effects}}}, "analysis": {...}, "status", "success", "wall_s": {"solve", "total"},
     "energies": {axial, bending, gravity, loads, ...}, "potential", "strain_energy",
     "solver": {"solved_by" (who produced the answer, with its own status), "path", "iterations" (Newton +
                IPOPT, all attempts), "attempts": [{method, status, iterations}], "stable"},
     "constraint_violation", "constraint_forces": {label: [...]}, "constraint_forces_sign": "...",
     "members": {name: {"nodes": [[x, y(, z)], ...], "slopes": [...], "tip": [...]}},
     "kernels": [{label, element, effect, gauss, elements}]}

Non-finite numbers are written as null (the file is strict JSON).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from . import contact, contact_exact
from .statics import StaticResult

FORMAT = "ancf_sym.statics/1"
# written into result.json beside the values, so that the file says what its numbers mean (docs/scenes.md)
CONSTRAINT_FORCES_SIGN = ("per label, one value per constraint row (position rows x, y(, z) first, then slope rows): "
                          "the force [N] the structure exerts ON the support (the support's reaction on the "
                          "structure is its negative); for a joint, the force member a exerts on member b; slope "
                          "rows: the moment-like multiplier [N m] of the fixed slope direction. Exact constraints: "
                          "the Lagrange multipliers; penalty: the penalty spring forces")


def _clean(v):
    """numpy -> Python, NaN/inf -> None, recursively."""
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, np.ndarray):
        return _clean(v.tolist())
    if isinstance(v, (np.bool_, bool)):
        return bool(v)
    if isinstance(v, (np.integer, int)):
        return int(v)
    if isinstance(v, (np.floating, float)):
        return float(v) if math.isfinite(v) else None
    return v


def static_result_dict(result: StaticResult, scene_file: str | Path | None = None, analysis: dict | None = None,
                       wall_total: float | None = None) -> dict:
    """The JSON document of a static result (see the module docstring)."""
    asm = result.assembly
    scene = asm.scene
    base = result.to_dict()
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
        "energies": base["energies"],
        "potential": base["potential"],
        "strain_energy": result.strain_energy,
        "solver": {"solved_by": result.solved_by, "path": result.path, "iterations": result.iterations,
                   "attempts": result.attempts, "stable": result.stable},
        "constraint_violation": result.constraint_violation,
        "constraint_forces": base["constraint_forces"],
        "constraint_forces_sign": CONSTRAINT_FORCES_SIGN,
        # per contact: min_gap [m], normal_force [N]; exact ones also per point gaps and forces (the multipliers)
        "contacts": contact.report(asm, result.x)
        + contact_exact.report(asm, result.x, result.constraint_forces.get("contact")),
        "members": {name: {**v, "tip": v["nodes"][-1]} for name, v in base["members"].items()},
        "kernels": [{"label": t.label, "element": t.element, "effect": t.effect, "gauss": t.gauss,
                     "elements": int(t.idx.shape[0])} for t in asm.terms],
    }
    return _clean(doc)


def _members_of(asm, term) -> set:
    """Names of the members whose coordinates a term touches."""
    first = term.idx[:, 0]
    return {name for name, mm in asm.mesh.members.items()
            if np.any((first >= mm.offset) & (first < mm.offset + mm.x0.size))}


def write_json(path: str | Path, doc: dict) -> Path:
    path = Path(path)
    path.write_text(json.dumps(_clean(doc), indent=1, allow_nan=False) + "\n")
    return path
