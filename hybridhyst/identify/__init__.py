"""Identification of nominal-model parameters from records."""

from .gradient import FitResult as FitResult
from .gradient import fit_gradient as fit_gradient

__all__ = ["FitResult", "fit_gradient"]
