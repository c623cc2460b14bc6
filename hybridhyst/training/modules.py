"""Lightning modules sharing one data and metric interface.

Every module maps a batch of ``RecordDataModule`` (training windows or whole records) to a predicted
response ``(batch, time)`` in physical units; the base class owns the losses, logging and optimiser:

- ``PhysicsModule``  — the nominal model alone, identified by gradient (seed 000's recipe available:
  softplus parameters re-initialised near zero, MAE + λ·|p − p_init|).
- ``HybridModule``   — nominal + parallel residual branch (MLP on normalised t, x, ẋ, conditions with a
  zero-initialised last layer, or LSTM), optionally starting from an identified nominal (seed 003).
- ``MLPModule``, ``LSTMModule`` — data-only baselines on the same features.
- ``StdPINNModule``  — a network of time and conditions predicting the response and the nominal's
  states, trained on data plus the physics residual (the standard PINN baseline of seed 003).

``λ_phys`` (``lambda_phys``) weighs the physics residual (``training.losses``) against the data loss
(``w_data = 1``); data-only modules ignore it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import lightning as L
import numpy as np
import torch
from torch import nn

from ..data.datamodule import Normaliser
from ..nets import build_net, count_parameters
from ..physics.models import DrivenOscillator
from ..simulate import simulate
from .losses import data_loss, hybrid_physics_residual, parameter_prior, pinn_physics_residual, taylor_inputs

__all__ = ["HybridModule", "LSTMModule", "MLPModule", "MODULES", "PhysicsModule", "SequenceModule", "StdPINNModule",
           "load_nominal_state"]

_FEATURES = ("t", "u", "du", "ddu")


class SequenceModule(L.LightningModule):
    """Shared machinery: features, losses, validation metrics in physical units, optimiser.

    Parameters
    ----------
    normaliser : ``Normaliser.to_dict()`` of the training data (fitted on training records only).
    condition_names : numeric conditions in ``batch["cond"]`` (network inputs, parameter functions).
    features : input channels of networks among "t", "u", "du", "ddu" (conditions are appended).
    lr, weight_decay : Adam settings of the networks; nominal_lr : relative Adam step of each nominal
        parameter (times max(|raw value|, 1); default ``lr``).
    loss : "mse" or "mae" data misfit; lambda_phys : physics weight.
    units : the data's units (``{"y": "kip", ...}``), for logs and reports.
    """

    kind = "base"

    def __init__(self, normaliser: dict, condition_names: Sequence[str] = (),
                 features: Sequence[str] = ("t", "u", "du"), lr: float = 1e-3, weight_decay: float = 0.0,
                 loss: str = "mse", lambda_phys: float = 0.0, units: dict | None = None,
                 nominal_lr: float | None = None):
        super().__init__()
        bad = [f for f in features if f not in _FEATURES]
        if bad:
            raise ValueError(f"unknown network feature(s) {bad}; choose from {_FEATURES}")
        if loss not in ("mse", "mae"):
            raise ValueError(f"unknown data loss {loss!r}; choose 'mse' or 'mae'")
        if float(lambda_phys) < 0:
            raise ValueError(f"lambda_phys must be >= 0, got {lambda_phys}")
        self.norm = Normaliser.from_dict(normaliser)
        self.condition_names = list(condition_names)
        self.feature_names = list(features)
        self.lr, self.weight_decay, self.loss_kind = float(lr), float(weight_decay), loss
        self.nominal_lr = float(lr if nominal_lr is None else nominal_lr)
        self.lambda_phys = float(lambda_phys)
        self.units = dict(units or {})
        self.history: list[dict] = []  # per-epoch parameter values (modules with a nominal)
        self._val = {"sse": 0.0, "sae": 0.0, "n": 0}
        self._epoch_start = time.perf_counter()

    # -- features ----------------------------------------------------------------------------------
    @property
    def n_features(self) -> int:
        return len(self.feature_names) + len(self.condition_names)

    def features(self, batch, inputs=None, t=None) -> torch.Tensor:
        """Normalised network inputs ``(batch, time, n_features)``; ``inputs``/``t`` override the batch's."""
        ch = {"t": batch["t"] if t is None else t, "u": batch["u"], "du": batch["du"], "ddu": batch["ddu"]}
        if inputs is not None:
            ch.update(u=inputs.u, du=inputs.du, ddu=inputs.ddu)
        cols = [self.norm.scale(name, ch[name]) for name in self.feature_names]
        T = cols[0].shape[1] if cols else batch["t"].shape[1]
        for j, name in enumerate(self.condition_names):
            cols.append(self.norm.scale(name, batch["cond"][:, j])[:, None].expand(-1, T))
        return torch.stack(cols, dim=-1).to(self.dtype)

    @property
    def y_scale(self) -> float:
        return self.norm.sd["y"]

    # -- to be provided ----------------------------------------------------------------------------
    def forward(self, batch) -> dict:
        """``{"y": (batch, time) prediction, "nominal": (batch, time) or None}`` in physical units."""
        raise NotImplementedError

    def physics_loss(self, batch, out) -> torch.Tensor | None:
        return None

    def prior_loss(self) -> torch.Tensor | None:
        return None

    # -- Lightning ---------------------------------------------------------------------------------
    def training_step(self, batch, batch_idx):
        out = self(batch)
        loss = data_loss(out["y"], batch["y"].to(out["y"]), batch["mask"].to(out["y"]), self.y_scale, self.loss_kind)
        B = batch["y"].shape[0]
        self.log("train/data_loss", loss, batch_size=B, on_step=False, on_epoch=True)
        if self.lambda_phys > 0:
            phys = self.physics_loss(batch, out)
            if phys is not None:
                self.log("train/phys_loss", phys, batch_size=B, on_step=False, on_epoch=True)
                loss = loss + self.lambda_phys * phys
        prior = self.prior_loss()
        if prior is not None:
            self.log("train/prior_loss", prior, batch_size=B, on_step=False, on_epoch=True)
            loss = loss + prior
        if not torch.isfinite(loss):  # a diverged simulation or residual: skip this step, count it
            self.log("train/skipped_steps", 1.0, batch_size=B, on_step=False, on_epoch=True, reduce_fx="sum")
            return None
        self.log("train/loss", loss, batch_size=B, on_step=False, on_epoch=True, prog_bar=True)
        return loss

    def on_validation_epoch_start(self):
        self._val = {"sse": 0.0, "sae": 0.0, "n": 0}

    def validation_step(self, batch, batch_idx):
        with torch.no_grad():
            err = (self(batch)["y"] - batch["y"].to(self.dtype)).detach()
        self._val["sse"] += float(err.square().sum())
        self._val["sae"] += float(err.abs().sum())
        self._val["n"] += err.numel()

    def on_validation_epoch_end(self):
        n = max(self._val["n"], 1)
        rmse = math.sqrt(self._val["sse"] / n)
        self.log("val/rmse", rmse if math.isfinite(rmse) else float("inf"), prog_bar=True)
        self.log("val/mae", self._val["sae"] / n)

    def configure_optimizers(self):
        """Adam: networks at ``lr``; each nominal parameter in its own group at ``nominal_lr × max(|raw|, 1)``
        (a relative step, so a stiffness of 5e4 N/m and a friction force of 0.5 kip move alike)."""
        nominal = getattr(self, "nominal", None)
        own = {id(p) for p in nominal.parameters()} if nominal is not None else set()
        groups = [{"params": [p for p in self.parameters() if p.requires_grad and id(p) not in own], "lr": self.lr,
                   "weight_decay": self.weight_decay}]
        if nominal is not None:
            groups += [{"params": [p], "lr": self.nominal_lr * max(float(p.detach().abs().max()), 1.0),
                        "weight_decay": 0.0} for p in nominal.parameters() if p.requires_grad]
        groups = [g for g in groups if g["params"]]
        return torch.optim.Adam(groups, lr=self.lr)

    def n_parameters(self) -> int:
        return count_parameters(self)


