"""Adaptive and adjoint solves through torchdiffeq (an option; the fixed-step path is the default)."""

from __future__ import annotations

import torch
from torch import nn

from .inputs import input_sample, interpolate


class _Vectorfield(nn.Module):
    def __init__(self, model, U, t, conditions, batch, controls=()):
        super().__init__()
        self.model = model
        self.U, self.t, self.conditions, self.batch, self.controls = U, t, conditions, batch, controls

    def forward(self, tt, y):
        # parameters are evaluated inside the vector field so that the adjoint sees them
        P = self.model.evaluate(self.conditions, self.batch)
        tq = tt.reshape(1, 1).expand(self.batch, 1).to(self.t.dtype)
        v = interpolate(self.U, self.t, tq)[:, 0]
        return self.model.derivative(y, input_sample(v, self.controls), P)


def integrate_adaptive(model, U, t, conditions, state0, method="dopri5", rtol=1e-7, atol=1e-9,
                       adjoint=False, options=None, controls: tuple[str, ...] = ()) -> torch.Tensor:
    """States at every sample time, ``(batch, time, state_dim)``, from torchdiffeq's ``odeint``; ``U``'s columns
    after the third are the control channels named ``controls``."""
    import torchdiffeq

    if state0.shape[1] == 0:
        return state0[:, None, :].expand(-1, U.shape[1], -1)
    field = _Vectorfield(model, U, t, conditions, state0.shape[0], controls)
    kwargs = dict(method=method, rtol=rtol, atol=atol, options=options)
    if adjoint:
        params = tuple(p for p in model.parameters() if p.requires_grad)
        ys = torchdiffeq.odeint_adjoint(field, state0, t, adjoint_params=params, **kwargs)
    else:
        ys = torchdiffeq.odeint(field, state0, t, **kwargs)
    return ys.permute(1, 0, 2)
