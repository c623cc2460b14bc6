"""The pieces of one training run, built from a composed ``hybridhyst-train`` config (``conf/train.yaml``).

``build_datamodule`` (records and split), ``build_module`` (the LightningModule with its network, loss and
nominal start), ``build_trainer`` (checkpoints, logger, loop figures) and ``run_info`` (what identifies the run
in a report). The app ``hybridhyst.cli.train`` wires them into a run directory; tests and callers below the
apps use them directly.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

import lightning as L
from omegaconf import DictConfig

from ..data.datamodule import RecordDataModule
from ..nets import parse_hidden
from ..simulate import SimulationSettings
from .callbacks import LoopFigures
from .config import check_kwargs, check_model_data, config_number, instantiate, load_records, split_options, to_plain
from .modules import MODULES, load_nominal_state

__all__ = ["NOMINAL_MODULES", "build_datamodule", "build_module", "build_trainer", "encoder_past", "max_epochs",
           "nominal_start", "run_info"]

DISPLAY = {"physics": "physics-only", "mlp": "mlp", "lstm": "lstm", "std_pinn": "std-pinn"}
NOMINAL_MODULES = ("physics", "hybrid", "std_pinn")


def build_datamodule(cfg: DictConfig) -> RecordDataModule:
    """Records from ``cfg.data`` (``split.select``) in a ``RecordDataModule`` (``split.held_out`` -> test,
    ``split.val`` -> validation). Its conditions are those fed to the networks (``datamodule.conditions``) and
    those the nominal's parameter functions read (a model whose parameters depend on the pressure gets it
    without the network seeing it); each must be a number in every record."""
    from ..data.splits import check_conditions
    from ..physics.models import conditions_used

    split = split_options(cfg)
    d = check_kwargs(to_plain(cfg.datamodule), RecordDataModule.__init__, "datamodule",
                     reserved=("records", "held_out", "val", "seed", "past"))
    records = load_records(cfg, split["select"])
    parts = records.split(held_out=split["held_out"], val=split["val"])
    network = list(d.pop("conditions", None) or [])
    check_conditions(parts, network, "datamodule.conditions")
    model = []
    if cfg.get("module") in NOMINAL_MODULES:
        nominal = instantiate(cfg.model, _convert_="all")
        note = check_model_data(nominal, parts, "model", read_elsewhere=network)  # the network reads these
        if note:  # records without units: the model's are assumed
            print(note, flush=True)
        model = [c for c in conditions_used(nominal) if c not in network]
    return RecordDataModule(records, held_out=split["held_out"], val=split["val"], seed=int(cfg.seed),
                            past=encoder_past(cfg), conditions=[*network, *model], **d)


def encoder_past(cfg: DictConfig) -> int:
    """Samples before each training window that the window-start encoder reads (``encoder.past``; 0: none)."""
    past = (cfg.get("encoder") or {}).get("past") or 0
    if cfg.get("module") not in ("physics", "hybrid") and past:
        raise ValueError(f"encoder.past={past}: the window-start encoder belongs to a module with a nominal model "
                         f"(physics, hybrid), not {cfg.get('module')!r}")
    return int(past)


def build_module(cfg: DictConfig, dm: RecordDataModule, identify: Callable | None = None):
    """The LightningModule named by ``cfg.module`` with its network (``cfg.residual``) and loss settings.

    A nominal (physics, hybrid, std_pinn) is fitted to the training records first by ``identify(cfg, dm,
    nominal) -> summary`` when ``nominal_start`` says ``"identify"`` and the run does not resume from
    ``ckpt_path`` (training does not import ``hybridhyst.identify``: the app ``hybridhyst.cli.train`` passes its
    ``identify_nominal``); the summary goes to ``module.nominal_identified`` (metrics.json)."""
    kind = cfg.module
    if kind not in MODULES:
        raise ValueError(f"unknown module {kind!r}; choose from {sorted(MODULES)}")
    loss, net = cfg.loss, cfg.residual
    network = [c for c in [*dm.condition_names, *dm.control_names] if c in (cfg.datamodule.get("conditions") or [])]
    common = {"normaliser": dm.normaliser.to_dict(), "condition_names": dm.condition_names,
              "control_names": dm.control_names, "network_conditions": network, "units": dm.units,
              "lr": float(cfg.trainer.lr), "weight_decay": float(cfg.trainer.weight_decay), "loss": loss.kind,
              "nominal_lr": cfg.trainer.get("nominal_lr"), "normalise_loss": bool(loss.get("normalise", True)),
              "lambda_phys": float(loss.lambda_phys), "lr_schedule": str(cfg.trainer.lr_schedule),
              "lr_final_ratio": float(cfg.trainer.lr_final_ratio)}
    simulation = SimulationSettings.from_config(cfg.simulation)  # a LightningModule's hyperparameters: plain values
    sim = {"method": simulation.method, "substeps": simulation.substeps, "backend": simulation.backend}
    encoder = {"encoder_past": encoder_past(cfg), "encoder_hidden": (cfg.get("encoder") or {}).get("hidden", "2x32"),
               "window_start": str(cfg.get("window_start") or "rest")}
    if kind in NOMINAL_MODULES:
        nominal = instantiate(cfg.model, _convert_="all").double()
        check_model_data(nominal, dm.split, "model")
        from ..physics.effects.base import ControlEffect

        acting = [key for key, e in nominal.effects.items() if isinstance(e, ControlEffect)]
        if acting and (kind == "std_pinn" or float(loss.lambda_phys) > 0):
            raise ValueError(f"the physics residual (lambda_phys > 0, std_pinn) evaluates the law at collocation "
                             f"points, where an effect acting on a control ({', '.join(acting)}: a lag, a saturation) "
                             "has no history; train with loss.lambda_phys=0 and module=physics or hybrid")
        if cfg.get("nominal_state"):
            try:
                nominal.load_state_dict(load_nominal_state(cfg.nominal_state))
            except RuntimeError as e:  # keys or shapes of another model
                raise ValueError(f"nominal_state={cfg.nominal_state} does not fit the model "
                                 f"{cfg.model.get('name') or ''!s}: {' '.join(str(e).split())[:300]}; give the run "
                                 "directory of this model, or the model config that run wrote (model=...)") from None
        identified, start = None, nominal_start(cfg)
        if start not in ("nominal_state", "init_noise", "identify", "model"):
            raise ValueError(f"unknown nominal_init.start {start!r}; choose 'identify' or 'none'")
        if start == "identify" and not cfg.get("ckpt_path"):  # resuming: the checkpoint has them
            if identify is None:
                raise ValueError("nominal_init.start=identify needs an identification step: build_module(cfg, dm, "
                                 "identify=hybridhyst.cli.train.identify_nominal), or nominal_init.start=none")
            identified = identify(cfg, dm, nominal)
    if kind == "physics":
        module = MODULES[kind](nominal, init_noise=loss.get("init_noise"), prior_weight=float(loss.prior_weight),
                               prior_kind=loss.prior_kind, features=list(cfg.features), **encoder, **sim,
                               **common)
    elif kind == "hybrid":
        module = MODULES[kind](nominal, residual=net.kind, hidden=net.hidden, activation=net.activation,
                               freeze_nominal=bool(cfg.freeze_nominal), features=list(cfg.features),
                               placement=str(cfg.placement),
                               latent_states=int(cfg.latent_states), **dynamics_inputs(cfg), **encoder, **sim, **common)
    elif kind == "std_pinn":
        module = MODULES[kind](nominal, hidden=net.hidden, activation=net.activation,
                               freeze_nominal=bool(cfg.freeze_nominal), **sim, **common)
    else:
        return MODULES[kind](hidden=net.hidden, activation=net.activation, features=list(cfg.features), **common)
    module.nominal_identified = identified  # identification summary (None without one), for metrics.json
    return module


def dynamics_inputs(cfg: DictConfig) -> dict:
    """``{"dynamics_inputs": (...), "latent_form": ...}`` for a hybrid whose network sits inside the dynamics;
    ``{}`` otherwise (the keys are read by ``placement=dynamics`` only, so an experiment config can set them for
    every run it sweeps)."""
    if cfg.module != "hybrid" or cfg.get("placement") != "dynamics":
        return {}
    return {"dynamics_inputs": tuple(cfg.get("dynamics_inputs") or ("x", "v")),
            "latent_form": str(cfg.get("latent_form") or "free")}


def nominal_start(cfg: DictConfig) -> str | None:
    """Where the nominal of ``cfg.module`` starts: ``"nominal_state"`` (a given state dict), ``"init_noise"``
    (the physics module's seed 000 re-initialisation near zero), ``"identify"`` (``nominal_init.start``:
    batched identification on the training records) or ``"model"`` (the model config's values); None for
    modules without a nominal."""
    if cfg.module not in NOMINAL_MODULES:
        return None
    if cfg.get("nominal_state"):
        return "nominal_state"
    if cfg.module == "physics" and cfg.loss.get("init_noise"):
        return "init_noise"
    start = str((cfg.get("nominal_init") or {}).get("start") or "none")
    return "model" if start == "none" else start  # build_module refuses an unknown start


def _stage_block(cfg: DictConfig, key: str, known: tuple[str, ...], what: str) -> dict | None:
    """``trainer.<key>`` with its keys checked, or None when it has no steps; every key given (the values are
    conf/trainer/default.yaml's)."""
    block = to_plain(cfg.trainer.get(key)) or {}
    unknown = sorted(set(block) - set(known))
    if unknown:
        raise ValueError(f"unknown trainer.{key} key(s) {unknown}; the keys are {sorted(known)}")
    if not block.get("steps"):
        return None
    missing = [k for k in known if block.get(k) is None]
    if missing:
        raise ValueError(f"trainer.{key}.{missing[0]} is missing: the {what} stage needs {list(known)} "
                         "(see conf/trainer/default.yaml)")
    return block


def _one_process(cfg: DictConfig, key: str, why: str) -> None:
    """Refuse a multi-device run for a stage that needs the whole training set in one process."""
    t = cfg.trainer
    devices = t.get("devices", 1)
    if (int(t.get("num_nodes", 1)) > 1 or "ddp" in str(t.get("strategy", "auto"))
            or (isinstance(devices, int) and devices > 1) or isinstance(devices, (list, tuple))
            or (isinstance(devices, str) and devices.strip().isdigit() and int(devices) > 1)):
        raise ValueError(f"trainer.{key} runs in one process ({why}): set trainer.{key}.steps=0 for a multi-device "
                         "run")


def lbfgs_settings(cfg: DictConfig) -> dict | None:
    """``trainer.lbfgs`` checked: ``{"steps", "max_iter", "history_size", "check_val_every_n_epoch"}``, or None
    when the run has no L-BFGS stage (``steps: 0`` or no block)."""
    known = ("steps", "max_iter", "history_size", "check_val_every_n_epoch")
    block = _stage_block(cfg, "lbfgs", known, "L-BFGS")
    if block is None:
        return None
    out = {k: int(block[k]) for k in known}
    if out["steps"] < 0 or min(out["max_iter"], out["history_size"], out["check_val_every_n_epoch"]) < 1:
        raise ValueError(f"trainer.lbfgs needs steps >= 0 and max_iter, history_size, check_val_every_n_epoch >= 1, "
                         f"got {out}")
    _one_process(cfg, "lbfgs", "its line search needs the whole batch's loss")
    return out


def lm_settings(cfg: DictConfig) -> dict | None:
    """``trainer.lm`` checked: ``{"steps", "damping", "check_val_every_n_epoch"}``, or None when the run has no
    Levenberg–Marquardt stage (``steps: 0`` or no block)."""
    block = _stage_block(cfg, "lm", ("steps", "damping", "check_val_every_n_epoch"), "Levenberg-Marquardt")
    if block is None:
        return None
    out = {"steps": int(block["steps"]), "damping": float(block["damping"]),
           "check_val_every_n_epoch": int(block["check_val_every_n_epoch"])}
    if out["steps"] < 0 or out["check_val_every_n_epoch"] < 1 or not out["damping"] > 0:
        raise ValueError(f"trainer.lm needs steps >= 0, damping > 0 and check_val_every_n_epoch >= 1, got {out}")
    if lbfgs_settings(cfg) is not None:
        raise ValueError("trainer.lbfgs.steps and trainer.lm.steps are both set: the stage after Adam is one of "
                         "them; set the other's steps to 0")
    _one_process(cfg, "lm", "each step needs every record's Jacobian")
    t = cfg.trainer
    if str(t.get("accelerator", "cpu")) != "cpu":
        raise ValueError(f"trainer.lm runs on the CPU (its Jacobians come from the compiled loop on the host), not "
                         f"trainer.accelerator={t.get('accelerator')}: use trainer=default, or trainer.lm.steps=0")
    return out


def second_stage(cfg: DictConfig) -> tuple[str, dict] | None:
    """The stage after the Adam epochs: ``("lbfgs", trainer.lbfgs)``, ``("lm", trainer.lm)`` or None."""
    lm = lm_settings(cfg)
    if lm is not None:
        return "lm", lm
    lbfgs = lbfgs_settings(cfg)
    return ("lbfgs", lbfgs) if lbfgs is not None else None


def max_epochs(cfg: DictConfig) -> int:
    """``trainer.max_epochs`` checked: a whole number >= 0, or Lightning's -1 (no limit) where a stopping rule in
    ``trainer.extra`` ends the run (``max_steps``, ``max_time``). Alone, -1 would train without end, and Lightning
    refuses anything below it with a traceback."""
    t = cfg.trainer
    epochs = config_number(t, "max_epochs", "trainer.max_epochs", whole=True)
    if epochs >= 0:
        return epochs
    extra = to_plain(t.get("extra")) or {}
    stops = [k for k in ("max_steps", "max_time") if extra.get(k) not in (None, -1)]
    if epochs == -1 and stops:
        return epochs
    rule = "'+trainer.extra.max_steps=<steps>' or '+trainer.extra.max_time=00:02:00:00' (DD:HH:MM:SS)"
    if epochs == -1:
        raise ValueError(f"config key trainer.max_epochs=-1 (no limit) trains without end: give "
                         f"trainer.max_epochs=<epochs>, or a stopping rule with it: {rule}")
    raise ValueError(f"config key trainer.max_epochs must be >= 0, got {epochs}: give trainer.max_epochs=<epochs> "
                     f"(-1: no limit, only with a stopping rule: {rule})")


def _no_advert(record: logging.LogRecord) -> bool:
    return "litlogger" not in record.getMessage()


def _quiet_lightning() -> None:
    """Drop Lightning's advertisement for its cloud logger from the run's terminal output (once per process)."""
    log = logging.getLogger("lightning.pytorch.utilities.rank_zero")
    if _no_advert not in log.filters:
        log.addFilter(_no_advert)


def build_trainer(cfg: DictConfig, run_dir: Path, callbacks: list | tuple = (), after: L.Trainer | None = None,
                  monitor: str | None = None) -> L.Trainer:
    """Trainer with checkpoints (best validation RMSE + last), the logger of ``cfg.logger``, loop figures and
    ``callbacks``; ``cfg.trainer`` gives the accelerator, devices, strategy and the loop's settings.

    ``after``: the trainer of the Adam epochs; the new one runs the stage after them (``second_stage``: the
    L-BFGS or Levenberg–Marquardt steps as epochs, no gradient clipping, its logger version ``lbfgs`` or ``lm``;
    the Levenberg–Marquardt stage reads no training batch, so it loads one per step). It keeps ``after``'s
    best-checkpoint callback, so ``best.ckpt`` stays the best of both stages, and writes no ``last.ckpt``: that
    stays the end of the Adam epochs, and a run resumed from it repeats the (deterministic) stage.

    ``monitor``: the metric the best checkpoint is chosen by, the one the module logs (``val/rmse``, or
    ``train/rmse`` where the data module has no validation records); by default from ``split.val``."""
    from lightning.pytorch.callbacks import ModelCheckpoint

    _quiet_lightning()
    t = cfg.trainer
    stage_after = second_stage(cfg) if after is not None else None
    if after is not None and stage_after is None:
        raise ValueError("build_trainer(after=...) is for the stage after Adam; trainer.lbfgs.steps and "
                         "trainer.lm.steps are 0")
    # resuming keeps writing into the checkpoint's own folder, so the best score so far carries over
    ckpt_dir = Path(cfg.ckpt_path).resolve().parent if cfg.get("ckpt_path") else Path(run_dir) / "checkpoints"
    # best.ckpt: the best validation RMSE; last.ckpt: every epoch. Lightning >= 2.6 writes save_last's copy only
    # when a top-k checkpoint is saved at the same step (last.ckpt would be the best one, not the last), so
    # last.ckpt has a checkpoint callback of its own (listed second: it saves the best one's updated state)
    if after is None:
        # the validation loop scores the training records where there are no validation ones, named so
        monitor = monitor or ("val/rmse" if split_options(cfg)["val"] else "train/rmse")
        checkpoints = [ModelCheckpoint(dirpath=ckpt_dir, monitor=monitor, mode="min", save_last=False,
                                       filename="best", save_top_k=1),
                       ModelCheckpoint(dirpath=ckpt_dir, monitor=None, save_top_k=1, filename="last",
                                       enable_version_counter=False)]
    else:
        checkpoints = [after.checkpoint_callbacks[0]]
    callbacks = [*checkpoints, *callbacks]
    logger = False
    version = "" if stage_after is None else stage_after[0]
    if cfg.logger.kind == "tensorboard":
        from lightning.pytorch.loggers import TensorBoardLogger

        logger = TensorBoardLogger(save_dir=str(run_dir), name="tensorboard", version=version, default_hp_metric=False)
        callbacks.append(LoopFigures(int(cfg.logger.loop_every_n_epochs), int(cfg.logger.max_loop_figures)))
    elif cfg.logger.kind == "csv":
        from lightning.pytorch.loggers import CSVLogger

        logger = CSVLogger(save_dir=str(run_dir), name="csv", version=version)
    elif cfg.logger.kind != "none":
        raise ValueError(f"unknown logger {cfg.logger.kind!r}; choose tensorboard, csv or none")
    if bool(t.enable_progress_bar):
        callbacks.extend(_progress_bar())
    extra = to_plain(t.get("extra")) or {}
    stage = {"max_epochs": max_epochs(cfg), "gradient_clip_val": t.gradient_clip_val,
             "check_val_every_n_epoch": int(t.check_val_every_n_epoch), "limit_train_batches": t.limit_train_batches}
    if stage_after is not None:
        kind, settings = stage_after
        stage = {"max_epochs": settings["steps"], "gradient_clip_val": None,
                 "check_val_every_n_epoch": settings["check_val_every_n_epoch"]}
        if kind == "lm":
            stage["limit_train_batches"] = 1
    return L.Trainer(accelerator=t.accelerator, devices=t.devices, strategy=t.strategy, num_nodes=int(t.num_nodes),
                     precision=t.precision, log_every_n_steps=int(t.log_every_n_steps),
                     deterministic=bool(t.deterministic),
                     limit_val_batches=t.limit_val_batches, enable_progress_bar=bool(t.enable_progress_bar),
                     enable_model_summary=False, default_root_dir=str(run_dir), logger=logger, callbacks=callbacks,
                     **stage, **extra)


def _progress_bar() -> list:
    """Lightning's rich progress bar with metrics in significant figures: its default, three decimals, shows an
    RMSE in metres as 0.000. Empty without ``rich``: Lightning's tqdm bar is used, which prints three
    significant figures already."""
    try:
        from lightning.pytorch.callbacks import RichProgressBar
        from lightning.pytorch.callbacks.progress.rich_progress import RichProgressBarTheme

        return [RichProgressBar(theme=RichProgressBarTheme(metrics_format=".4g"))]
    except ImportError:
        return []


def run_info(cfg: DictConfig) -> dict:
    """What identifies a run in a report (``metrics.json``'s ``info``; everything but the seed makes a
    configuration)."""
    kind = cfg.module
    uses_net = kind != "physics"
    name = DISPLAY.get(kind, kind)
    if kind == "hybrid":  # hybrid-mlp, hybrid-lstm (the output branch) or hybrid-dynamics (inside the equations)
        name = "hybrid-dynamics" if cfg.placement == "dynamics" else f"hybrid-{cfg.residual.kind}"
    model = (cfg.model.get("name") or cfg.model.get("_target_", "").rsplit(".", 1)[-1]) \
        if kind in NOMINAL_MODULES else None
    max_epochs(cfg)  # checked before the run starts (the trainer is built after the nominal's identification)
    return {"module": kind, "name": name, "residual": cfg.residual.kind if uses_net else None,
            "hidden": parse_hidden(cfg.residual.hidden) if uses_net else None,
            "lambda_phys": float(cfg.loss.lambda_phys) if kind in ("hybrid", "std_pinn") else 0.0,
            "seed": int(cfg.seed), "train_fraction": float(cfg.datamodule.train_fraction),
            "conditions": ",".join(cfg.datamodule.conditions),
            "data": cfg.data.get("name", cfg.data.get("_target_", "")), "model": model,
            "placement": str(cfg.placement) if kind == "hybrid" else None,
            "dynamics_inputs": ",".join(dynamics_inputs(cfg).get("dynamics_inputs", ())) or None,
            "latent_form": dynamics_inputs(cfg).get("latent_form"),
            "freeze_nominal": bool(cfg.freeze_nominal) if kind in ("hybrid", "std_pinn") else None,
            "encoder_past": encoder_past(cfg) if kind in ("physics", "hybrid") else None,
            "window_start": str(cfg.get("window_start") or "rest") if kind in ("physics", "hybrid") else None,
            "nominal_init": nominal_start(cfg), "lbfgs_steps": (lbfgs_settings(cfg) or {}).get("steps", 0),
            "lm_steps": (lm_settings(cfg) or {}).get("steps", 0),
            "experiment": cfg.get("experiment_name")}
