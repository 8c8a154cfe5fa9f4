"""Linearisation and modal analysis about an equilibrium (docs/modal.md)."""
from ancf_sym.modal.analysis import modal_analysis
from ancf_sym.modal.linearize import Linearization, linearize
from ancf_sym.modal.result import ModalResult

__all__ = ["modal_analysis", "linearize", "Linearization", "ModalResult"]
