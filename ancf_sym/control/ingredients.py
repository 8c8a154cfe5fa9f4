"""What a control problem is made of: controls (support motions, point forces), payloads, costs, path
constraints, and the view of one instant that path constraints are written against."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np




@dataclass(frozen=True)
class PointMass:
    """A concentrated mass [kg] at a node of a member (e.g. a crane's payload); its weight follows scene.gravity."""
    member: str
    at: Any
    mass: float


@dataclass(frozen=True)
class SupportMotion:
    """Prescribed translation of a supported node (pin or clamp) along `axes` (0 = x, 1 = y, 2 = z).

    Each axis is a channel named `name` (one axis) or `name_x`, `name_y`, ... with the states
    `<channel>.position` (displacement from the reference [m]) and `<channel>.velocity` [m/s], and the control
    `<channel>.acceleration` [m/s^2]."""
    member: str
    at: Any = "start"
    axes: tuple = (0,)
    name: str = "support"


@dataclass(frozen=True)
class PointForce:
    """A controlled dead force of magnitude `<name>.force` [N] along the fixed `direction` at a node or material
    coordinate s [m] (float)."""
    member: str
    at: Any
    direction: Sequence[float]
    name: str = "force"


@dataclass(frozen=True)
class Effort:
    """Integral of sum_c w_c u_c^2 over the horizon; `weights` per control name (default 1 for all)."""
    weight: float = 1.0
    weights: dict | None = None


@dataclass(frozen=True)
class MinimumTime:
    """weight * T: the horizon becomes a decision variable (give `horizon` as (lower, guess, upper))."""
    weight: float = 1.0


@dataclass(frozen=True)
class Swing:
    """Integral of the kinetic energy of the scene relative to the controlled supports' translation [J s]."""
    weight: float = 1.0


@dataclass(frozen=True)
class PathConstraint:
    """lower <= fn(view) <= upper at every collocation point. fn receives a `StateView` of CasADi expressions
    (positions, velocities, support channels, controls) and returns an expression (scalar or vector); polynomial
    expressions keep IPOPT's exact Hessian cheap (CasADi differentiates them)."""
    fn: Callable
    lower: Any = -np.inf
    upper: Any = np.inf
    name: str = "path"
