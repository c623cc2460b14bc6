"""Metrics, loop metrics and free-vibration analysis."""

from .metrics import mae as mae
from .metrics import nrmse as nrmse
from .metrics import r2 as r2
from .metrics import relative_error as relative_error
from .metrics import rmse as rmse
from .vibration import free_vibration_frequency as free_vibration_frequency
from .vibration import turning_points as turning_points

__all__ = ["free_vibration_frequency", "mae", "nrmse", "r2", "relative_error", "rmse", "turning_points"]
