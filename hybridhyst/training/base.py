"""Shared machinery of the Lightning modules: features, losses, metrics, optimiser, the nominal simulator."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from functools import partial

import lightning as L
import torch
from torch import nn

from ..data.datamodule import Normaliser
from ..nets import build_net, count_parameters
from ..optim import line_search_loss
from ..physics.models import DrivenOscillator
from ..simulate import SimulationSettings, simulate
from .losses import data_loss

__all__ = ["LR_SCHEDULES", "SequenceModule", "NominalMixin", "InputSampleOf", "cosine_factor", "load_nominal_state",
           "neural_scales"]

_FEATURES = ("t", "u", "du", "ddu")
LR_SCHEDULES = ("constant", "cosine")


def cosine_factor(epoch: int, epochs: int, final: float) -> float:
    """The cosine schedule's multiplier of the starting step after ``epoch`` epochs: 1 at 0, ``final`` from
    ``epochs`` on."""
    e = min(max(int(epoch), 0), int(epochs))
    return float(final) + (1.0 - float(final)) * 0.5 * (1.0 + math.cos(math.pi * e / int(epochs)))


class SequenceModule(L.LightningModule):
    """Shared machinery: features, losses, validation metrics in physical units, optimiser.

    Parameters
    ----------
    normaliser : ``Normaliser.to_dict()`` of the training data (fitted on training records only).
    condition_names : numeric conditions in ``batch["cond"]`` (network inputs, parameter functions).
    network_conditions : those of them the networks read (default: all); the nominal's parameter functions
        read any of them.
    features : input channels of networks among "t", "u", "du", "ddu" (conditions are appended).
    lr, weight_decay : Adam settings of the networks; nominal_lr : relative Adam step of each nominal
        parameter (times max(|raw value|, 1); default ``lr``).
    lr_schedule : "constant", or "cosine": every group's step decays by a half cosine over the trainer's
        ``max_epochs`` to ``lr_final_ratio`` × its start (stepped once per epoch; resumed runs continue it).
    loss : "mse" or "mae" data misfit; lambda_phys : physics weight.
    normalise_loss : divide the data misfit by the training response sd (default); False keeps it in the
        response's units (seed 000's MAE in Nm).
    units : the data's units (``{"y": "kip", ...}``), for logs and reports.
    """

    kind = "base"

    def __init__(self, normaliser: dict, condition_names: Sequence[str] = (), control_names: Sequence[str] = (),
                 network_conditions: Sequence[str] | None = None, features: Sequence[str] = ("t", "u", "du"),
                 lr: float = 1e-3, weight_decay: float = 0.0,
                 loss: str = "mse", lambda_phys: float = 0.0, units: dict | None = None,
                 nominal_lr: float | None = None, normalise_loss: bool = True, lr_schedule: str = "constant",
                 lr_final_ratio: float = 0.01):
        super().__init__()
        bad = [f for f in features if f not in _FEATURES]
        if bad:
            raise ValueError(f"unknown network feature(s) {bad}; choose from {_FEATURES}")
        if loss not in ("mse", "mae"):
            raise ValueError(f"unknown data loss {loss!r}; choose 'mse' or 'mae'")
        if lr_schedule not in LR_SCHEDULES:
            raise ValueError(f"unknown lr_schedule {lr_schedule!r}; choose from {LR_SCHEDULES}")
        if not 0.0 < float(lr_final_ratio) <= 1.0:
            raise ValueError(f"lr_final_ratio must be in (0, 1], got {lr_final_ratio}")
        if float(lambda_phys) < 0:
            raise ValueError(f"lambda_phys must be >= 0, got {lambda_phys}")
        self.norm = Normaliser.from_dict(normaliser)
        self.condition_names = list(condition_names)
        self.control_names = list(control_names)
        self.network_conditions = list(self.condition_names if network_conditions is None else network_conditions)
        unknown = [c for c in self.network_conditions if c not in [*self.condition_names, *self.control_names]]
        if unknown:
            raise ValueError(f"network condition(s) {unknown} are not among the batch's conditions "
                             f"{self.condition_names} or controls {self.control_names}")
        self.feature_names = list(features)
        self.lr, self.weight_decay, self.loss_kind = float(lr), float(weight_decay), loss
        self.nominal_lr = float(lr if nominal_lr is None else nominal_lr)
        self.lr_schedule, self.lr_final_ratio = lr_schedule, float(lr_final_ratio)
        self.normalise_loss = bool(normalise_loss)
        self.lambda_phys = float(lambda_phys)
        self.units = dict(units or {})
        self.history: list[dict] = []  # per-epoch parameter values (modules with a nominal)
        self._val = {"sse": 0.0, "sae": 0.0, "n": 0}
        self._epoch_start = time.perf_counter()
        self.lbfgs: dict | None = None  # set by use_lbfgs: the stage after Adam
        self.epoch_offset = 0  # epochs before this stage (the history counts on from the Adam epochs)

    # -- features ----------------------------------------------------------------------------------
    @property
    def n_features(self) -> int:
        return len(self.feature_names) + len(self.network_conditions)

    def features(self, batch, inputs=None, t=None) -> torch.Tensor:
        """Normalised network inputs ``(batch, time, n_features)``; ``inputs``/``t`` override the batch's."""
        ch = {"t": batch["t"] if t is None else t, "u": batch["u"], "du": batch["du"], "ddu": batch["ddu"]}
        if inputs is not None:
            ch.update(u=inputs.u, du=inputs.du, ddu=inputs.ddu)
        cols = [self.norm.scale(name, ch[name]) for name in self.feature_names]
        T = cols[0].shape[1] if cols else batch["t"].shape[1]
        cols += [c[:, None].expand(-1, T) if c.ndim == 1 else c for c in self.condition_features(batch)]
        return torch.stack(cols, dim=-1).to(self.dtype)

    def condition_features(self, batch) -> list[torch.Tensor]:
        """Each condition the networks read, normalised: one ``(batch,)`` tensor per condition, ``(batch, time)``
        per control channel."""
        out = []
        for name in self.network_conditions:
            if name in self.control_names:
                out.append(self.norm.scale(name, batch["controls"][..., self.control_names.index(name)].to(self.dtype)))
            else:
                out.append(self.norm.scale(name, batch["cond"][:, self.condition_names.index(name)].to(self.dtype)))
        return out

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
        if self.lbfgs is not None:
            return self._lbfgs_step(batch)
        loss = self._objective(batch, log=True)
        if loss is None:  # a diverged simulation or residual: skip this step, count it
            self.log("train/skipped_steps", 1.0, batch_size=batch["y"].shape[0], on_step=False, on_epoch=True,
                     reduce_fx="sum")
            return None
        self.log("train/loss", loss, batch_size=batch["y"].shape[0], on_step=False, on_epoch=True, prog_bar=True)
        return loss

    def _objective(self, batch, log: bool = False, share: tuple[float, float, bool] = (1.0, 1.0, True)
                   ) -> torch.Tensor | None:
        """The training loss of ``batch``: data loss (+ λ_phys · physics loss) (+ prior); None if not finite.
        ``share``: for a chunk of a larger batch, its share of the scored samples (the data loss is their mean),
        its share of the windows (the physics loss is a mean over windows) and whether it carries the prior,
        so that the chunks' losses add up to the whole batch's."""
        out = self(batch)
        scale = self.y_scale if self.normalise_loss else 1.0
        loss = data_loss(out["y"], batch["y"].to(out["y"]), batch["mask"].to(out["y"]), scale, self.loss_kind)
        loss = loss * share[0]
        B = batch["y"].shape[0]
        if log:
            self.log("train/data_loss", loss, batch_size=B, on_step=False, on_epoch=True)
        if self.lambda_phys > 0:
            phys = self.physics_loss(batch, out)
            if phys is not None:
                if log:
                    self.log("train/phys_loss", phys, batch_size=B, on_step=False, on_epoch=True)
                loss = loss + self.lambda_phys * phys * share[1]
        prior = self.prior_loss() if share[2] else None
        if prior is not None:
            if log:
                self.log("train/prior_loss", prior, batch_size=B, on_step=False, on_epoch=True)
            loss = loss + prior
        return loss if torch.isfinite(loss) else None

    # -- L-BFGS stage ------------------------------------------------------------------------------
    def use_lbfgs(self, max_iter: int = 20, history_size: int = 50, chunk: int = 64, epoch_offset: int = 0) -> None:
        """Switch to full-batch L-BFGS (``torch.optim.LBFGS``, strong-Wolfe line search): each training step
        is one L-BFGS step over the whole batch, its loss and gradient accumulated over chunks of ``chunk``
        windows (the same mean as one pass over the batch, in bounded memory). For the stage after Adam
        (``trainer.lbfgs``), as universal differential equations are trained: Adam, then a quasi-Newton
        method to converge. ``epoch_offset``: the epochs before, for the parameter history."""
        if int(max_iter) < 1 or int(history_size) < 1 or int(chunk) < 1:
            raise ValueError(f"L-BFGS needs max_iter, history_size and chunk >= 1, got {max_iter}, {history_size}, "
                             f"{chunk}")
        self.lbfgs = {"max_iter": int(max_iter), "history_size": int(history_size), "chunk": int(chunk)}
        self.automatic_optimization = False
        self.epoch_offset = int(epoch_offset)

    def _lbfgs_step(self, batch):
        opt = self.optimizers()
        B, scored = batch["y"].shape[0], float(batch["mask"].sum().clamp_min(1.0))
        parts = [slice(i, i + self.lbfgs["chunk"]) for i in range(0, B, self.lbfgs["chunk"])]
        evaluations, start = 0, math.inf  # start: the loss where the step began (the line search's reference)

        def closure():
            nonlocal evaluations, start
            evaluations += 1
            opt.zero_grad()
            total = torch.zeros((), dtype=self.dtype)
            for sl in parts:
                part = {k: v[sl] for k, v in batch.items()}
                share = (float(part["mask"].sum()) / scored, part["y"].shape[0] / B, sl.start == 0)
                loss = self._objective(part, share=share)
                if loss is None:  # a diverged simulation: a large finite loss, so the line search backs off
                    opt.zero_grad()
                    return line_search_loss(torch.tensor(math.inf, dtype=self.dtype), start)
                self.manual_backward(loss)
                total = total + loss.detach()
            if evaluations == 1:
                start = float(total)
            return total

        loss = opt.step(closure)
        self.log("train/loss", loss, batch_size=B, on_step=False, on_epoch=True, prog_bar=True)
        self.log("train/lbfgs_evaluations", float(evaluations), batch_size=B, on_step=False, on_epoch=True,
                 reduce_fx="sum")
        return loss

    def on_validation_epoch_start(self):
        self._val = {"sse": 0.0, "sae": 0.0, "n": 0}

    def validation_step(self, batch, batch_idx):
        with torch.no_grad():
            err = (self(batch)["y"] - batch["y"].to(self.dtype)).detach()
        self._val["sse"] += float(err.square().sum())
        self._val["sae"] += float(err.abs().sum())
        self._val["n"] += err.numel()

    def validated_split(self) -> str:
        """The split the validation loop scores, which names its metrics: "val" where the data module holds
        validation records, "train" where it has none and scores the training records (whole records, as
        ``RecordDataModule.val_dataloader`` gives them) -- logged as ``train/rmse``, never under a validation
        name. Without a data module (a plain dataloader) "val"."""
        dm = getattr(getattr(self, "_trainer", None), "datamodule", None)
        split = getattr(dm, "split", None)
        if split is None:
            return "val"
        return "val" if len(split.val) else "train"

    def on_validation_epoch_end(self):
        n = max(self._val["n"], 1)
        rmse = math.sqrt(self._val["sse"] / n)
        part = self.validated_split()
        self.log(f"{part}/rmse", rmse if math.isfinite(rmse) else float("inf"), prog_bar=True, sync_dist=True)
        self.log(f"{part}/mae", self._val["sae"] / n, sync_dist=True)

    def on_save_checkpoint(self, checkpoint):
        checkpoint["hybridhyst_history"] = list(self.history)

    def on_load_checkpoint(self, checkpoint):
        self.history = list(checkpoint.get("hybridhyst_history", []))

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
        if self.lbfgs is not None:  # one group: L-BFGS scales its steps itself
            return torch.optim.LBFGS([p for g in groups for p in g["params"]], lr=1.0, max_iter=self.lbfgs["max_iter"],
                                     history_size=self.lbfgs["history_size"], line_search_fn="strong_wolfe")
        optimizer = torch.optim.Adam(groups, lr=self.lr)
        if self.lr_schedule == "constant":
            return optimizer
        epochs = self.trainer.max_epochs
        if epochs is None or epochs < 1:
            raise ValueError(f"lr_schedule=cosine decays over trainer.max_epochs; give max_epochs >= 1, got {epochs}")
        scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, partial(cosine_factor, epochs=epochs,
                                                                          final=self.lr_final_ratio))
        return {"optimizer": optimizer, "lr_scheduler": {"scheduler": scheduler, "interval": "epoch"}}

    def n_parameters(self) -> int:
        return count_parameters(self)


