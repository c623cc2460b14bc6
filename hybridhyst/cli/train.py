"""``hybridhyst-train``: one Lightning training run of a physics, hybrid or baseline module.

Default (``conf/train.yaml``): the hybrid (Coulomb + viscous + Dahl nominal + 4×128 tanh MLP residual) on
the BRFD characterisation tests at 36 lb band tension, 1 in tests held out. Writes into the run directory
(``hydra.run.dir=...``): ``config.yaml`` (resolved), ``checkpoints/`` (best by validation RMSE and
``last.ckpt``; resume with ``ckpt_path=...``), ``tensorboard/`` (losses, metrics, ``phys/<parameter>
[unit]``, loop figures of the held-out conditions, hparams with the final metrics), ``metrics.json``,
``predictions.parquet``, ``parameters.csv`` (nominal parameters per epoch) and ``model.pt`` (the
nominal's state dict). A failed run still writes ``metrics.json`` with ``status: failed`` and the error,
so a sweep's report lists it; the other jobs of a multirun are unaffected.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import hydra
import lightning as L
import pandas as pd
import torch
from omegaconf import DictConfig

from ..data.datamodule import RecordDataModule
from ..nets import parse_hidden
from ..training import MODULES, LoopFigures, predict_split, predictions_frame, split_metrics
from ..training.modules import load_nominal_state
from .common import (
    CONF_DIR,
    atomic_write,
    check_app,
    check_kwargs,
    check_model_conditions,
    guarded,
    hydra_entry,
    instantiate,
    load_records,
    prepare_run_dir,
    split_options,
    to_plain,
    torch_settings,
    write_json,
)

__all__ = ["build_datamodule", "build_module", "build_trainer", "main", "run"]

DISPLAY = {"physics": "physics-only", "mlp": "mlp", "lstm": "lstm", "std_pinn": "std-pinn"}


def build_datamodule(cfg: DictConfig) -> RecordDataModule:
    """Records from ``cfg.data`` (``split.select``) in a ``RecordDataModule`` (``split.held_out`` -> test,
    ``split.val`` -> validation); the conditions fed to the networks must be numbers in every record."""
    from ..data.splits import check_conditions

    split = split_options(cfg)
    d = check_kwargs(to_plain(cfg.datamodule), RecordDataModule.__init__, "datamodule",
                     reserved=("records", "held_out", "val", "seed"))
    records = load_records(cfg, split["select"])
    check_conditions(records.split(held_out=split["held_out"], val=split["val"]), d.get("conditions") or [],
                     "datamodule.conditions")
    return RecordDataModule(records, held_out=split["held_out"], val=split["val"], seed=int(cfg.seed), **d)


def build_module(cfg: DictConfig, dm: RecordDataModule):
    """The LightningModule named by ``cfg.module`` with its network (``cfg.residual``) and loss settings."""
    kind = cfg.module
    if kind not in MODULES:
        raise ValueError(f"unknown module {kind!r}; choose from {sorted(MODULES)}")
    loss, net = cfg.loss, cfg.residual
    common = {"normaliser": dm.normaliser.to_dict(), "condition_names": dm.condition_names, "units": dm.units,
              "lr": float(cfg.trainer.lr), "weight_decay": float(cfg.trainer.weight_decay), "loss": loss.kind,
              "nominal_lr": cfg.trainer.get("nominal_lr"), "normalise_loss": bool(loss.get("normalise", True)),
              "lambda_phys": float(loss.lambda_phys)}
    sim = {"backend": cfg.simulation.backend, "method": cfg.simulation.method, "substeps": int(cfg.simulation.substeps)}
    if kind in ("physics", "hybrid", "std_pinn"):
        nominal = instantiate(cfg.model, _convert_="all").double()
        check_model_conditions(nominal, dm.split, "model")
        if cfg.get("nominal_state"):
            nominal.load_state_dict(load_nominal_state(cfg.nominal_state))
    if kind == "physics":
        return MODULES[kind](nominal, init_noise=loss.get("init_noise"), prior_weight=float(loss.prior_weight),
                             prior_kind=loss.prior_kind, features=list(cfg.features), **sim, **common)
    if kind == "hybrid":
        return MODULES[kind](nominal, residual=net.kind, hidden=net.hidden, activation=net.activation,
                             freeze_nominal=bool(cfg.freeze_nominal), features=list(cfg.features), **sim, **common)
    if kind == "std_pinn":
        return MODULES[kind](nominal, hidden=net.hidden, activation=net.activation,
                             freeze_nominal=bool(cfg.freeze_nominal), **sim, **common)
    return MODULES[kind](hidden=net.hidden, activation=net.activation, features=list(cfg.features), **common)


def build_trainer(cfg: DictConfig, run_dir: Path) -> L.Trainer:
    """Trainer with checkpoints (best validation RMSE + last), the logger of ``cfg.logger`` and loop figures."""
    from lightning.pytorch.callbacks import ModelCheckpoint

    t = cfg.trainer
    # resuming keeps writing into the checkpoint's own folder, so the best score so far carries over
    ckpt_dir = Path(cfg.ckpt_path).resolve().parent if cfg.get("ckpt_path") else run_dir / "checkpoints"
    callbacks = [ModelCheckpoint(dirpath=ckpt_dir, monitor="val/rmse", mode="min", save_last=True,
                                 filename="best", save_top_k=1)]
    logger = False
    if cfg.logger.kind == "tensorboard":
        from lightning.pytorch.loggers import TensorBoardLogger

        logger = TensorBoardLogger(save_dir=str(run_dir), name="tensorboard", version="", default_hp_metric=False)
        callbacks.append(LoopFigures(int(cfg.logger.loop_every_n_epochs), int(cfg.logger.max_loop_figures)))
    elif cfg.logger.kind == "csv":
        from lightning.pytorch.loggers import CSVLogger

        logger = CSVLogger(save_dir=str(run_dir), name="csv", version="")
    elif cfg.logger.kind != "none":
        raise ValueError(f"unknown logger {cfg.logger.kind!r}; choose tensorboard, csv or none")
    extra = to_plain(t.get("extra")) or {}
    return L.Trainer(max_epochs=int(t.max_epochs), accelerator=t.accelerator, devices=t.devices,
                     strategy=t.strategy, num_nodes=int(t.num_nodes), precision=t.precision,
                     gradient_clip_val=t.gradient_clip_val, log_every_n_steps=int(t.log_every_n_steps),
                     check_val_every_n_epoch=int(t.check_val_every_n_epoch), deterministic=bool(t.deterministic),
                     limit_train_batches=t.limit_train_batches, limit_val_batches=t.limit_val_batches,
                     enable_progress_bar=bool(t.enable_progress_bar), enable_model_summary=False,
                     default_root_dir=str(run_dir), logger=logger, callbacks=callbacks, **extra)


def info(cfg: DictConfig) -> dict:
    """What identifies this run in a report (everything but the seed makes a configuration)."""
    kind = cfg.module
    uses_net = kind != "physics"
    name = f"hybrid-{cfg.residual.kind}" if kind == "hybrid" else DISPLAY.get(kind, kind)
    model = (cfg.model.get("name") or cfg.model.get("_target_", "").rsplit(".", 1)[-1]) \
        if kind in ("physics", "hybrid", "std_pinn") else None
    return {"module": kind, "name": name, "residual": cfg.residual.kind if uses_net else None,
            "hidden": parse_hidden(cfg.residual.hidden) if uses_net else None,
            "lambda_phys": float(cfg.loss.lambda_phys) if kind in ("hybrid", "std_pinn") else 0.0,
            "seed": int(cfg.seed), "train_fraction": float(cfg.datamodule.train_fraction),
            "conditions": ",".join(cfg.datamodule.conditions),
            "data": cfg.data.get("name", cfg.data.get("_target_", "")), "model": model,
            "experiment": cfg.get("experiment_name")}


def run(cfg: DictConfig) -> dict:
    """Train, evaluate every split on whole records, write the run directory; returns ``metrics.json``."""
    check_app(cfg, "train")
    start = time.perf_counter()
    run_dir = prepare_run_dir(cfg)
    meta = info(cfg)
    try:
        return _run(cfg, run_dir, meta, start)
    except Exception as e:
        write_json(run_dir / "metrics.json", {"status": "failed", "error": f"{type(e).__name__}: {e}", "info": meta})
        raise


def _run(cfg, run_dir: Path, meta: dict, start: float) -> dict:
    with torch_settings("float64", cfg.get("threads"), int(cfg.seed)), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*does not have many workers.*")
        warnings.filterwarnings("ignore", message=".*litlogger.*")
        L.seed_everything(int(cfg.seed), workers=True, verbose=False)
        dm = build_datamodule(cfg)
        module = build_module(cfg, dm)
        trainer = build_trainer(cfg, run_dir)
        t0 = time.perf_counter()
        trainer.fit(module, dm, ckpt_path=cfg.get("ckpt_path"))
        train_time = time.perf_counter() - t0
        best = trainer.checkpoint_callback.best_model_path if trainer.checkpoint_callback else ""
        if best and cfg.evaluate_best:
            module.load_state_dict(torch.load(best, map_location="cpu", weights_only=False)["state_dict"])
        preds = {s: predict_split(module, dm, s) for s in ("train", "val", "test")}
    if not trainer.is_global_zero:  # DDP: one process writes the run directory
        return {}
    metrics = {s: split_metrics(p) for s, p in preds.items()}
    meta.update(n_parameters=module.n_parameters(), train_time_s=train_time, epochs=int(trainer.current_epoch),
                units={"x": dm.units.get("x", ""), "F": dm.units.get("y", ""), "t": dm.units.get("t", "s")},
                evaluated="best" if best and cfg.evaluate_best else "last")
    result = {"status": "ok", **metrics, "info": meta, "physics": _physics(module),
              "wall_s": time.perf_counter() - start}
    if cfg.predictions:
        frame = predictions_frame([p for s in ("train", "val", "test") for p in preds[s]])
        atomic_write(run_dir / "predictions.parquet", lambda p: frame.to_parquet(p, index=False))
    if getattr(module, "history", None):
        atomic_write(run_dir / "parameters.csv", pd.DataFrame(module.history).to_csv(index=False))
    if hasattr(module, "nominal"):
        atomic_write(run_dir / "model.pt", lambda p: torch.save(module.nominal.state_dict(), p))
    _log_hparams(trainer, cfg, result)
    write_json(run_dir / "metrics.json", result)
    return result


def _physics(module) -> dict:
    if not hasattr(module, "nominal"):
        return {}
    return {k: {"value": v, "unit": module.nominal_unit(k)} for k, v in module.nominal_values().items()}


def _log_hparams(trainer, cfg, result):
    logger = trainer.logger
    if not logger or not hasattr(logger, "log_hyperparams"):
        return
    i = result["info"]
    params = {"module": i["module"], "name": i["name"], "hidden": "x".join(map(str, i["hidden"] or [])) or "none",
              "lambda_phys": i["lambda_phys"], "seed": i["seed"], "train_fraction": i["train_fraction"],
              "lr": float(cfg.trainer.lr), "max_epochs": int(cfg.trainer.max_epochs), "n_parameters": i["n_parameters"]}
    final = {f"hp/{s}_{m}": result[s][m] for s in ("train", "val", "test") for m in ("rmse", "mae")
             if result.get(s) and math.isfinite(result[s][m])}
    logger.log_hyperparams(params, final)


@hydra.main(config_path=CONF_DIR, config_name="train", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    guarded(run, cfg)


def main() -> None:
    """Console entry point ``hybridhyst-train`` (Hydra overrides on the command line; ``-m`` sweeps)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
