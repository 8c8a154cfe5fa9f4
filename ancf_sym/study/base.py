"""What a study is: a sweep over named axes, one run per setting, a reference, and an error per run.

A study module defines a `Study` and registers it (ancf_sym/study/__init__.py). Runs happen in worker processes,
so `run` and `reference` are plain module-level functions of (setting, variant) that return JSON-able dicts.
"""
from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable

from ancf_sym.util.checks import SceneError


class StudyError(SceneError):
    """Bad study input (unknown name or axis, empty sweep, unwritable folder) or a failed reference."""


@dataclass(frozen=True)
class Axis:
    name: str
    values: tuple  # the default sweep
    quick: tuple  # the test suite's sweep
    kind: type = str  # int | float | str: how --sweep values are read
    allowed: tuple | None = None  # categorical axes: the values a sweep may name
    help: str = ""
    positive: bool = True  # numeric values must be > 0 (else >= 0)

    def parse(self, text: str) -> Any:
        try:
            v = self.kind(text)
        except ValueError:
            raise StudyError(f"--sweep {self.name}: {text!r} is not a {self.kind.__name__}") from None
        if self.allowed is not None and v not in self.allowed:
            raise StudyError(f"--sweep {self.name}: {v!r} is not one of {list(self.allowed)}")
        if isinstance(v, (int, float)) and not (math.isfinite(v) and (v > 0 if self.positive else v >= 0)):
            raise StudyError(f"--sweep {self.name}: values must be {'positive' if self.positive else 'non-negative'} "
                             f"and finite, got {text!r}")
        return v


@dataclass(frozen=True)
class Study:
    name: str
    title: str
    axes: tuple[Axis, ...]
    run: Callable[[dict, str], dict]  # (setting, variant) -> record with at least status, success, wall_s
    reference: Callable[[str], dict]  # variant -> reference dict (must hold "how"); raises on failure
    error: Callable[[dict, dict], float]  # (record, reference) -> error measure (relative, >= 0)
    error_name: str  # e.g. "relative tip displacement error"
    target: float  # the error a user asks for (the report's answer names the cheapest setting reaching it)
    columns: tuple[str, ...] = ()  # extra record fields shown in the table
    refine_axis: str | None = "n"  # the axis of the convergence plot (error vs n)
    step_axis: str | None = None  # a step-size axis (error ~ dt^p): a second convergence plot
    conclusions: Callable[[list[dict], dict], list[str]] | None = None  # extra Markdown lines at the end
    notes: str = ""  # Markdown paragraph: model, reference, what is timed
    repeats: int = 1  # timing repeats per setting (min is kept)
    max_jobs: int | None = None  # e.g. 1 for studies timing sub-microsecond work: parallel workers would skew them
    extra: dict = field(default_factory=dict)

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name:
                return a
        raise StudyError(f"study {self.name!r} has no axis {name!r}; its axes: {[a.name for a in self.axes]}")

    def settings(self, variant: str, sweep: dict[str, list] | None = None) -> list[dict]:
        """The cartesian product of the axes (a --sweep replaces an axis' values)."""
        sweep = sweep or {}
        for k in sweep:
            self.axis(k)
        values = []
        for a in self.axes:
            vs = tuple(sweep[a.name]) if a.name in sweep else (a.quick if variant == "quick" else a.values)
            if not vs:
                raise StudyError(f"study {self.name!r}: the sweep over {a.name!r} is empty")
            values.append(vs)
        return [dict(zip([a.name for a in self.axes], combo)) for combo in itertools.product(*values)]


def setting_key(setting: dict) -> str:
    """File-name-safe identity of a setting, e.g. 'strain=green,n=6,gauss=5'."""
    text = ",".join(f"{k}={v}" for k, v in setting.items())
    return re.sub(r"[^A-Za-z0-9=,._+-]", "_", text)


def parse_sweep(study: Study, items: list[str] | None) -> dict[str, list]:
    """--sweep AXIS=V1,V2 ... -> {axis: [values]}; empty or unknown axes are refused."""
    out: dict[str, list] = {}
    for item in items or []:
        if "=" not in item:
            raise StudyError(f"--sweep {item!r}: expected AXIS=V1,V2,... (axes: {[a.name for a in study.axes]})")
        name, _, rest = item.partition("=")
        axis = study.axis(name.strip())
        vals = [v.strip() for v in rest.split(",") if v.strip()]
        if not vals:
            raise StudyError(f"--sweep {name}: empty list of values")
        out[axis.name] = list(dict.fromkeys(axis.parse(v) for v in vals))
    return out
