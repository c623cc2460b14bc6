"""Shared machinery of the Lightning modules: features, losses, metrics, optimiser and schedule (the nominal
simulator of the modules that have one: ``training.nominal``)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from functools import partial

import lightning as L
import torch

from ..data.datamodule import Normaliser
from ..nets import count_parameters
from ..optim import line_search_loss
from .losses import data_loss

__all__ = ["LR_SCHEDULES", "SequenceModule", "cosine_factor"]

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
        self.lm = None  # set by use_lm: the Levenberg-Marquardt stage after Adam (training.marquardt)
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
        if self.lm is not None:
            return self._lm_step()
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

    # -- Levenberg-Marquardt stage -----------------------------------------------------------------
    def use_lm(self, damping: float = 1e-3, epoch_offset: int = 0) -> None:
        """Switch to Levenberg–Marquardt (``trainer.lm``, ``training.marquardt``): each training step is one
        damped Gauss–Newton iteration on the simulation error of every whole training record, over the nominal's
        trainable parameters and the weights of a network inside the dynamics (the training batch itself is not
        read). For the stage after Adam. ``epoch_offset``: the epochs before, for the parameter history."""
        from .marquardt import MarquardtStage

        self.lm = MarquardtStage(self, damping)
        self._lm_records = None  # the whole training records, batched one by one (on the first step)
        self.automatic_optimization = False
        self.epoch_offset = int(epoch_offset)

    def _lm_step(self):
        if self._lm_records is None:
            whole = self.trainer.datamodule.whole("train")
            self._lm_records = [{k: v[None] for k, v in whole[i].items()} for i in range(len(whole))]
        out = self.optimizers().step(closure=lambda: self.lm.step(self, self._lm_records))
        B = len(self._lm_records)
        self.log("train/loss", out["cost"], batch_size=B, on_step=False, on_epoch=True, prog_bar=True)
        self.log("train/lm_damping", out["damping"], batch_size=B, on_step=False, on_epoch=True)
        self.log("train/lm_tries", float(out["tries"]), batch_size=B, on_step=False, on_epoch=True)
        return None

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
        if self.lm is not None:  # the stage steps the parameters itself, through an optimiser Lightning counts
            from .marquardt import StageStep

            return StageStep([*self.lm.raw, *self.lm.weights])
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
