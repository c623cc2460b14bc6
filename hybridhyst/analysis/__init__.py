"""Metrics, loop metrics and free-vibration analysis."""

from .loops import LoopMetrics as LoopMetrics
from .loops import TrendFit as TrendFit
from .loops import dissipated_energy as dissipated_energy
from .loops import equivalent_stiffness as equivalent_stiffness
from .loops import fit_trend as fit_trend
from .loops import loop_metrics as loop_metrics
from .loops import peak_response as peak_response
from .metrics import mae as mae
from .metrics import nrmse as nrmse
from .metrics import r2 as r2
from .metrics import relative_error as relative_error
from .metrics import rmse as rmse
from .metrics import split_metrics as split_metrics
from .vibration import free_vibration_frequency as free_vibration_frequency
from .vibration import turning_points as turning_points

__all__ = ["LoopMetrics", "TrendFit", "dissipated_energy", "equivalent_stiffness", "fit_trend",
           "free_vibration_frequency", "loop_metrics", "mae", "nrmse", "peak_response", "r2",
           "relative_error", "rmse", "split_metrics", "turning_points"]
