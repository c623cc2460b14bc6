"""What a closure of ``torch.optim.LBFGS`` returns when a trial step's simulation diverges.

Below every package that fits by L-BFGS (``identify.fit_gradient``, the training stage after Adam, the
discovery loop's leftover network through ``fit_gradient``), so the rule is written once.
"""

from __future__ import annotations

import math

import torch

__all__ = ["line_search_loss"]

PENALTY = 1e3  # a diverged trial step scores this many times the lowest finite loss seen


def line_search_loss(value: torch.Tensor, reference: float) -> torch.Tensor:
    """``value`` where finite; for a trial step whose loss is not (a diverged explicit simulation), a large finite
    loss, ``PENALTY`` × ``reference`` (the lowest finite loss seen), with no gradient: the strong-Wolfe line
    search then backs off towards its start. Returning inf instead turns its cubic interpolation into nan, and
    every later trial of the step with it, so the step ends where it began after spending its evaluations.
    With no finite ``reference`` yet, ``value`` itself (the optimiser's start is not finite: the fit stops)."""
    if torch.isfinite(value) or not math.isfinite(reference):
        return value
    return torch.full_like(value.detach(), PENALTY * max(abs(reference), 1e-300))
