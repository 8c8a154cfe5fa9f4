"""Input checks shared by the scene, dynamics and control front ends: errors name the field and the value."""
from __future__ import annotations

import math
from typing import Any


class SceneError(ValueError):
    """A scene value that cannot be simulated; the message names the field and the value."""


def number(name: str, value: Any, positive: bool = False, nonneg: bool = False) -> float:
    """A finite float (booleans refused), optionally > 0 or >= 0."""
    if isinstance(value, bool):
        raise SceneError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise SceneError(f"{name} must be finite, got {value!r}")
    if positive and v <= 0:
        raise SceneError(f"{name} must be positive, got {value!r}")
    if nonneg and v < 0:
        raise SceneError(f"{name} must be non-negative, got {value!r}")
    return v