class _NominalMixin:
    """A nominal model simulated along the batch (grouped by time grid), on the compiled fast path."""

    nominal: nn.Module

    def _setup_nominal(self, nominal, backend: str, method: str, substeps: int, trainable: bool):
        self.nominal = nominal
        self.sim = {"backend": backend, "method": method, "substeps": int(substeps)}
        for p in self.nominal.parameters():
            p.requires_grad_(bool(trainable))

    def conditions(self, batch, rows: int | None = None) -> dict[str, torch.Tensor]:
        cond = {name: batch["cond"][:, j].to(self.dtype) for j, name in enumerate(self.condition_names)}
        if rows is not None:
            reps = rows // batch["cond"].shape[0]
            cond = {k: v.repeat_interleave(reps) for k, v in cond.items()}
        return cond

    def _initial_state(self, batch):
        """Oscillators whose output is the position start a mid-record window at the measured (y, ẏ)."""
        if not (isinstance(self.nominal, DrivenOscillator) and self.nominal.outputs[0] == "x"):
            return None
        y0 = batch["y0"].to(self.dtype)
        return torch.where((batch["start"] > 0)[:, None], y0, torch.zeros_like(y0))

    def simulate_nominal(self, batch, return_states: bool = False):
        """Nominal response ``(batch, time)`` (and states ``(batch, time, S)``) along each row's input."""
        t = (batch["t"] - batch["t"][:, :1]).to(self.dtype)
        U = torch.stack([batch["u"], batch["du"], batch["ddu"]], dim=-1).to(self.dtype)
        cond, s0 = self.conditions(batch), self._initial_state(batch)
        grid = np.round(t.detach().cpu().numpy(), 12)
        groups: dict[bytes, list[int]] = {}
        for i, row in enumerate(grid):
            groups.setdefault(row.tobytes(), []).append(i)
        ys, ss = [None] * t.shape[0], [None] * t.shape[0]
        for idx in groups.values():
            sel = torch.tensor(idx)
            res = simulate(self.nominal, U[sel], t=t[idx[0]], conditions={k: v[sel] for k, v in cond.items()},
                           initial_state=None if s0 is None else s0[sel], return_states=return_states, **self.sim)
            y, s = res if return_states else (res, None)
            for j, i in enumerate(idx):
                ys[i] = y[j, :, 0]
                ss[i] = None if s is None else s[j]
        Y = torch.stack(ys)
        return (Y, torch.stack(ss)) if return_states else Y

    def nominal_values(self) -> dict[str, float]:
        """Nominal parameters in their units: ``{"effect.param": value}`` for constants, and for parameters
        that are functions of a condition their value at each training condition,
        ``{"effect.param@pressure_mpa=0.03": value}`` (trajectories, TensorBoard, metrics.json)."""
        from ..cli.common import parameter_table

        out, varying = {}, []
        for e, params in parameter_table(self.nominal).items():
            for p, info in params.items():
                if isinstance(info["value"], (int, float)):
                    out[f"{e}.{p}"] = float(info["value"])
                else:
                    varying.append((e, p))
        levels = self._training_conditions()
        if varying and levels:
            with torch.no_grad():
                P = self.nominal.evaluate({k: torch.tensor([lv[k] for lv in levels], dtype=self.dtype)
                                           for k in levels[0]}, len(levels))
            for e, p in varying:
                for i, lv in enumerate(levels):
                    at = ",".join(f"{k}={v:g}" for k, v in lv.items())
                    out[f"{e}.{p}@{at}"] = float(P[e][p][i])
        return out

    def _training_conditions(self) -> list[dict[str, float]]:
        dm = getattr(getattr(self, "_trainer", None), "datamodule", None)
        if dm is None or not self.condition_names:
            return []
        rows = sorted({tuple(c) for c in dm.cond["train"]})
        return [dict(zip(self.condition_names, r)) for r in rows]

    def nominal_units(self) -> dict[str, str]:
        from ..cli.common import parameter_table

        units = {f"{e}.{p}": info["unit"] for e, params in parameter_table(self.nominal).items()
                 for p, info in params.items()}
        return {k: units.get(k.split("@")[0], "") for k in self.nominal_values()} | units

    def on_train_batch_end(self, outputs, batch, batch_idx):
        from ..physics.parameters import project_to_bounds

        project_to_bounds(self.nominal)  # amplitudes stored unconstrained stay inside their bounds

    def on_train_epoch_end(self):
        values = self.nominal_values()
        self.history.append({"epoch": int(self.current_epoch), **values})
        units = self.nominal_units()
        for key, v in values.items():
            self.log(f"phys/{key} [{units.get(key, '')}]", v)

    def flat(self, batch, out=None):
        """Masked collocation rows: inputs, times, conditions and parameter values ``(N,)``."""
        m = batch["mask"].reshape(-1) > 0
        B, T = batch["u"].shape
        rows = {k: batch[k].reshape(-1)[m].to(self.dtype) for k in ("t", "u", "du", "ddu")}
        cond = {k: v.repeat_interleave(T)[m] for k, v in self.conditions(batch).items()}
        P = self.nominal.evaluate(cond, int(m.sum()))
        return m, rows, P


