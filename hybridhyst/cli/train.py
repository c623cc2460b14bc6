"""``hybridhyst-train``: one Lightning training run of a physics, hybrid or baseline module.

Default (``conf/train.yaml``): the hybrid (Coulomb + viscous + Dahl nominal + 4×128 tanh MLP residual) on
the BRFD characterisation tests at 36 lb band tension, 1 in tests held out. Writes into the run directory
(``hydra.run.dir=...``): ``config.yaml`` (resolved), ``checkpoints/`` (best by validation RMSE and
``last.ckpt``; resume with ``ckpt_path=...``), ``tensorboard/`` (losses, metrics, ``phys/<parameter>
[unit]``, loop figures of the held-out conditions, hparams with the final metrics), ``metrics.json``,
``predictions.parquet``, ``parameters.csv`` (nominal parameters per epoch) and ``model.pt`` (the
nominal's state dict). The nominal (physics, hybrid and std_pinn modules) starts from a batched identification
on the training records (``nominal_init``) unless ``nominal_state`` is given; ``metrics.json`` reports the
starting nominal's own errors (``nominal``) beside the run's, and a run that ends worse on validation than the
model it started from keeps the starting weights (``start``); the terminal shows both. A failed run still
writes ``metrics.json`` with ``status: failed`` and the error, so a sweep's report lists it; the other jobs of
a multirun are unaffected.
"""

from __future__ import annotations

import copy
import json
import math
import time
import warnings
from pathlib import Path

import hydra
import lightning as L
import pandas as pd
import torch
from lightning.pytorch.callbacks import Callback
from omegaconf import DictConfig, OmegaConf

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

__all__ = ["StartModel", "build_datamodule", "build_module", "build_trainer", "identify_nominal", "main",
           "nominal_start", "run"]

DISPLAY = {"physics": "physics-only", "mlp": "mlp", "lstm": "lstm", "std_pinn": "std-pinn"}
NOMINAL_MODULES = ("physics", "hybrid", "std_pinn")


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
    """The LightningModule named by ``cfg.module`` with its network (``cfg.residual``) and loss settings. A
    nominal (physics, hybrid, std_pinn) is identified on the training records first (``identify_nominal``)
    when ``nominal_start`` says ``"identify"`` and the run does not resume from ``ckpt_path``."""
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
        identified, start = None, nominal_start(cfg)
        if start not in ("nominal_state", "init_noise", "identify", "model"):
            raise ValueError(f"unknown nominal_init.method {start!r}; choose 'identify' or 'none'")
        if start == "identify" and not cfg.get("ckpt_path"):  # resuming: the checkpoint has them
            identified = identify_nominal(cfg, dm, nominal)
    if kind == "physics":
        module = MODULES[kind](nominal, init_noise=loss.get("init_noise"), prior_weight=float(loss.prior_weight),
                               prior_kind=loss.prior_kind, features=list(cfg.features), **sim, **common)
    elif kind == "hybrid":
        module = MODULES[kind](nominal, residual=net.kind, hidden=net.hidden, activation=net.activation,
                               freeze_nominal=bool(cfg.freeze_nominal), features=list(cfg.features),
                               placement=str(cfg.get("placement", "output")),
                               latent_states=int(cfg.get("latent_states", 0)), **sim, **common)
    elif kind == "std_pinn":
        module = MODULES[kind](nominal, hidden=net.hidden, activation=net.activation,
                               freeze_nominal=bool(cfg.freeze_nominal), **sim, **common)
    else:
        return MODULES[kind](hidden=net.hidden, activation=net.activation, features=list(cfg.features), **common)
    module.nominal_identified = identified  # identification summary (None without one), for metrics.json
    return module


def nominal_start(cfg: DictConfig) -> str | None:
    """Where the nominal of ``cfg.module`` starts: ``"nominal_state"`` (a given state dict), ``"init_noise"``
    (the physics module's seed 000 re-initialisation near zero), ``"identify"`` (``nominal_init.method``:
    batched identification on the training records) or ``"model"`` (the model config's values); None for
    modules without a nominal."""
    if cfg.module not in NOMINAL_MODULES:
        return None
    if cfg.get("nominal_state"):
        return "nominal_state"
    if cfg.module == "physics" and cfg.loss.get("init_noise"):
        return "init_noise"
    method = str((cfg.get("nominal_init") or {}).get("method") or "none")
    return "model" if method == "none" else method  # build_module refuses an unknown method