class NominalMixin:
    """A nominal model simulated along the batch (each row on its own time grid), on the compiled fast path.

    A training window that starts inside a record needs the state there. An oscillator whose output is the
    position starts at the measured (y, ẏ) and every other state at rest; the first ``warmup`` samples are not
    scored while the rest forgets. With an encoder (``_setup_encoder(past)``, ``encoder.past`` of
    ``hybridhyst-train``) an MLP reads the ``past`` samples of (u, y) before the window (and the conditions) and
    adds its estimate to that start, every state scaled by its spread in a simulation of the first training
    batch, as subspace-encoder methods do (Beintema, Tóth, Schoukens, "Deep subspace encoders for nonlinear
    system identification", Automatica 156, 2023). Its last layer starts at zero: training starts from the
    plain start. Whole records (validation, test) start at rest as before: the encoder only serves training.
    """

    nominal: nn.Module

    @property
    def model(self):
        """The model that is simulated (the nominal here; a hybrid's augmented model in ``HybridModule``)."""
        return self.nominal

    def _setup_encoder(self, past: int = 0, hidden="2x32"):
        """An MLP encoder of each window's start state from the ``past`` samples before it (0: none)."""
        self.past, self.encoder = int(past), None
        if self.past < 0:
            raise ValueError(f"encoder.past must be >= 0 samples, got {past}")
        if not self.past:
            return
        S = self.model.state_dim
        if not S:
            raise ValueError(f"encoder.past={past}: model {self.nominal.name!r} has no state to estimate at a window's "
                             "start (a memoryless model); use encoder.past=0")
        self.encoder = build_net("mlp", 2 * self.past + len(self.network_conditions), S, hidden, activation="tanh",
                                 zero_last=True).double()
        self.register_buffer("state_scale", torch.zeros(S, dtype=torch.float64))  # from the first training batch

    def _setup_nominal(self, nominal, backend: str, method: str, substeps: int, trainable: bool):
        self.nominal = nominal
        self.sim = SimulationSettings(method=method, substeps=int(substeps), backend=backend)
        for p in self.nominal.parameters():
            p.requires_grad_(bool(trainable))

    def conditions(self, batch, rows: int | None = None) -> dict[str, torch.Tensor]:
        """The conditions of a batch for the simulator: ``(batch,)`` per condition, ``(batch, time)`` per control
        channel; with ``rows``, each repeated to ``rows`` (the controls only where they are not signals)."""
        cond = {name: batch["cond"][:, j].to(self.dtype) for j, name in enumerate(self.condition_names)}
        if rows is not None:
            reps = rows // batch["cond"].shape[0]
            cond = {k: v.repeat_interleave(reps) for k, v in cond.items()}
        elif self.control_names:
            cond.update({c: batch["controls"][..., j].to(self.dtype) for j, c in enumerate(self.control_names)})
        return cond

    def _initial_state(self, batch, model=None):
        """The state each row starts from: oscillators whose output is the position start a mid-record window at
        the measured (y, ẏ); with an encoder, its estimate is added wherever a window starts inside a record."""
        measured = isinstance(self.nominal, DrivenOscillator) and self.nominal.outputs[0] == "x"
        inside = batch["start"] > 0
        base = None
        if measured:
            y0 = batch["y0"].to(self.dtype)
            base = torch.where(inside[:, None], y0, torch.zeros_like(y0))
        model = self.model if model is None else model
        if getattr(self, "encoder", None) is None or model is not self.model or not bool(inside.any()):
            return base  # the encoder estimates the simulated model's states (not the bare nominal's of a hybrid)
        B = batch["t"].shape[0]
        s0 = model.initial_state(model.evaluate(self.conditions(batch), B), B, base=base)
        if not bool((self.state_scale > 0).all()):
            self._fit_state_scale(batch, model, s0)
        past = batch["past"].to(self.dtype)
        feats = [self.norm.scale("u", past[..., 0]), self.norm.scale("y", past[..., 1])]
        feats += [(c if c.ndim == 1 else c[:, 0])[:, None] for c in self.condition_features(batch)]  # (controls: at
        # the window's start)
        offset = self.encoder(torch.cat(feats, dim=1)) * self.state_scale
        return s0 + torch.where(inside[:, None], offset, torch.zeros_like(offset))

    def _fit_state_scale(self, batch, model, s0):
        """Each state's spread along the batch, simulated from the plain start (1 where a state stays put: the
        network's latent states, dimensionless by design)."""
        t = (batch["t"] - batch["t"][:, :1]).to(self.dtype)
        U = torch.stack([batch["u"], batch["du"], batch["ddu"]], dim=-1).to(self.dtype)
        with torch.no_grad():
            _, states = simulate(model, U, t=t, conditions=self.conditions(batch), initial_state=s0,
                                 return_states=True, settings=self.sim)
        sd = states.reshape(-1, states.shape[-1]).std(0)
        self.state_scale.copy_(torch.where(torch.isfinite(sd) & (sd > 1e-12), sd, torch.ones_like(sd)))

    def simulate_nominal(self, batch, return_states: bool = False, model=None):
        """Nominal response ``(batch, time)`` (and states ``(batch, time, S)``) along each row's input; ``model``
        simulates another model with the nominal's structure instead (a hybrid's augmented model)."""
        t = (batch["t"] - batch["t"][:, :1]).to(self.dtype)
        U = torch.stack([batch["u"], batch["du"], batch["ddu"]], dim=-1).to(self.dtype)
        model = self.nominal if model is None else model
        res = simulate(model, U, t=t, conditions=self.conditions(batch),
                       initial_state=self._initial_state(batch, model), return_states=return_states, settings=self.sim)
        return (res[0][..., 0], res[1]) if return_states else res[..., 0]

    def nominal_values(self) -> dict[str, float]:
        """Nominal parameters in their units: ``{"effect.param": value}`` for constants, and for parameters
        that are functions of a condition their value at each training condition,
        ``{"effect.param@pressure_mpa=0.03": value}`` (trajectories, TensorBoard, metrics.json)."""
        out, varying = {}, []
        for e, params in self.nominal.parameter_table().items():
            fns = self.nominal.effects[e].params if e in self.nominal.effects else self.nominal.structure_params
            for p, info in params.items():
                fn = fns[p]
                if isinstance(info["value"], (int, float)):
                    out[f"{e}.{p}"] = float(info["value"])
                elif fn.condition in self.control_names:  # a function of a control: its coefficients
                    out.update({f"{e}.{p}{c.suffix}": c.value for c in fn.coordinates()})
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

    def nominal_unit(self, key: str) -> str:
        """The unit of a ``nominal_values`` key (``"dahl.Fc"`` or ``"dahl.Fc@amplitude_in=1"``)."""
        effect, param = key.split("@")[0].split(".", 1)
        return self.nominal.parameter_table().get(effect, {}).get(param, {}).get("unit", "")

    def on_train_batch_end(self, outputs, batch, batch_idx):
        from ..physics.parameters import project_to_bounds

        project_to_bounds(self.nominal)  # amplitudes stored unconstrained stay inside their bounds

    def on_train_epoch_end(self):
        values = self.nominal_values()
        self.history.append({"epoch": self.epoch_offset + int(self.current_epoch), **values})
        for key, v in values.items():
            self.log(f"phys/{key} [{self.nominal_unit(key)}]", v)

    def flat(self, batch, detach: bool = True, model=None):
        """Masked collocation rows: inputs, times and the nominal's parameter values ``(N,)``; ``detach``
        makes the parameters constants (the hybrid: λ_phys regularises the branch, the data loss trains the
        nominal) or keeps them trainable (the standard PINN identifies the nominal through the residual);
        ``model``: another model's values (a hybrid's augmented model) instead of the nominal's."""
        m = batch["mask"].reshape(-1) > 0
        B, T = batch["u"].shape
        rows = {k: batch[k].reshape(-1)[m].to(self.dtype) for k in ("t", "u", "du", "ddu", "dddu")}
        cond = {k: (v.reshape(-1) if v.ndim == 2 else v.repeat_interleave(T))[m]
                for k, v in self.conditions(batch).items()}
        P = (self.nominal if model is None else model).evaluate(cond, int(m.sum()))
        if detach:
            P = {e: {n: v.detach() for n, v in ps.items()} for e, ps in P.items()}
        return m, rows, P