class PhysicsModule(_NominalMixin, SequenceModule):
    """The nominal model alone, trained by gradient through the simulator.

    Parameters
    ----------
    nominal : the nominal model (``NominalModel``); its parameters are the trainable ones.
    init_noise : seed 000's recipe: re-initialise every softplus-constrained constant's raw value from
        N(0, init_noise) (values near softplus(0) ≈ 0.69) before training; None keeps the given values.
    prior_weight, prior_kind : ``prior_weight · Σ|p − p_init|`` ("l1", seed 000) or squared ("l2").
    backend, method, substeps : simulator settings.
    """

    kind = "physics"

    def __init__(self, nominal, normaliser: dict, init_noise: float | None = None, prior_weight: float = 0.0,
                 prior_kind: str = "l1", backend: str = "fast", method: str = "rk4", substeps: int = 1, **kw):
        super().__init__(normaliser, **kw)
        self._setup_nominal(nominal, backend, method, substeps, trainable=True)
        if init_noise:
            self._reinitialise(float(init_noise))
        self.prior_weight, self.prior_kind = float(prior_weight), prior_kind
        self.initial = {k: v.detach().clone() for k, v in self.nominal.named_parameters()}

    def _reinitialise(self, sd: float):
        from ..physics.parameters import Constant, Positive

        with torch.no_grad():
            for module in self.nominal.modules():
                if isinstance(module, Constant) and hasattr(module, "parametrizations"):
                    plist = module.parametrizations["value"]
                    if any(isinstance(p, Positive) for p in plist):
                        plist.original.normal_(0.0, sd)

    def forward(self, batch):
        y = self.simulate_nominal(batch)
        return {"y": y, "nominal": y}

    def prior_loss(self):
        if not self.prior_weight:
            return None
        return parameter_prior(self.nominal, self.initial, self.prior_weight, self.prior_kind)


