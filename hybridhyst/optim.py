"""Rules the optimisers of several packages share, written once below them: what a closure of
``torch.optim.LBFGS`` returns when a trial step's simulation diverges (``identify.fit_gradient``, the training
stage after Adam, the discovery loop's leftover network through ``fit_gradient``), and Marquardt's damped normal
equations (identification's Levenberg–Marquardt, ``identify.refine``, and training's, ``training.marquardt``).
"""

from __future__ import annotations

import math

import torch

__all__ = ["line_search_loss", "marquardt_step", "marquardt_system"]

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


def marquardt_system(JtJ: torch.Tensor, damping) -> torch.Tensor:
    """``JᵀJ + λ (diag(JᵀJ) + 1e-12 I)``: Gauss–Newton damped along each coordinate's own curvature (Marquardt's
    scaling, so coordinates of any unit move alike); batched over leading axes with one λ per system."""
    D = JtJ.shape[-1]
    lam = torch.as_tensor(damping, dtype=JtJ.dtype)[..., None, None]
    eye = torch.eye(D, dtype=JtJ.dtype, device=JtJ.device)
    return JtJ + lam * (torch.diag_embed(JtJ.diagonal(dim1=-2, dim2=-1)) + 1e-12 * eye)


def marquardt_step(JtJ: torch.Tensor, Jtr: torch.Tensor, damping: float) -> torch.Tensor:
    """The Levenberg–Marquardt step ``-(marquardt_system)⁻¹ Jᵀr`` of one system; nan where it is singular (the
    caller refuses a step that is not finite)."""
    step, info = torch.linalg.solve_ex(marquardt_system(JtJ, damping), -Jtr[:, None])
    return step[:, 0] if int(info) == 0 else torch.full_like(Jtr, math.nan)
