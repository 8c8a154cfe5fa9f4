"""Time-dependent point loads of a dynamic run: F(t) = factor(t) * force, factor piecewise linear in time."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ancf_sym.model.assembly import Assembly
from ancf_sym.util.checks import check_keys, fail, is_number
from ancf_sym.model.loads import point_force
from ancf_sym.util.checks import SceneError, vector
from ancf_sym.scene.schema import TIME_LOAD


@dataclass
class TimeLoad:
    """A point force F(t) = factor(t) * force at a node or material coordinate, factor piecewise linear in
    `history` [(t, factor), ...] (zero outside unless the first/last factor says otherwise: held constant)."""
    member: str
    at: Any
    force: Sequence[float]
    history: Sequence[Sequence[float]]

    @classmethod
    def from_dict(cls, d: dict, index: int) -> "TimeLoad":
        if isinstance(d, TimeLoad):
            return d
        if not isinstance(d, dict):
            raise SceneError(f"analysis.loads[{index}] must be a table with member, at, force, history; got {d!r}")
        # the keys declared in ancf_sym.scene.schema
        check_keys(f"analysis.loads[{index}]", d, TIME_LOAD, required=("member", "force", "history"))
        TIME_LOAD["member"].check(f"analysis.loads[{index}].member", d["member"])
        check_history(f"analysis.loads[{index}].history", d["history"])
        return cls(d["member"], d.get("at", "end"), d["force"], d["history"])


def check_history(path: str, history: Any) -> np.ndarray:
    """[[t, factor], ...] as an (n, 2) array: finite numbers, times increasing; errors name `path`."""
    pairs = history if isinstance(history, (list, tuple, np.ndarray)) else None
    if pairs is None or not all(isinstance(p, (list, tuple, np.ndarray)) and len(p) == 2 for p in pairs):
        raise fail(path, "must be a list of [t, factor] pairs", history)
    for k, p in enumerate(pairs):  # (strings and booleans are not numbers)
        for j, v in enumerate(p):
            if not is_number(v):
                raise fail(f"{path}[{k}][{j}]", "must be a number", v)
    H = np.asarray(pairs, dtype=float).reshape(-1, 2)
    if H.ndim != 2 or H.shape[1] != 2 or len(H) < 1 or not np.all(np.isfinite(H)) or np.any(np.diff(H[:, 0]) <= 0):
        raise fail(path, "must be [t, factor] pairs with increasing finite times", history)
    return H


class LoadSum:
    """The sum of the time loads as a generalized force on the unknowns (free: the map E from unknowns to
    coordinates): a callable of t."""

    def __init__(self, loads: list[TimeLoad], asm: Assembly, free: np.ndarray):
        self.vecs, self.hist = [], []
        for i, ld in enumerate(loads):
            asm.scene.check_at(ld.member, ld.at, node_only=False, field_name=f"analysis.loads[{i}].at")
            F = vector(f"analysis.loads[{i}].force", ld.force, asm.scene.dim)
            H = check_history(f"analysis.loads[{i}].history", ld.history)
            mm = asm.mesh.members[ld.member]
            idx, val = point_force(mm, mm.coordinate(ld.at), F)
            q = np.zeros(asm.n)
            np.add.at(q, idx, val)
            self.vecs.append(free.T @ q)
            self.hist.append(H)

    def __call__(self, t: float) -> np.ndarray:
        out = np.zeros_like(self.vecs[0])
        for q, H in zip(self.vecs, self.hist):
            out += np.interp(t, H[:, 0], H[:, 1]) * q
        return out