class HybridModule(_NominalMixin, SequenceModule):
    """Nominal physics plus a parallel residual branch: ``ŷ = y_nom + sd_y · N(features)``.

    Parameters
    ----------
    nominal : the nominal model; nominal_state : optional path to a ``model.pt`` state dict (e.g. written
        by ``hybridhyst-identify``) or a run directory holding one, loaded into ``nominal`` first.
    freeze_nominal : keep the nominal's parameters fixed (seed 003 trains the residual only).
    residual : "mlp" (pointwise, last layer zero-initialised) or "lstm"; hidden : "4x128" etc.
    activation : MLP activation (tanh as seed 003).
    """

    kind = "hybrid"

    def __init__(self, nominal, normaliser: dict, residual: str = "mlp", hidden="4x128", activation: str = "tanh",
                 freeze_nominal: bool = False, nominal_state: str | None = None, backend: str = "fast",
                 method: str = "rk4", substeps: int = 1, **kw):
        super().__init__(normaliser, **kw)
        if nominal_state:
            nominal.load_state_dict(load_nominal_state(nominal_state))
        self._setup_nominal(nominal, backend, method, substeps, trainable=not freeze_nominal)
        self.residual_kind = residual
        self.net = build_net(residual, self.n_features, 1, hidden, activation=activation, zero_last=True)
        if residual == "lstm" and self.lambda_phys > 0 and isinstance(nominal, DrivenOscillator):
            raise ValueError("the physics residual of an oscillator needs pointwise time derivatives of the "
                             "residual branch; use residual=mlp, or lambda_phys=0 with an LSTM branch")

    def forward(self, batch):
        need_states = self.lambda_phys > 0 and self.training
        res = self.simulate_nominal(batch, return_states=need_states)
        y_nom, states = res if need_states else (res, None)
        r = self.net(self.features(batch))[..., 0] * self.y_scale
        out = {"y": y_nom + r, "nominal": y_nom}
        if states is not None:
            out["states"] = states
        return out

    def physics_loss(self, batch, out):
        m, rows, P = self.flat(batch)
        S = out["states"].reshape(-1, out["states"].shape[-1])[m].to(self.dtype)
        if self.residual_kind == "lstm":  # constitutive: the residual is the branch's own correction
            r = (out["y"] - out["nominal"]).reshape(-1)[m]
            return (r / self.y_scale).square().mean()
        tau = torch.zeros_like(rows["t"], requires_grad=True)
        inp = taylor_inputs(rows["u"], rows["du"], rows["ddu"], tau)
        one = {k: v[:, None] for k, v in rows.items()}
        feats = self.features({**one, "cond": _flat_cond(batch, m)}, inputs=_col(inp), t=(rows["t"] + tau)[:, None])
        r = self.net(feats)[:, 0, 0] * self.y_scale
        y_nom = out["nominal"].reshape(-1)[m].detach()
        if isinstance(self.nominal, DrivenOscillator) and self.nominal.outputs[0] == "x":
            with torch.no_grad():  # the nominal trajectory around each point: x + ẋ τ + ẍ τ²/2
                acc = self.nominal.derivative(S, InputSampleOf(rows), P)[:, 1]
            y = y_nom + S[:, 1] * tau + 0.5 * acc * tau.square() + r
            accel_scale = float(acc.std().clamp_min(1e-12))
        else:
            y, accel_scale = y_nom + r, 1.0
        return hybrid_physics_residual(self.nominal, P, S, y, inp, tau, self.y_scale, accel_scale)


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


