"""Exact sensitivities of results to scene parameters named by their TOML path, and calibration
(docs/sensitivity.md)."""
from ancf_sym.sensitivity.adjoint import EnergyOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.calibrate import Calibration, calibrate
from ancf_sym.sensitivity.frequency_fit import calibrate_frequencies
from ancf_sym.sensitivity.calibrate_history import SensorHistory
from ancf_sym.sensitivity.paths import ParameterPath, get_parameter, parse_path, with_parameter
from ancf_sym.sensitivity.static import StaticSensitivity

__all__ = ["ParameterPath", "parse_path", "get_parameter", "with_parameter", "sensitivities", "calibrate",
           "calibrate_frequencies", "Calibration", "StaticSensitivity", "dynamic_gradient", "SensorOutput",
           "EnergyOutput", "SensorHistory"]
