"""Baselines: data-only MLP and LSTM, and the standard PINN (seed 003's comparison models)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from ..nets import build_net
from .base import SequenceModule
from .losses import pinn_physics_residual, taylor_inputs
from .nominal import InputSampleOf, NominalMixin, _col, _flat_cond, _flat_controls

__all__ = ["LSTMModule", "MLPModule", "StdPINNModule"]


class _NetModule(SequenceModule):
    """Data-only network baseline: ``ŷ = mean_y + sd_y · N(features)``."""

    net_kind = "mlp"

    def __init__(self, normaliser: dict, hidden="4x128", activation: str = "tanh", **kw):
        super().__init__(normaliser, **kw)
        self.net = build_net(self.net_kind, self.n_features, 1, hidden, activation=activation, zero_last=False)

    def forward(self, batch):
        y = self.norm.unscale("y", self.net(self.features(batch))[..., 0])
        return {"y": y, "nominal": None}


class MLPModule(_NetModule):
    """Pointwise MLP on the normalised features (no memory: the data-only baseline of seed 003)."""

    kind = "mlp"
    net_kind = "mlp"


class LSTMModule(_NetModule):
    """LSTM over the feature sequence (the recurrent data-only baseline of seed 003)."""

    kind = "lstm"
    net_kind = "lstm"

    def __init__(self, normaliser: dict, hidden="2x64", **kw):
        super().__init__(normaliser, hidden=hidden, **kw)


class StdPINNModule(NominalMixin, SequenceModule):
    """Standard PINN: a network of time and conditions predicting the response and the nominal's states.

    The data loss fits the response; the physics loss (weight ``lambda_phys``) makes the predicted
    states obey the nominal's rate equations and the response its output law at every training sample.
    The nominal's parameters are trained too unless ``freeze_nominal`` (an inverse PINN). The simulator
    settings (backend, method, substeps) are used once, to scale the states from a nominal simulation.
    """

    kind = "std_pinn"

    def __init__(self, nominal, normaliser: dict, hidden="4x64", activation: str = "tanh",
                 freeze_nominal: bool = False, features: Sequence[str] = ("t",), backend: str = "fast",
                 method: str = "rk4", substeps: int = 1, **kw):
        super().__init__(normaliser, features=features, **kw)
        self._setup_nominal(nominal, backend, method, substeps, trainable=not freeze_nominal)
        S = nominal.state_dim
        self.net = build_net("mlp", self.n_features, 1 + S, hidden, activation=activation, zero_last=False)
        self.register_buffer("state_scale", torch.ones(S))
        self.register_buffer("rate_scale", torch.ones(S))
        self.register_buffer("scaled", torch.zeros(()))

    def _fit_scales(self, batch):
        """State and state-rate scales from the nominal's simulation of the first training batch."""
        with torch.no_grad():
            _, S = self.simulate_nominal(batch, return_states=True)
            S = S.reshape(-1, S.shape[-1]).to(self.dtype)
            if S.shape[1]:
                m, rows, P = self.flat(batch)
                rate = self.nominal.derivative(S[m], InputSampleOf(rows), P)
                self.state_scale.copy_(S.std(0).clamp_min(1e-9))
                self.rate_scale.copy_(rate.std(0).clamp_min(1e-9))
        self.scaled.fill_(1.0)

    def _outputs(self, feats):
        raw = self.net(feats)
        return self.norm.unscale("y", raw[..., 0]), raw[..., 1:] * self.state_scale

    def forward(self, batch):
        y, _ = self._outputs(self.features(batch))
        return {"y": y, "nominal": None}

    def training_step(self, batch, batch_idx):
        if not bool(self.scaled):
            self._fit_scales(batch)
        return super().training_step(batch, batch_idx)

    def physics_loss(self, batch, out):
        m, rows, P = self.flat(batch, detach=False)  # the inverse PINN: the residual trains the nominal too
        tau = torch.zeros_like(rows["t"], requires_grad=True)
        inp = taylor_inputs(rows["u"], rows["du"], rows["ddu"], tau, rows["dddu"])
        one = {k: v[:, None] for k, v in rows.items()}
        feats = self.features({**one, "cond": _flat_cond(batch, m), "controls": _flat_controls(batch, m)},
                              inputs=_col(inp), t=(rows["t"] + tau)[:, None])
        y, S = self._outputs(feats)
        return pinn_physics_residual(self.nominal, P, S[:, 0], y[:, 0], inp, tau, self.rate_scale, self.y_scale)
