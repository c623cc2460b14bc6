"""Find the run directories that ``hybridhyst-train`` writes and read their ``metrics.json`` into one table.

A run directory is any directory holding a ``metrics.json``, or the ``config.yaml`` of a ``hybridhyst-train`` run
that never wrote one (killed, or still running: a row with status ``"failed"``); Hydra multiruns put them below
``multirun/<date>/<time>/<job number>/``. Nothing is skipped silently: a file that cannot be read or does
not follow the contract becomes a row with status ``"invalid"`` and the reason in ``error``.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

__all__ = [
    "INFO_FIELDS",
    "MEASURED_FIELDS",
    "SPLITS",
    "collect_runs",
    "config_fields",
    "find_run_dirs",
    "read_run",
]

SPLITS = ("test", "val", "train")
METRICS = ("rmse", "mae", "nrmse", "n")
INFO_FIELDS = ("module", "name", "residual", "placement", "encoder_past", "lbfgs_steps", "hidden", "lambda_phys",
               "seed", "train_fraction", "n_parameters", "train_time_s", "epochs", "train_windows", "data", "model",
               "experiment")
# Outcomes of a run rather than settings: runs that differ only in these belong to one configuration.
MEASURED_FIELDS = ("seed", "n_parameters", "train_time_s", "epochs", "lbfgs_steps_done", "lm_steps_done",
                   "train_windows")
UNIT_FIELDS = ("unit_x", "unit_F", "unit_t")
_BASE = ("path", "status", "error", "predictions", "kept_start")
_METRIC_COLUMNS = tuple(f"{split}_{m}" for split in SPLITS for m in METRICS) + ("test_per_condition", "logged")


def _natural_key(path: Path) -> list:
    """Sort key that puts Hydra job ``2`` before ``10``."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", str(path))]


def find_run_dirs(dirs: str | Path | Iterable[str | Path]) -> list[Path]:
    """Run directories (folders with a ``metrics.json``) found recursively under each of ``dirs``.

    Paths keep the prefix they were given with; a run reached from two of ``dirs`` is listed once.

    Raises
    ------
    ValueError
        If no directory is given, one does not exist, or one holds no run directory at all.
    """
    dirs = [dirs] if isinstance(dirs, (str, Path)) else list(dirs)
    if not dirs:
        raise ValueError("no directory given: pass run directories or multirun folders")
    found: dict[Path, Path] = {}
    for d in dirs:
        root = Path(d)
        if not root.is_dir():
            what = "is not a directory" if root.exists() else "does not exist"
            raise ValueError(f"'{d}' {what}; pass run directories or the multirun folders that contain them")
        runs = [f.parent for f in root.rglob("metrics.json") if f.is_file()]
        runs += [f.parent for f in root.rglob("config.yaml")  # not Hydra's own copy in <run>/.hydra/
                 if ".hydra" not in f.parent.parts and _unfinished_train(f.parent)]
        if not runs:
            raise ValueError(f"no run directory (a folder with metrics.json) found under '{d}'; "
                             "point at the output of hybridhyst-train")
        for run in runs:
            found.setdefault(run.resolve(), run)
    return sorted(found.values(), key=_natural_key)


