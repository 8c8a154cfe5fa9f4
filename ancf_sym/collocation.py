"""Compatibility import path: collocation (Radau IIA, Gauss-Legendre) lives in ancf_sym.dynamics.collocation."""
from .dynamics.collocation import CollocationIntegrator, Tableau, stage_function, tableau

__all__ = ["Tableau", "tableau", "stage_function", "CollocationIntegrator"]