def _identify_settings(cfg: DictConfig) -> dict:
    """identify() keyword arguments: conf/identify.yaml's ``identify:`` block (one source of the defaults),
    the training simulation settings, no Fisher analysis, then ``nominal_init.settings``."""
    from ..identify import identify

    opts = to_plain(OmegaConf.load(Path(CONF_DIR) / "identify.yaml")["identify"])
    opts.update(fisher=False, ode_method=cfg.simulation.method, substeps=int(cfg.simulation.substeps),
                backend=cfg.simulation.backend)
    opts.update(to_plain((cfg.get("nominal_init") or {}).get("settings")) or {})
    opts["bounds"] = {k: tuple(v) for k, v in (opts.get("bounds") or {}).items()}
    return check_kwargs(opts, identify, "nominal_init.settings", reserved=("model", "records", "seed", "progress"))


def identify_nominal(cfg: DictConfig, dm: RecordDataModule, nominal) -> dict:
    """Fit ``nominal`` in place to the training records (``RecordDataModule.training_records``) with
    ``hybridhyst.identify.identify`` (``_identify_settings``); returns a summary for metrics.json."""
    from ..identify import identify

    opts = _identify_settings(cfg)
    records = dm.training_records()
    progress = bool((cfg.get("nominal_init") or {}).get("progress", True))
    if progress:
        print(f"identifying the nominal on {len(records)} training records "
              f"({opts['method']} + {opts['refine']}) ...", flush=True)
    try:
        result = identify(nominal, records, seed=int(cfg.seed), progress=progress, **opts)
    except ValueError as e:
        raise ValueError(f"nominal_init: identifying the nominal on the training records failed: {e} "
                         "(nominal_init.settings={bounds: ...} sets the search box; nominal_init.method=none "
                         "starts from the model config's values)") from e
    return {"rmse": result.rmse, "wall_s": result.wall_s, "records": len(records), "search": result.search,
            "refine": str(opts["refine"]), "evaluations": result.evaluations, "x": result.x}


def build_trainer(cfg: DictConfig, run_dir: Path, callbacks: list | tuple = ()) -> L.Trainer:
    """Trainer with checkpoints (best validation RMSE + last), the logger of ``cfg.logger``, loop figures and
    ``callbacks``."""
    from lightning.pytorch.callbacks import ModelCheckpoint

    t = cfg.trainer
    # resuming keeps writing into the checkpoint's own folder, so the best score so far carries over
    ckpt_dir = Path(cfg.ckpt_path).resolve().parent if cfg.get("ckpt_path") else run_dir / "checkpoints"
    # best.ckpt: the best validation RMSE; last.ckpt: every epoch. Lightning >= 2.6 writes save_last's copy only
    # when a top-k checkpoint is saved at the same step (last.ckpt would be the best one, not the last), so
    # last.ckpt has a checkpoint callback of its own (listed second: it saves the best one's updated state)
    callbacks = [ModelCheckpoint(dirpath=ckpt_dir, monitor="val/rmse", mode="min", save_last=False,
                                 filename="best", save_top_k=1),
                 ModelCheckpoint(dirpath=ckpt_dir, monitor=None, save_top_k=1, filename="last",
                                 enable_version_counter=False), *callbacks]
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
    name = DISPLAY.get(kind, kind)
    if kind == "hybrid":  # hybrid-mlp, hybrid-lstm (the output branch) or hybrid-dynamics (inside the equations)
        name = "hybrid-dynamics" if cfg.get("placement") == "dynamics" else f"hybrid-{cfg.residual.kind}"
    model = (cfg.model.get("name") or cfg.model.get("_target_", "").rsplit(".", 1)[-1]) \
        if kind in ("physics", "hybrid", "std_pinn") else None
    return {"module": kind, "name": name, "residual": cfg.residual.kind if uses_net else None,
            "hidden": parse_hidden(cfg.residual.hidden) if uses_net else None,
            "lambda_phys": float(cfg.loss.lambda_phys) if kind in ("hybrid", "std_pinn") else 0.0,
            "seed": int(cfg.seed), "train_fraction": float(cfg.datamodule.train_fraction),
            "conditions": ",".join(cfg.datamodule.conditions),
            "data": cfg.data.get("name", cfg.data.get("_target_", "")), "model": model,
            "placement": str(cfg.get("placement", "output")) if kind == "hybrid" else None,
            "freeze_nominal": bool(cfg.freeze_nominal) if kind in ("hybrid", "std_pinn") else None,
            "nominal_init": nominal_start(cfg), "experiment": cfg.get("experiment_name")}


