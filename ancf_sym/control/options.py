"""The options of a control problem that are not the scene: grid, scheme, horizon, costs, path constraints, end
conditions and IPOPT settings, checked once so that the model, bounds, transcription and warm start read them
without checking again."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ancf_sym.dynamics.collocation import Tableau, tableau
from ancf_sym.scene.builder import SceneError
from ancf_sym.util.checks import number as _num
from ancf_sym.control.ingredients import Effort, MinimumTime, PathConstraint, Swing

SCHEMES = ("radau", "gauss")


@dataclass
class ControlOptions:
    """The checked options (see ControlProblem for their meaning). K: intervals; tab: the Runge-Kutta tableau with
    s stages; T_bounds, T_guess: the horizon's range and start value (equal bounds: a fixed horizon)."""
    K: int
    scheme: str
    tab: Tableau
    control_form: str
    cost: list
    free_time: bool
    T_bounds: tuple[float, float]
    T_guess: float
    path: list = field(default_factory=list)
    terminal: list = field(default_factory=list)
    end_rest: bool = True
    end_modes: int | None = None
    end_frequency: float | None = None
    tol: float = 1e-8
    max_iter: int = 1000
    print_level: int = 0
    ipopt_extra: dict = field(default_factory=dict)

    @property
    def s(self) -> int:
        """Stages per interval."""
        return self.tab.s


def control_options(horizon: Any, cost: Sequence, path: Sequence, terminal: Sequence, intervals: int, stages: int,
                    scheme: str, end_rest: bool, end_modes: int | None, end_frequency: float | None,
                    control_form: str, tol: float, max_iter: int, print_level: int,
                    ipopt: dict | None) -> ControlOptions:
    """ControlOptions from ControlProblem's arguments, refusing bad ones (SceneError naming the argument) before
    any model is built."""
    if isinstance(intervals, bool) or not isinstance(intervals, (int, np.integer)) or intervals < 1:
        raise SceneError(f"intervals must be a positive integer, got {intervals!r}")
    if scheme not in SCHEMES:
        raise SceneError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    if control_form not in ("polynomial", "constant"):
        raise SceneError(f"control_form must be 'polynomial' (a value per collocation point) or 'constant' (one "
                         f"per interval), got {control_form!r}")
    tab = tableau(scheme, stages)
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise SceneError(f"max_iter must be a positive integer, got {max_iter!r}")
    tol = _num("tol", tol, positive=True)
    cost = list(cost) if isinstance(cost, (list, tuple)) else [cost]
    if not cost:
        raise SceneError("cost must name at least one term (Effort, MinimumTime, Swing)")
    for i, c in enumerate(cost):
        if not isinstance(c, (Effort, MinimumTime, Swing)):
            raise SceneError(f"cost[{i}] must be Effort, MinimumTime or Swing, got {c!r}")
        _num(f"cost[{i}].weight", c.weight, nonneg=True)
    free_time = any(isinstance(c, MinimumTime) for c in cost)
    T_bounds, T_guess = _horizon(horizon, free_time)
    return ControlOptions(K=int(intervals), scheme=scheme, tab=tab, control_form=control_form, cost=cost,
                          free_time=free_time, T_bounds=T_bounds, T_guess=T_guess, path=list(path),
                          terminal=list(terminal), end_rest=bool(end_rest), end_modes=end_modes,
                          end_frequency=end_frequency, tol=tol, max_iter=int(max_iter),
                          print_level=int(print_level), ipopt_extra=dict(ipopt or {}))


def _horizon(horizon: Any, free_time: bool) -> tuple[tuple[float, float], float]:
    """((lower, upper), guess) of the horizon: a range with a MinimumTime cost, one number otherwise."""
    if free_time:
        if not isinstance(horizon, (tuple, list)) or len(horizon) != 3:
            raise SceneError(f"a MinimumTime cost needs horizon=(lower, guess, upper) [s], got {horizon!r}")
        lo, g, hi = (_num(f"horizon[{i}]", v) for i, v in enumerate(horizon))
        if not 0 < lo <= g <= hi:
            raise SceneError(f"horizon (lower, guess, upper) must satisfy 0 < lower <= guess <= upper, got "
                             f"{tuple(horizon)!r}")
        return (lo, hi), g
    if isinstance(horizon, (tuple, list)):
        raise SceneError(f"horizon must be one number T [s] without a MinimumTime cost, got {horizon!r}")
    T = _num("horizon", horizon)
    if T <= 0:
        raise SceneError(f"horizon must be positive, got {horizon!r}")
    return (T, T), T


def check_constraints(path: Sequence, terminal: Sequence, end_modes: Any, end_frequency: Any) -> None:
    """Refuse path/terminal items that are not PathConstraints and bad end-mode settings."""
    for label, items in (("path", path), ("terminal", terminal)):
        for i, pc in enumerate(items):
            if not isinstance(pc, PathConstraint) or not callable(pc.fn):
                raise SceneError(f"{label}[{i}] must be a PathConstraint with a callable fn, got {pc!r}")
    if end_modes is not None and (isinstance(end_modes, bool) or not isinstance(end_modes, (int, np.integer))
                                  or end_modes < 1):
        raise SceneError(f"end_modes must be a positive integer, got {end_modes!r}")
    if end_frequency is not None:
        _num("end_frequency", end_frequency, positive=True)
