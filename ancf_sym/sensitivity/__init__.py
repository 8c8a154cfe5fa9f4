"""Exact sensitivities of results to scene parameters named by their TOML path, and calibration
(docs/sensitivity.md)."""
from .api import sensitivities
from .calibrate import Calibration, calibrate
from .paths import ParameterPath, get_parameter, parse_path, with_parameter
from .static import StaticSensitivity

__all__ = ["ParameterPath", "parse_path", "get_parameter", "with_parameter", "sensitivities", "calibrate",
           "Calibration", "StaticSensitivity"]