def neural_scales(nominal, norm: Normaliser) -> dict[str, float]:
    """Scales of a network inside ``nominal``'s dynamics, from the training data's standard deviations: the
    displacement and velocity the effects see, and a force. A damper law: the excitation, its rate and the
    response. An oscillator: the response (or the input) as displacement, the input's characteristic angular
    frequency ω = sd(u̇)/sd(u) for the velocity, the drive |g|·sd(u) (force drive) or m·sd(ü) (base motion)
    for the force."""
    sd = norm.sd
    if not isinstance(nominal, DrivenOscillator):
        return {"x": sd["u"], "v": sd["du"], "u": sd["u"], "du": sd["du"], "F": sd["y"]}
    sx = sd["y"] if nominal.outputs[0] == "x" else sd["u"]
    omega = sd["du"] / sd["u"]
    try:
        with torch.no_grad():
            P = nominal.evaluate(None, 1)["structure"]
        gain, mass = abs(float(P["drive_gain"][0].detach())), float(P["mass"][0].detach())
    except (ValueError, KeyError, TypeError):  # structure parameters that are functions of a condition
        gain, mass = 1.0, 1.0
    force = gain * sd["u"] if nominal.excitation == "force" else mass * sd["ddu"]
    return {"x": sx, "v": sx * omega, "u": sd["u"], "du": sd["du"], "F": max(force, 1e-300)}


