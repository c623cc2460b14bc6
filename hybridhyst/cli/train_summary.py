"""What ``hybridhyst-train`` reports once a run is done: the terminal summary (the starting nominal's RMSE and the
trained model's per split), the nominal's fitted values for metrics.json, and the hyperparameters TensorBoard
shows next to the final errors."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

from .common import edge_line

__all__ = ["SPLITS", "log_hparams", "physics_values", "summary"]

SPLITS = ("train", "val", "test")


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
        trained, start = _distinct(floor["trained_rmse"], floor["rmse"])
        lines.append(f"  the trained model's {floor['split']} RMSE {trained} {unit} is above the "
                     f"starting model's {start} {unit}: the starting weights are kept")
    if ident and ident.get("at_bounds"):  # the box, not the data, set these: the hybrid starts from them
        lines += textwrap.wrap(edge_line(ident["at_bounds"], "nominal_init.settings={bounds: {name: [low, high]}} "
                                         "or {box_factor: ...}"), 116, initial_indent="  ", subsequent_indent="  ")
    lines.append(f"  run dir: {run_dir}")
    return "\n".join(lines)


def _distinct(a, b) -> tuple[str, str]:
    """``a`` and ``b`` with as many significant figures (4 to 12) as it takes to tell them apart; None is inf
    (a diverged run's RMSE, which JSON stores as null)."""
    a, b = (math.inf if v is None else float(v) for v in (a, b))
    for digits in range(4, 13):
        sa, sb = f"{a:.{digits}g}", f"{b:.{digits}g}"
        if sa != sb:
            break
    return sa, sb


def _rmse(m) -> str:
    if not m:
        return "-"
    return "inf" if m.get("rmse") is None else f"{m['rmse']:.4g}"  # None: not finite (JSON null)


def physics_values(module) -> dict:
    if not hasattr(module, "nominal"):
        return {}
    return {k: {"value": v, "unit": module.nominal_unit(k)} for k, v in module.nominal_values().items()}


def log_hparams(trainer, cfg, result):
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
