"""Options of a dynamic analysis (the [analysis] table of type "dynamics"): declared once as DynamicOptions fields,
checked against ancf_sym.scene.schema, read by the Python API, the TOML reader and the CLI."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ancf_sym.dynamics import initial as initial_state
from ancf_sym.util.checks import check_fields, check_keys, fail, number
from ancf_sym.scene.builder import SceneError
from ancf_sym.scene.schema import DYNAMIC_OPTIONS
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.dynamics.schemes import Scheme
from ancf_sym.dynamics.sensors import Sensor
from ancf_sym.dynamics.time_loads import TimeLoad

INTEGRATORS = {"newmark": "newmark", "hht": "hht", "hht_alpha": "hht", "generalized_alpha": "generalized_alpha",
               "generalized-alpha": "generalized_alpha", "genalpha": "generalized_alpha",
               "gen_alpha": "generalized_alpha", "radau": "radau", "radau_iia": "radau", "radauiia": "radau",
               "gauss": "gauss", "gauss_legendre": "gauss", "gauss-legendre": "gauss"}


@dataclass
class DynamicOptions:
    dt: float
    t_end: float
    integrator: str = "generalized_alpha"
    t_start: float = 0.0
    rho_inf: float = 0.9  # generalized-alpha spectral radius at infinite frequency
    alpha: float = -0.05  # HHT
    beta: float = 0.25  # Newmark
    gamma: float = 0.5  # Newmark
    stages: int | None = None  # collocation stages (radau default 3, gauss default 2)
    adaptive: bool = False
    tol: float | None = None  # adaptive: local error tolerance [m] (default 1e-6 x length scale)
    dt_min: float | None = None  # smallest step before giving up (default dt * 2^-12)
    dt_max: float | None = None  # adaptive: largest step (default 100 dt... but at most the output spacing)
    output_every: int | None = None  # record every k accepted steps (fixed step); default: ~200 outputs
    output_dt: float | None = None  # record at t_start + k output_dt
    output_times: Sequence[float] | None = None  # record at these times
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    sensors: list = field(default_factory=list)
    loads: list = field(default_factory=list)  # TimeLoad (time-dependent point forces)
    energies: bool = True  # record the energy balance at output times (one energy evaluation per output)
    record_states: bool = False  # keep every coordinate at the output times (DynamicResult.states)
    q0: np.ndarray | None = None  # initial coordinates (full, default the reference state)
    v0: np.ndarray | None = None  # initial velocities (full, default zero)
    initial: list | None = None  # initial velocities per member/body ([[initial]] tables, ancf_sym.dynamics.initial)
    start: str | None = None  # "reference" (default) | "static": start from the static equilibrium
    release: list | None = None  # supports of the static start released for the run (labels or indices)
    from_result: str | None = None  # a result.json to start from (ancf_sym.dynamics.initial.from_result)

    def __post_init__(self):
        check_fields(self, DYNAMIC_OPTIONS, "analysis")  # types and ranges as declared in ancf_sym.scene.schema
        if self.initial is not None:
            self.initial = initial_state.check_specs(self.initial)
            if self.v0 is not None:
                raise fail("analysis.initial", "and v0 both give the initial velocities: give one", self.initial)
        if self.start == "static" and self.q0 is not None:
            raise fail("analysis.start", "= 'static' and q0 both give the initial state: give one", self.start)
        if self.release is not None:
            if self.start != "static":
                raise fail("analysis.release", "releases supports after the starting statics: give start = "
                           "\"static\" with it", self.release)
            self.release = initial_state.check_release(self.release)
        if self.from_result is not None:
            for other in ("q0", "v0", "start"):
                if getattr(self, other) is not None:
                    raise fail("analysis.from_result", f"and {other} both give the initial state: give one",
                               self.from_result)
        if self.t_end <= self.t_start:
            raise fail("analysis.t_end", f"must be greater than t_start = {self.t_start:g}", self.t_end)
        if self.dt > self.t_end - self.t_start:
            raise fail("analysis.dt", f"must not exceed t_end - t_start = {self.t_end - self.t_start:g} s", self.dt)
        if self.integrator not in INTEGRATORS:
            raise SceneError(f"analysis.integrator: must be one of {sorted(set(INTEGRATORS.values()))} (aliases "
                             f"{sorted(INTEGRATORS)}), got {self.integrator!r}")
        self.integrator = INTEGRATORS[self.integrator]
        self.scheme()  # checks rho_inf / alpha / beta, gamma
        if self.dt_min is not None:
            if self.dt_min > self.dt:
                raise fail("analysis.dt_min", f"must not exceed dt = {self.dt:g}", self.dt_min)
        if self.dt_max is not None:
            if self.dt_max < self.dt:
                raise fail("analysis.dt_max", f"must not be below dt = {self.dt:g}", self.dt_max)
        given = [k for k in ("output_every", "output_dt", "output_times") if getattr(self, k) is not None]
        if len(given) > 1:
            raise fail("analysis", "give one of output_every, output_dt, output_times", given)
        if self.output_every is not None:
            if self.adaptive:
                raise fail("analysis.output_every", "needs fixed steps; with adaptive = true give output_dt or "
                           "output_times")
        if self.output_times is not None:
            if isinstance(self.output_times, (str, bytes)) or not isinstance(self.output_times,
                                                                             (list, tuple, np.ndarray)):
                raise fail("analysis.output_times", "must be a list of numbers", self.output_times)
            ot = np.array([number(f"analysis.output_times[{i}]", v)
                           for i, v in enumerate(np.asarray(self.output_times, dtype=object).ravel())])
            eps = 1e-12 * max(1.0, abs(self.t_end))
            bad = ot[~np.isfinite(ot) | (ot < self.t_start - eps) | (ot > self.t_end + eps)]
            if len(bad):
                raise fail("analysis.output_times", f"must lie in [t_start, t_end] = [{self.t_start:g}, "
                           f"{self.t_end:g}]", bad.tolist())
            self.output_times = np.unique(np.clip(ot, self.t_start, self.t_end))
        if isinstance(self.newton, dict):
            unknown = set(self.newton) - set(NewtonOptions.__dataclass_fields__)
            if unknown:
                raise SceneError(f"newton: unknown option(s) {sorted(unknown)}; known: "
                                 f"{sorted(NewtonOptions.__dataclass_fields__)}")
            self.newton = NewtonOptions(**self.newton)
        elif not isinstance(self.newton, NewtonOptions):
            raise SceneError(f"newton must be a table of Newton options, got {self.newton!r}")
        if not isinstance(self.sensors, (list, tuple)):
            raise SceneError(f"sensors must be a list, got {self.sensors!r}")
        self.sensors = [Sensor.from_dict(s, i) for i, s in enumerate(self.sensors)]
        names = [s.name for s in self.sensors]
        if len(set(names)) != len(names):
            raise SceneError(f"sensor names must be unique, got {names}")
        if not isinstance(self.loads, (list, tuple)):
            raise SceneError(f"loads must be a list, got {self.loads!r}")
        self.loads = [TimeLoad.from_dict(d, i) for i, d in enumerate(self.loads)]

    @property
    def n_grid(self) -> int:
        """Whole steps of dt in [t_start, t_end] (a shorter last step, if any, comes after them)."""
        return int(math.floor((self.t_end - self.t_start) / self.dt + 1e-9))

    def scheme(self) -> Scheme | None:
        if self.integrator == "newmark":
            return Scheme.newmark(number("beta", self.beta), number("gamma", self.gamma))
        if self.integrator == "hht":
            return Scheme.hht(number("alpha", self.alpha))
        if self.integrator == "generalized_alpha":
            return Scheme.generalized_alpha(number("rho_inf", self.rho_inf))
        return None


def options_from_dict(analysis: dict) -> DynamicOptions:
    """DynamicOptions from a TOML [analysis] table of type "dynamics" (keys as the DynamicOptions fields)."""
    if not isinstance(analysis, dict):
        raise SceneError(f"analysis must be a table, got {analysis!r}")
    if analysis.get("type", "dynamics") != "dynamics":
        raise SceneError(f"analysis.type must be 'dynamics' here, got {analysis.get('type')!r}")
    check_keys("analysis", analysis, ("type", *DYNAMIC_OPTIONS), ("dt", "t_end"))
    kw = {k: v for k, v in analysis.items() if k != "type"}
    try:
        return DynamicOptions(**kw)
    except SceneError as exc:  # sub-tables (newton, sensors, loads) name their field from inside the table
        msg = str(exc)
        if msg.startswith("analysis"):
            raise
        head = re.match(r"(newton|sensors|loads|initial)\b[.\[:]?", msg)
        raise SceneError(f"analysis.{msg}" if head else f"analysis: {msg}") from None
