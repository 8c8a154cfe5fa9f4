"""Linearisation and modal analysis about an equilibrium (docs/modal.md)."""
from .analysis import modal_analysis
from .linearize import Linearization, linearize
from .result import ModalResult

__all__ = ["modal_analysis", "linearize", "Linearization", "ModalResult"]