def InputSampleOf(rows):  # noqa: N802 - reads like the class it builds
    from ..physics.models import InputSample

    return InputSample(u=rows["u"], du=rows["du"], ddu=rows["ddu"])


def _col(inp):
    from ..physics.models import InputSample

    return InputSample(u=inp.u[:, None], du=inp.du[:, None], ddu=inp.ddu[:, None])


def _flat_cond(batch, m):
    T = batch["u"].shape[1]
    return batch["cond"].repeat_interleave(T, dim=0)[m]


def _flat_controls(batch, m):
    """The control channels at the masked collocation rows, ``(rows, 1, C)`` (each row a one-sample window)."""
    c = batch["controls"]
    return c.reshape(c.shape[0] * c.shape[1], c.shape[-1])[m][:, None, :]


def load_nominal_state(path) -> dict:
    """A nominal's state dict from a ``model.pt`` or a run directory holding one (``hybridhyst-identify``,
    ``hybridhyst-train``): tensors only (``files.load_weights``), and from a run directory only when its run
    finished (``runs.require_complete``)."""
    from pathlib import Path

    from ..files import load_weights
    from ..runs import is_run_dir, require_complete

    p = Path(path)
    if p.is_dir():
        p = p / "model.pt"
    if not p.exists():
        raise FileNotFoundError(f"nominal state {p} not found; give a model.pt or a run directory holding one")
    if is_run_dir(p.parent):  # a run killed while writing leaves a model.pt that belongs to no finished result
        require_complete(p.parent, f"the nominal state {p.name}", p.name)
    return load_weights(p)