SPLITS = ("train", "val", "test")


def _monitor(dm: RecordDataModule) -> str:
    """The split that validation scores (and the checkpoint choice uses): val, or the training records."""
    return "val" if len(dm.records("val")) else "train"


def _plain_json(value):
    return json.loads(json.dumps(value))


class StartModel(Callback):
    """The weights a run starts from, their validation RMSE and the starting nominal's errors, saved in every
    checkpoint (Lightning's callback state), so that a run resumed with ``ckpt_path`` keeps its original start:
    the floor of ``evaluate_best`` and metrics.json's ``nominal`` block. Nothing is saved before ``capture``
    (a run resumed from a checkpoint without this state has neither)."""

    def __init__(self):
        self.weights: dict | None = None  # the module's state dict before the first epoch (a deep copy)
        self.start: dict | None = None    # {"split": the validation split, "rmse": the starting model's RMSE}
        self.nominal: dict | None = None  # {"source", "identify", "train", "val", "test"}; None without a nominal

    def capture(self, module, dm: RecordDataModule, source: str | None) -> None:
        """Record ``module``'s weights and errors now (before ``trainer.fit``), on whole records."""
        monitor = _monitor(dm)
        self.weights = copy.deepcopy(module.state_dict())
        nominal = None
        if hasattr(module, "simulate_nominal"):
            preds = {s: predict_split(module, dm, s, nominal=True) for s in SPLITS}
            nominal = {"source": source, "identify": getattr(module, "nominal_identified", None),
                       **{s: split_metrics(p) for s, p in preds.items()}}
        if nominal is not None and module.kind == "physics":  # the module is its nominal
            rmse = nominal[monitor]["rmse"]
        else:
            rmse = split_metrics(predict_split(module, dm, monitor))["rmse"]
        self.start = {"split": monitor, "rmse": float(rmse)}
        self.nominal = _plain_json(nominal)

    def state_dict(self) -> dict:
        if self.weights is None:
            return {}
        return {"weights": self.weights, "start": self.start, "nominal": self.nominal}

    def load_state_dict(self, state: dict) -> None:
        self.weights, self.start, self.nominal = state["weights"], state["start"], state.get("nominal")


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
        module = build_module(cfg, dm)  # identifies the nominal (nominal_init) unless resuming
        starting = StartModel()
        trainer = build_trainer(cfg, run_dir, callbacks=[starting])
        if not cfg.get("ckpt_path"):  # resuming: trainer.fit restores the original start from the checkpoint
            starting.capture(module, dm, nominal_start(cfg))
        t0 = time.perf_counter()
        trainer.fit(module, dm, ckpt_path=cfg.get("ckpt_path"))
        train_time = time.perf_counter() - t0
        best = trainer.checkpoint_callback.best_model_path if trainer.checkpoint_callback else ""
        if best and cfg.evaluate_best:
            module.load_state_dict(torch.load(best, map_location="cpu", weights_only=False)["state_dict"])
        preds = {s: predict_split(module, dm, s) for s in SPLITS}
        floor = None
        if cfg.evaluate_best and starting.weights is not None:  # never worse on validation than the start
            split, start_rmse = starting.start["split"], starting.start["rmse"]
            trained = split_metrics(preds[split])["rmse"]
            restored = math.isfinite(start_rmse) and not trained <= start_rmse
            floor = {"split": split, "rmse": start_rmse, "trained_rmse": trained, "restored": restored}
            if restored:
                module.load_state_dict(starting.weights)
                preds = {s: predict_split(module, dm, s) for s in SPLITS}
    if not trainer.is_global_zero:  # DDP: one process writes the run directory
        return {}
    metrics = {s: split_metrics(p) for s, p in preds.items()}
    meta.update(n_parameters=module.n_parameters(), train_time_s=train_time, epochs=int(trainer.current_epoch),
                units={"x": dm.units.get("x", ""), "F": dm.units.get("y", ""), "t": dm.units.get("t", "s")},
                evaluated="best" if best and cfg.evaluate_best else "last")
    result = {"status": "ok", **metrics, "info": meta, "physics": _physics(module), "nominal": starting.nominal,
              "start": floor, "wall_s": time.perf_counter() - start}
    if cfg.predictions:
        frame = predictions_frame([p for s in ("train", "val", "test") for p in preds[s]])
        atomic_write(run_dir / "predictions.parquet", lambda p: frame.to_parquet(p, index=False))
    if getattr(module, "history", None):
        atomic_write(run_dir / "parameters.csv", pd.DataFrame(module.history).to_csv(index=False))
    if hasattr(module, "nominal"):
        atomic_write(run_dir / "model.pt", lambda p: torch.save(module.nominal.state_dict(), p))
    _log_hparams(trainer, cfg, result)
    write_json(run_dir / "metrics.json", result)
    print(summary(result, run_dir, cfg.get("ckpt_path")), flush=True)
    return result


