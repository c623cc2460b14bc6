"""Comparison tables over configurations: summary (mean ± std over seeds), test RMSE per held-out
condition, and the failed/invalid runs.

A *configuration* is the set of info fields other than the seed and the measured ones
(:data:`~hybridhyst.report.collect.MEASURED_FIELDS`); its runs are the seeds. Errors are in the force
unit of the runs (``info.units["F"]``); NRMSE is dimensionless.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence

import numpy as np
import pandas as pd

__all__ = [
    "arch_label",
    "condition_stats",
    "condition_table",
    "configuration_labels",
    "error_unit",
    "failed_table",
    "summary_table",
]

STAT_COLUMNS = ("test_rmse", "test_mae", "test_nrmse", "val_rmse")
SUMMARY_FRONT = ["configuration", "name", "module", "residual", "placement", "arch", "lambda_phys", "train_fraction",
                 "n_seeds", "n_failed", *(f"{c}_{s}" for c in STAT_COLUMNS for s in ("mean", "std")), "n_parameters",
                 "train_time_s_mean"]


def arch_label(hidden) -> str | None:
    """Hidden-layer widths as text: ``[128, 128, 128, 128]`` → ``"4×128"``, ``[64, 32]`` → ``"64-32"``."""
    if hidden is None or (isinstance(hidden, float) and math.isnan(hidden)) or len(hidden) == 0:
        return None
    widths = [int(h) for h in hidden]
    return f"{len(widths)}×{widths[0]}" if len(set(widths)) == 1 else "-".join(map(str, widths))


def _value_text(field: str, value) -> str:
    """One distinguishing setting as a short label part (``λ=0.1``, ``train=0.5``, ``4×128``)."""
    if value is None:
        return f"{field}=none"
    if field == "hidden":
        return arch_label(value) or "hidden=none"
    number = f"{value:.4g}" if isinstance(value, float) else str(value)
    short = {"lambda_phys": "λ", "train_fraction": "train"}.get(field, field)
    return f"{short}={number}"


def configuration_labels(configs: Sequence[dict], exclude: Iterable[str] = ()) -> list[str]:
    """Unique display labels: the ``name`` plus the settings in which same-named configurations differ.

    Parameters
    ----------
    configs
        One dict of configuration fields per configuration (as stored in the ``config`` JSON key).
    exclude
        Fields never used to tell configurations apart (e.g. the swept one in a sweep figure).
    """
    exclude = {"name", *exclude}
    names = [str(c.get("name") or c.get("module") or "run") for c in configs]
    labels = []
    for i, config in enumerate(configs):
        same = [c for c, n in zip(configs, names) if n == names[i]]
        varying = [f for f in sorted(config) if f not in exclude
                   and len({json.dumps(c.get(f), sort_keys=True) for c in same}) > 1]
        parts = [_value_text(f, config.get(f)) for f in varying]
        labels.append(f"{names[i]} ({', '.join(parts)})" if parts else names[i])
    # identical settings under the given exclusions (only possible with ``exclude``): number them
    counts = {label: labels.count(label) for label in labels}
    seen: dict[str, int] = {}
    for i, label in enumerate(labels):
        if counts[label] > 1:
            seen[label] = seen.get(label, 0) + 1
            labels[i] = f"{label} #{seen[label]}"
    return labels


def error_unit(runs: pd.DataFrame) -> str | None:
    """The force unit of the errors when every successful run states the same one, else None."""
    units = set(runs.loc[runs["status"] == "ok", "unit_F"].dropna())
    return units.pop() if len(units) == 1 else None


def _configuration_row(key: str, group: pd.DataFrame, n_failed: int) -> dict:
    """Settings and seed statistics (mean, std with ddof=1) of one configuration's successful runs."""
    row = {"configuration": None, **json.loads(key), "n_seeds": len(group), "n_failed": n_failed,
           "n_kept_start": int(group["kept_start"].astype(bool).sum()) if "kept_start" in group else 0}
    row["arch"] = arch_label(row.get("hidden"))
    for column in STAT_COLUMNS:
        values = group[column].astype(float)
        row[f"{column}_mean"] = values.mean()
        row[f"{column}_std"] = values.std(ddof=1)  # NaN for a single seed
    params = group["n_parameters"].dropna()
    row["n_parameters"] = int(round(params.mean())) if len(params) else None
    row["train_time_s_mean"] = group["train_time_s"].astype(float).mean()
    row["config"] = key
    return row