class StdPINNModule(_NominalMixin, SequenceModule):
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
        m, rows, P = self.flat(batch)
        tau = torch.zeros_like(rows["t"], requires_grad=True)
        inp = taylor_inputs(rows["u"], rows["du"], rows["ddu"], tau)
        one = {k: v[:, None] for k, v in rows.items()}
        feats = self.features({**one, "cond": _flat_cond(batch, m)}, inputs=_col(inp), t=(rows["t"] + tau)[:, None])
        y, S = self._outputs(feats)
        return pinn_physics_residual(self.nominal, P, S[:, 0], y[:, 0], inp, tau, self.rate_scale, self.y_scale)


# -- helpers ---------------------------------------------------------------------------------------
def InputSampleOf(rows):  # noqa: N802 - reads like the class it builds
    from ..physics.models import InputSample

    return InputSample(u=rows["u"], du=rows["du"], ddu=rows["ddu"])


def _col(inp):
    from ..physics.models import InputSample

    return InputSample(u=inp.u[:, None], du=inp.du[:, None], ddu=inp.ddu[:, None])


def _flat_cond(batch, m):
    T = batch["u"].shape[1]
    return batch["cond"].repeat_interleave(T, dim=0)[m]


def load_nominal_state(path) -> dict:
    """A nominal's state dict from a ``model.pt`` or a run directory holding one (``hybridhyst-identify``,
    ``hybridhyst-train``)."""
    from pathlib import Path

    p = Path(path)
    if p.is_dir():
        p = p / "model.pt"
    if not p.exists():
        raise FileNotFoundError(f"nominal state {p} not found; give a model.pt or a run directory holding one")
    return torch.load(p, map_location="cpu", weights_only=True)


MODULES = {"physics": PhysicsModule, "hybrid": HybridModule, "mlp": MLPModule, "lstm": LSTMModule,
           "std_pinn": StdPINNModule}
