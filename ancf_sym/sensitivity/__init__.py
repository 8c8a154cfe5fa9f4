"""Sensitivities of results to scene parameters named by their TOML path."""
from ancf_sym.sensitivity.paths import ParameterPath, parse_path, get_parameter, with_parameter

__all__ = ["ParameterPath", "parse_path", "get_parameter", "with_parameter"]