def _unfinished_train(run_dir: Path) -> bool:
    """A ``hybridhyst-train`` run directory (its resolved ``config.yaml`` says ``app: train``) without a
    ``metrics.json``: the run was killed before it could write one, or is still running."""
    if (run_dir / "metrics.json").exists():
        return False
    try:
        head = (run_dir / "config.yaml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return re.search(r"^app: train\s*$", head, flags=re.M) is not None


def _number(value) -> float:
    """A JSON number as float; null, missing or non-numeric values are NaN."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


def _check(metrics) -> None:
    """Raise ``ValueError`` saying how ``metrics.json`` breaks the run-directory contract."""
    if not isinstance(metrics, dict):
        raise ValueError(f"expected a JSON object, got {type(metrics).__name__}")
    status = metrics.get("status")
    if status not in ("ok", "failed"):
        raise ValueError(f"'status' must be 'ok' or 'failed', got {status!r}")
    for key in ("info", "physics", *SPLITS):
        if metrics.get(key) is not None and not isinstance(metrics[key], dict):
            raise ValueError(f"'{key}' must be an object, got {type(metrics[key]).__name__}")
    if status == "ok" and not math.isfinite(_number((metrics.get("test") or {}).get("rmse"))):
        raise ValueError("status is 'ok' but test.rmse is missing or not a finite number")
    per_condition = (metrics.get("test") or {}).get("per_condition", {})
    if not isinstance(per_condition, dict) or not all(isinstance(v, dict) for v in per_condition.values()):
        raise ValueError("test.per_condition must map condition labels to {rmse, mae, nrmse, n} objects")


def _info_columns(info: dict) -> dict:
    """The ``info`` object as flat columns: ``hidden`` as a tuple, ``units`` as ``unit_<quantity>``."""
    out = {k: v for k, v in info.items() if k != "units"}
    hidden = out.get("hidden")
    out["hidden"] = tuple(int(h) for h in hidden) if isinstance(hidden, (list, tuple)) else None
    for quantity, unit in (info.get("units") or {}).items():
        out[f"unit_{quantity}"] = unit
    return out


def _split_columns(metrics: dict) -> dict:
    """``<split>_<metric>`` columns (NaN where absent) and the test split's per-condition metrics."""
    out = {}
    for split in SPLITS:
        scores = metrics.get(split) or {}
        for m in METRICS:
            out[f"{split}_{m}"] = _number(scores.get(m))
    out["test_per_condition"] = (metrics.get("test") or {}).get("per_condition") or {}
    logged = metrics.get("logged")
    out["logged"] = {k: _number(v) for k, v in logged.items()} if isinstance(logged, dict) else {}
    return out


def read_run(run_dir: str | Path) -> dict:
    """One run directory as a flat row: path, status, error, info fields, split metrics.

    Returns a row with status ``"invalid"`` and the reason in ``error`` when ``metrics.json`` cannot be
    read or does not follow the contract (never raises for a bad file).
    """
    run_dir = Path(run_dir)
    predictions = run_dir / "predictions.parquet"
    row = {"path": str(run_dir), "status": "invalid", "error": None,
           "predictions": str(predictions) if predictions.is_file() else None, "kept_start": False}
    if _unfinished_train(run_dir):
        row.update(status="failed", error="no metrics.json: the run was killed before it finished (or is still "
                                          "running)")
        return row
    try:
        metrics = json.loads((run_dir / "metrics.json").read_text(encoding="utf-8"))
        _check(metrics)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        row["error"] = f"invalid metrics.json: {' '.join(str(exc).split())}"
        return row
    row["status"] = metrics["status"]
    if row["status"] == "failed":
        row["error"] = str(metrics.get("error") or "(failed without an error message)")
    row["kept_start"] = bool((metrics.get("start") or {}).get("restored", False))
    row.update(_info_columns(metrics.get("info") or {}))
    row.update(_split_columns(metrics))
    return row


def config_fields(runs: pd.DataFrame) -> list[str]:
    """Columns that define a configuration: every info field except the measured ones and the seed."""
    skip = {*_BASE, *_METRIC_COLUMNS, *MEASURED_FIELDS, "config"}
    return [c for c in runs.columns if c not in skip]


def _plain(value):
    """A cell as a JSON-able value (NaN to None, tuples to lists, numpy scalars to python)."""
    if isinstance(value, tuple):
        return list(value)
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def collect_runs(dirs: str | Path | Iterable[str | Path]) -> pd.DataFrame:
    """One row per run directory found under ``dirs`` (searched recursively).

    Columns: ``path``, ``status`` ("ok", "failed" or "invalid"), ``error``, ``predictions`` (path of
    ``predictions.parquet`` or None), ``kept_start`` (the trained model did worse on validation than the one
    it started from, whose weights the run kept: ``metrics.json``'s ``start.restored``), the info fields
    (``hidden`` as a tuple, ``units`` as ``unit_x``,
    ``unit_F``, ``unit_t``), ``{test,val,train}_{rmse,mae,nrmse,n}`` (errors in the force unit
    ``unit_F``; NaN where absent), ``test_per_condition`` (dict), ``logged`` (the last epoch's logged values,
    ``{"train/phys_loss": ...}``; empty for runs written before it) and ``config``, a JSON key of the
    configuration fields (:func:`config_fields`) shared by the seeds of one configuration.

    Raises
    ------
    ValueError
        If a directory does not exist or holds no run directory.
    """
    rows = [read_run(d) for d in find_run_dirs(dirs)]
    extra = sorted({k for row in rows for k in row} - {*_BASE, *INFO_FIELDS, *UNIT_FIELDS, *_METRIC_COLUMNS})
    columns = [*_BASE, *INFO_FIELDS, *extra, *UNIT_FIELDS, *_METRIC_COLUMNS]
    runs = pd.DataFrame(rows).reindex(columns=columns)
    for column in ("test_per_condition", "logged"):
        runs[column] = [v if isinstance(v, dict) else {} for v in runs[column]]
    fields = config_fields(runs)
    runs["config"] = [json.dumps({f: _plain(row[f]) for f in fields}, sort_keys=True)
                      for _, row in runs.iterrows()]
    return runs