def summary_table(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per configuration of the successful runs, best (lowest mean test RMSE) first.

    Columns: ``configuration`` (unique label), the settings (``name``, ``module``, ``residual``, ``arch``
    as ``"4×128"``, ``lambda_phys``, ``train_fraction``, ...), ``n_seeds`` (successful runs),
    ``n_failed`` (failed runs of the same configuration), ``n_kept_start`` (successful runs that kept their
    starting weights: training did not beat the start on validation), ``<split>_<metric>_mean`` and ``_std`` over
    seeds (ddof=1, NaN for one seed) for test RMSE/MAE/NRMSE and val RMSE [force unit; NRMSE 1],
    ``n_parameters``, ``train_time_s_mean`` [s] and ``config`` (the JSON key).
    """
    ok = runs[runs["status"] == "ok"]
    failed = runs.loc[runs["status"] != "ok", "config"].value_counts()
    rows = [_configuration_row(key, group, int(failed.get(key, 0)))
            for key, group in ok.groupby("config", sort=False)]
    if not rows:
        return pd.DataFrame(columns=[*SUMMARY_FRONT, "config"])
    table = pd.DataFrame(rows)
    table["configuration"] = configuration_labels([json.loads(k) for k in table["config"]])
    table = table.sort_values("test_rmse_mean", kind="stable", na_position="last").reset_index(drop=True)
    front = [c for c in SUMMARY_FRONT if c in table.columns]
    return table[front + [c for c in table.columns if c not in front]]


def condition_stats(runs: pd.DataFrame, summary: pd.DataFrame | None = None) -> pd.DataFrame:
    """Test error per held-out condition and configuration, over seeds (long format).

    Columns: ``configuration``, ``condition``, ``rmse_mean``, ``rmse_std`` (ddof=1), ``mae_mean``,
    ``n_seeds``; conditions in the order the runs list them, configurations in summary order.
    """
    summary = summary_table(runs) if summary is None else summary
    label = dict(zip(summary["config"], summary["configuration"]))
    records = [{"configuration": label[row.config], "condition": str(condition),
                "rmse": _float(scores.get("rmse")), "mae": _float(scores.get("mae"))}
               for row in runs[runs["status"] == "ok"].itertuples()
               for condition, scores in row.test_per_condition.items()]
    columns = ["configuration", "condition", "rmse_mean", "rmse_std", "mae_mean", "n_seeds"]
    if not records:
        return pd.DataFrame(columns=columns)
    long = pd.DataFrame(records)
    stats = long.groupby(["configuration", "condition"], sort=False).agg(
        rmse_mean=("rmse", "mean"), rmse_std=("rmse", lambda v: v.std(ddof=1)), mae_mean=("mae", "mean"),
        n_seeds=("rmse", "count")).reset_index()
    order = {c: i for i, c in enumerate(summary["configuration"])}
    conditions = {c: i for i, c in enumerate(dict.fromkeys(long["condition"]))}
    stats["_condition"] = stats["condition"].map(conditions)
    stats["_configuration"] = stats["configuration"].map(order)
    stats = stats.sort_values(["_condition", "_configuration"])
    return stats[columns].reset_index(drop=True)


def _float(value) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else np.nan


def condition_table(runs: pd.DataFrame, summary: pd.DataFrame | None = None) -> pd.DataFrame:
    """Mean test RMSE over seeds [force unit]: rows = held-out conditions, columns = configurations
    (summary order), plus a ``best`` column naming the configuration with the lowest value per row."""
    summary = summary_table(runs) if summary is None else summary
    stats = condition_stats(runs, summary)
    if stats.empty:
        return pd.DataFrame(columns=["best"], index=pd.Index([], name="condition"))
    table = stats.pivot(index="condition", columns="configuration", values="rmse_mean")
    table = table.reindex(index=list(dict.fromkeys(stats["condition"])),
                          columns=[c for c in summary["configuration"] if c in table.columns])
    table.index.name, table.columns.name = "condition", None
    table["best"] = [row.idxmin() if row.notna().any() else None for _, row in table.iterrows()]
    return table


def failed_table(runs: pd.DataFrame) -> pd.DataFrame:
    """The failed and invalid runs with their error: ``path``, ``status``, ``name``, ``seed``, ``error``."""
    bad = runs[runs["status"] != "ok"]
    return bad[["path", "status", "name", "seed", "error"]].reset_index(drop=True)
