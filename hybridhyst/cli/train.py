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
a multirun are unaffected. ``metrics.json`` also keeps the last epoch's logged values (``logged``, e.g.
``train/phys_loss``) and the number of training windows (``info.train_windows``). ``skip_finished: true`` (an
experiment config's key, or ``+skip_finished=true``: a sweep re-launched after an interruption) keeps every run
directory that already holds a finished run of the same config and trains only the others.

The pieces of a run are built by ``hybridhyst.training.build`` (``build_datamodule``, ``build_module``,
``build_trainer``); this module wires them into a run directory.
"""

from __future__ import annotations

import copy
import json
import math
import pickle
import shutil
import time
import warnings
from pathlib import Path

import hydra
import lightning as L
import pandas as pd
import torch
import yaml
from lightning.pytorch.callbacks import Callback
from lightning.pytorch.utilities.exceptions import MisconfigurationException
from omegaconf import DictConfig, OmegaConf

from ..analysis.finite import check_finite
from ..data.datamodule import RecordDataModule
from ..files import load_weights, not_weights
from ..runs import RunInterrupted, claim, inside, is_complete, is_run_dir
from ..training import predict_split, predictions_frame, split_metrics
from ..training.build import build_datamodule, build_trainer, nominal_start, run_info, second_stage
from ..training.build import build_module as _build_module
from ..training.marquardt import check_module
from .common import (
    CONF_DIR,
    atomic_write,
    check_app,
    guarded,
    hydra_entry,
    jsonable,
    mark_complete,
    prepare_run_dir,
    run_dir_path,
    say,
    torch_settings,
    write_json,
)
from .settings import identify_start, simulation_settings, start_settings
from .train_summary import SPLITS, log_hparams, physics_values, summary

# build_datamodule, build_trainer, nominal_start and run_info come from hybridhyst.training.build,
# re-exported for the app's callers and tests; build_module here adds the nominal's identification
__all__ = ["StartModel", "build_datamodule", "build_module", "build_trainer", "finished_run", "identify_nominal",
           "main", "nominal_start", "run", "run_info", "summary"]



def build_module(cfg: DictConfig, dm: RecordDataModule):
    """``hybridhyst.training.build.build_module`` with the nominal identified first (``identify_nominal``) when
    ``nominal_init.start`` is ``identify``: the module a run trains."""
    return _build_module(cfg, dm, identify=identify_nominal)


def _identify_settings(cfg: DictConfig):
    """``IdentifySettings`` of the nominal's start: conf/identify.yaml's ``identify:`` block (one source of the
    defaults), the training simulation settings (its sub-steps, not ones step doubling would choose: the nominal
    is identified as training simulates it), no Fisher analysis, then ``nominal_init.settings``."""
    return start_settings(simulation_settings(cfg, "train"),
                          (cfg.get("nominal_init") or {}).get("settings"), "nominal_init.settings")


def identify_nominal(cfg: DictConfig, dm: RecordDataModule, nominal) -> dict:
    """Fit ``nominal`` in place to the training records (``RecordDataModule.training_records``) with
    ``hybridhyst.identify.identify`` (``_identify_settings``); returns a summary for metrics.json."""
    opts = _identify_settings(cfg)
    records = dm.training_records()
    progress = bool((cfg.get("nominal_init") or {}).get("progress", True))
    if progress:
        print(f"identifying the nominal on {len(records)} training records "
              f"({opts.search} + {opts.refine}) ...", flush=True)
    result = identify_start(nominal, records, opts, "nominal_init.settings",
                            "nominal_init.start=none starts from the model config's values", seed=int(cfg.seed),
                            progress=progress)
    return {"rmse": result.rmse, "wall_s": result.wall_s, "records": len(records), "search": result.search,
            "refine": str(opts.refine), "evaluations": result.evaluations, "x": result.x,
            "at_bounds": dict(result.at_bounds)}


def _monitor(dm: RecordDataModule) -> str:
    """The split that validation scores (and the checkpoint choice uses): val, or the training records."""
    return "val" if len(dm.records("val")) else "train"


class StartModel(Callback):
    """The weights a run starts from, their validation RMSE and the starting nominal's errors, saved in every
    checkpoint (Lightning's callback state), so that a run resumed with ``ckpt_path`` keeps its original start:
    the floor of ``evaluate_best`` and metrics.json's ``nominal`` block, and the seconds trained up to the
    checkpoint, so that a resumed run (an L-BFGS stage after Adam) reports its whole training time. Nothing is
    saved before ``capture`` (a run resumed from a checkpoint without this state has neither)."""

    def __init__(self):
        self.weights: dict | None = None  # the module's state dict before the first epoch (a deep copy)
        self.start: dict | None = None    # {"split": the validation split, "rmse": the starting model's RMSE}
        self.nominal: dict | None = None  # {"source", "identify", "train", "val", "test"}; None without a nominal
        self.trained_before = 0.0         # seconds trained by the runs this one continues (from the checkpoint)
        self._since: float | None = None  # when this process started training

    def on_train_start(self, trainer, pl_module) -> None:
        if self._since is None:  # the first stage: a later one (L-BFGS) is the same run's training
            self._since = time.perf_counter()

    def trained_s(self) -> float:
        """Seconds trained so far, the runs this one continues included."""
        return self.trained_before + (time.perf_counter() - self._since if self._since is not None else 0.0)

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
        self.nominal = jsonable(nominal)

    def state_dict(self) -> dict:
        if self.weights is None:
            return {}
        return {"weights": self.weights, "start": self.start, "nominal": self.nominal, "train_s": self.trained_s()}

    def load_state_dict(self, state: dict) -> None:
        self.weights, self.start, self.nominal = state["weights"], state["start"], state.get("nominal")
        self.trained_before = float(state.get("train_s", 0.0))


def run(cfg: DictConfig) -> dict:
    """Train, evaluate every split on whole records, write the run directory; returns ``metrics.json``.

    With ``skip_finished: true`` a run directory that already holds a finished run (``finished_run``) of this
    very config is kept and its ``metrics.json`` returned; otherwise an earlier run's ``metrics.json`` and
    ``checkpoints/`` there are removed first (unless resuming), so that neither is mistaken for this run's."""
    check_app(cfg, "train")
    start = time.perf_counter()
    if not cfg.get("ckpt_path"):
        done = finished_run(cfg) if cfg.get("skip_finished") else None
        if done is not None:
            say(f"{done['info']['name']}: finished earlier with this config, kept: {run_dir_path(cfg)}")
            return done
    run_dir = prepare_run_dir(cfg)  # claimed: a second run into this directory is refused while this one lives
    if cfg.get("ckpt_path"):  # a resumed run writes its checkpoints into the checkpoint's own run directory: hold it
        resumed = _checkpoint_dir(cfg, run_dir).parent
        if is_run_dir(resumed):
            claim(resumed)
    else:
        _clear(run_dir)
    meta = run_info(cfg)
    try:
        return _run(cfg, run_dir, meta, start)
    except BaseException as e:  # an error or an interruption (RunInterrupted): the run's results say so
        what = f"interrupted by {e.signame}" if isinstance(e, RunInterrupted) else f"{type(e).__name__}: {e}"
        write_json(run_dir / "metrics.json", {"status": "failed", "error": what, "info": meta})
        if isinstance(e, RunInterrupted):
            e.note = _interrupted_note(cfg, run_dir)
        raise


def _checkpoint_dir(cfg: DictConfig, run_dir: Path) -> Path:
    """Where the run's checkpoints go (``build_trainer``'s rule): a resumed run keeps writing into the
    checkpoint's own folder, a new one into ``<run dir>/checkpoints``."""
    return Path(cfg.ckpt_path).resolve().parent if cfg.get("ckpt_path") else run_dir / "checkpoints"


def _interrupted_note(cfg: DictConfig, run_dir: Path) -> str:
    """The line an interrupted run ends with: where its state is and the command option that resumes it."""
    state = _checkpoint_dir(cfg, run_dir) / INTERRUPTED
    if state.is_file():
        return (f"metrics.json says status failed (interrupted); the state at the interruption is in {state}: "
                f"resume with ckpt_path={state}")
    return "metrics.json says status failed (interrupted); nothing to resume from (it stopped before training)"


INTERRUPTED = "interrupted.ckpt"


class InterruptCheckpoint(Callback):
    """Saves the trainer's whole state as ``<checkpoint dir>/interrupted.ckpt`` when SIGTERM or SIGINT stop
    the run (``RunInterrupted``), mid-epoch included, so that ``ckpt_path=`` resumes it (Lightning's
    ``OnExceptionCheckpoint`` deletes its file again at teardown, and fires on every error)."""

    def __init__(self, dirpath: Path):
        self.path = Path(dirpath) / INTERRUPTED

    def on_exception(self, trainer, pl_module, exception) -> None:
        if isinstance(exception, RunInterrupted):
            self.path.parent.mkdir(parents=True, exist_ok=True)
            trainer.save_checkpoint(self.path)  # the whole state, optimizer included (loaded with weights_only)


def finished_run(cfg: DictConfig) -> dict | None:
    """The ``metrics.json`` of a finished run (``status: ok``) in ``cfg``'s run directory whose ``config.yaml``
    equals ``cfg`` (resolved, as plain containers: key order does not matter); None otherwise."""
    run_dir = run_dir_path(cfg)
    try:
        metrics = json.loads((run_dir / "metrics.json").read_text(encoding="utf-8"))
        earlier = OmegaConf.to_container(OmegaConf.load(run_dir / "config.yaml"), resolve=True)
    except (OSError, ValueError, yaml.YAMLError):
        return None
    if not isinstance(metrics, dict) or metrics.get("status") != "ok" or not is_complete(run_dir):
        return None
    now = OmegaConf.to_container(cfg, resolve=True)
    # the flag itself is no part of the run: a sweep launched without it is re-launched with it
    return metrics if _without(earlier, "skip_finished") == _without(now, "skip_finished") else None


def _without(config: dict, key: str) -> dict:
    return {k: v for k, v in config.items() if k != key} if isinstance(config, dict) else config


def _clear(run_dir: Path) -> None:
    """Remove an earlier run's results from ``run_dir`` (a new run starts there): ``metrics.json``, the
    checkpoints and the TensorBoard events, so that neither is mistaken for this run's (a run directory
    holds one run)."""
    (run_dir / "metrics.json").unlink(missing_ok=True)
    shutil.rmtree(run_dir / "checkpoints", ignore_errors=True)
    shutil.rmtree(run_dir / "tensorboard", ignore_errors=True)


def _run(cfg, run_dir: Path, meta: dict, start: float) -> dict:
    with torch_settings("float64", cfg.get("threads"), int(cfg.seed)), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*does not have many workers.*")
        warnings.filterwarnings("ignore", message=".*LeafSpec.*")  # Lightning's own use of a deprecated torch API
        warnings.filterwarnings("ignore", message=".*smaller than the logging interval.*")  # short runs log per epoch
        # a new run clears its checkpoints (_clear): the folder holds some only when resuming or in the L-BFGS
        # stage, which continues the Adam stage's best.ckpt on purpose
        warnings.filterwarnings("ignore", message="Checkpoint directory .* exists and is not empty")
        L.seed_everything(int(cfg.seed), workers=True, verbose=False)
        dm = build_datamodule(cfg)
        module = build_module(cfg, dm)  # identifies the nominal (nominal_init) unless resuming
        if (second_stage(cfg) or ("",))[0] == "lm":  # settings the stage cannot honour stop the run before Adam
            check_module(module)
        starting = StartModel()
        trainer = build_trainer(cfg, run_dir, callbacks=[starting, InterruptCheckpoint(_checkpoint_dir(cfg, run_dir))],
                                monitor=f"{_monitor(dm)}/rmse")  # the split the module's validation loop scores
        if not cfg.get("ckpt_path"):  # resuming: trainer.fit restores the original start from the checkpoint
            starting.capture(module, dm, nominal_start(cfg))
        t0 = time.perf_counter()
        try:
            trainer.fit(module, dm, ckpt_path=cfg.get("ckpt_path"), weights_only=True)  # a checkpoint is data, not code
        except pickle.UnpicklingError as e:
            raise not_weights(cfg.ckpt_path, e) from None
        except MisconfigurationException as e:  # e.g. a checkpoint past trainer.max_epochs: one line, not a traceback
            raise ValueError(f"trainer: {' '.join(str(e).split())} (ckpt_path={cfg.get('ckpt_path')}, "
                             f"trainer.max_epochs={cfg.trainer.max_epochs})") from None
        epochs = int(trainer.current_epoch)
        after = second_stage(cfg)
        if after is not None:  # L-BFGS or Levenberg-Marquardt from where Adam ended, in a trainer of its own
            kind, settings = after
            if kind == "lbfgs":  # full batch
                module.use_lbfgs(settings["max_iter"], settings["history_size"], chunk=dm.batch_size,
                                 epoch_offset=epochs)
                dm.batch_size = len(dm.train_dataloader().dataset)
            else:  # whole training records, one step per epoch
                module.use_lm(settings["damping"], epoch_offset=epochs)
            trainer = build_trainer(cfg, run_dir, after=trainer)
            trainer.fit(module, dm)
        train_time = time.perf_counter() - t0
        best = _best_checkpoint(trainer, _checkpoint_dir(cfg, run_dir))
        if best and cfg.evaluate_best:
            module.load_state_dict(load_weights(best)["state_dict"])
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
    rows = [p for s in SPLITS for p in preds[s]]
    diverged = check_finite([p["y_pred"] for p in rows], [p["record"] for p in rows], [p["t"] for p in rows],
                            splits=[p["split"] for p in rows], keep_going=bool(cfg.get("keep_going", False)),
                            hint="raise simulation.substeps or check the nominal's parameters (nominal_init, "
                                 "nominal_state)",
                            what="the trained model's simulation", time_unit=dm.units.get("t", "s"),
                            warn=lambda text: say(text, error=True))
    metrics = {s: split_metrics(p) for s, p in preds.items()}
    if starting.trained_before:  # a resumed run: the whole training, and this run's part of it
        meta["train_time_this_run_s"] = train_time
    meta.update(n_parameters=module.n_parameters(), train_time_s=starting.trained_before + train_time, epochs=epochs,
                lbfgs_steps_done=int(trainer.current_epoch) if after and after[0] == "lbfgs" else 0,
                lm_steps_done=int(trainer.current_epoch) if after and after[0] == "lm" else 0,
                train_windows=len(dm.train_dataloader().dataset),
                units={"x": dm.units.get("x", ""), "F": dm.units.get("y", ""), "t": dm.units.get("t", "s")},
                evaluated="best" if best and cfg.evaluate_best else "last")
    logged = {k: float(v) for k, v in trainer.callback_metrics.items()}  # the last epoch's logged values
    result = {"status": "ok", **metrics, "info": meta, "physics": physics_values(module), "nominal": starting.nominal,
              "start": floor, "logged": logged, "diverged": [d.to_dict() for d in diverged],
              "wall_s": time.perf_counter() - start}
    if cfg.predictions:
        frame = predictions_frame([p for s in ("train", "val", "test") for p in preds[s]])
        atomic_write(run_dir / "predictions.parquet", lambda p: frame.to_parquet(p, index=False))
    if getattr(module, "history", None):
        atomic_write(run_dir / "parameters.csv", pd.DataFrame(module.history).to_csv(index=False))
    if hasattr(module, "nominal"):
        atomic_write(run_dir / "model.pt", lambda p: torch.save(module.nominal.state_dict(), p))
    log_hparams(trainer, cfg, result)
    write_json(run_dir / "metrics.json", result)
    mark_complete(run_dir, "train", ["config.yaml", "metrics.json", "predictions.parquet", "parameters.csv",
                                     "model.pt", "checkpoints", "tensorboard"])
    say(summary(result, run_dir, cfg.get("ckpt_path")))
    return result


def _best_checkpoint(trainer, checkpoints: Path) -> str:
    """The best checkpoint's path, used only where it lies in this run's checkpoint folder: a checkpoint
    names the best one by a path of its own (``best_model_path`` in ``last.ckpt``), which in a copied or
    shared run directory points elsewhere; there the file of that name in ``checkpoints`` is used, if any."""
    best = trainer.checkpoint_callback.best_model_path if trainer.checkpoint_callback else ""
    if not best or inside(best, checkpoints):
        return best
    here = checkpoints / Path(best).name
    if here.is_file():
        return str(here)
    say(f"note: the checkpoint names its best weights at {best}, outside this run's {checkpoints}: not read; "
        "the last weights are evaluated")
    return ""


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
    rmse = scores.get("rmse")  # None: not finite (a run kept by skip_finished is read back from metrics.json)
    return float(rmse) if rmse is not None and math.isfinite(rmse) else math.inf


def main() -> None:
    """Console entry point ``hybridhyst-train`` (Hydra overrides on the command line; ``-m`` sweeps)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