def summary(result: dict, run_dir: Path, resumed: str | None = None) -> str:
    """The terminal summary of a finished run: the starting nominal's RMSE and the trained model's per split
    (``resumed``: the checkpoint the run was resumed from)."""
    info, unit = result["info"], result["info"]["units"]["F"]

    def row(label, m):
        return f"  {label:<24}" + "".join(f"{_rmse(m.get(s)):>10}" for s in SPLITS)

    nominal = result.get("nominal")
    how = {"identify": "identified", "model": "model config", "nominal_state": "nominal_state",
           "init_noise": "init_noise"}.get((nominal or {}).get("source"), "start")
    ident = (nominal or {}).get("identify")
    head = f"{info['name']}: {info['epochs']} epochs, {info['train_time_s']:.3g} s training"
    if resumed:
        head += f", resumed from {resumed}"
    elif ident:
        head += f" + {ident['wall_s']:.3g} s identifying the nominal"
    lines = [head, f"  {'RMSE [' + unit + ']':<24}" + "".join(f"{s:>10}" for s in SPLITS)]
    if nominal:
        lines.append(row(f"nominal ({how})", nominal))
    floor = result.get("start")
    kept = bool(floor and floor["restored"])
    lines.append(row(f"{info['name']} ({'start' if kept else info['evaluated']})", result))
    if kept:
        lines.append(f"  the trained model's {floor['split']} RMSE {floor['trained_rmse']:.4g} {unit} is above the "
                     f"starting model's {floor['rmse']:.4g} {unit}: the starting weights are kept")
    lines.append(f"  run dir: {run_dir}")
    return "\n".join(lines)


def _rmse(m) -> str:
    return f"{m['rmse']:.4g}" if m else "-"


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
    logger.finalize("success")  # after fit, this reopened the writer: close it (flushes the file now)


@hydra.main(config_path=CONF_DIR, config_name="train", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> float:
    """One run; returns the objective a search sweeper minimises (``sweep=optuna``): the validation RMSE, the
    training RMSE without a validation split, +inf for a diverged run. Under the Optuna sweeper a failed run
    (its ``metrics.json`` says ``status: failed``) scores +inf instead of ending the study; elsewhere it fails
    its job as before (a grid multirun runs the others and fails at the end)."""
    import logging

    from hydra.core.hydra_config import HydraConfig

    searching = HydraConfig.initialized() and "optuna" in str(HydraConfig.get().sweeper.get("_target_", ""))
    try:
        result = guarded(run, cfg)
    except Exception as exc:
        if not searching:
            raise
        logging.getLogger(__name__).error("run failed, scored +inf: %s: %s", type(exc).__name__, exc)
        return math.inf
    scores = result.get("val") or result.get("train") or {}
    rmse = float(scores.get("rmse", math.nan))
    return rmse if math.isfinite(rmse) else math.inf


def main() -> None:
    """Console entry point ``hybridhyst-train`` (Hydra overrides on the command line; ``-m`` sweeps)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
