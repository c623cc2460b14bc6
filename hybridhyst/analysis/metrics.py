"""Error metrics between a prediction and a measurement (numpy or torch, any shape)."""

from __future__ import annotations

import math

import numpy as np


def _np(a) -> np.ndarray:
    if hasattr(a, "detach"):
        a = a.detach().cpu().numpy()
    return np.asarray(a, dtype=np.float64)


def _pair(pred, target):
    p, t = _np(pred), _np(target)
    if p.shape != t.shape:
        raise ValueError(f"prediction has shape {p.shape} but the measurement has {t.shape}")
    return p, t


def rmse(pred, target) -> float:
    """Root-mean-square error, in the response's unit."""
    p, t = _pair(pred, target)
    return float(np.sqrt(np.mean((p - t) ** 2)))


def mae(pred, target) -> float:
    """Mean absolute error, in the response's unit."""
    p, t = _pair(pred, target)
    return float(np.mean(np.abs(p - t)))


def nrmse(pred, target) -> float:
    """RMSE divided by the measurement's standard deviation (0 = perfect, 1 = predicting the mean)."""
    p, t = _pair(pred, target)
    return rmse(p, t) / float(np.std(t))


def r2(pred, target) -> float:
    """Coefficient of determination 1 − SS_res / SS_tot; NaN (no warning) for a constant target, where it is
    undefined."""
    p, t = _pair(pred, target)
    ss_tot = float(np.sum((t - t.mean()) ** 2))
    return float(1.0 - np.sum((p - t) ** 2) / ss_tot) if ss_tot > 0 else math.nan


def relative_error(pred, target) -> float:
    """Relative RMS error sqrt(Σ (F_meas − F_model)² / Σ F_meas²).

    Seed 004's formula (5) prints sqrt((Σ F_emp² − F_BW²)/Σ F_emp²), which is malformed (it can be
    imaginary and is zero for any model with the same energy); the evident intent is the norm of the
    difference, used here.
    """
    p, t = _pair(pred, target)
    return float(np.sqrt(np.sum((t - p) ** 2) / np.sum(t**2)))


def _all_metrics(pred: np.ndarray, y: np.ndarray) -> dict:
    if not bool(np.isfinite(pred).all()):
        return {"rmse": math.inf, "mae": math.inf, "nrmse": math.inf, "n": int(y.size)}
    return {"rmse": rmse(pred, y), "mae": mae(pred, y), "nrmse": nrmse(pred, y), "n": int(y.size)}


def split_metrics(preds: list[dict]) -> dict:
    """Pooled metrics (rmse, mae, nrmse, n) over every scored sample of a split, and per condition label.

    ``preds``: one dict per record with ``y`` (measured), ``y_pred``, ``condition`` (its label) and optional
    ``warmup`` (leading samples simulated but not scored). Records are pooled; ``{}`` without records.
    Returns ``{"rmse", "mae", "nrmse", "n", "per_condition": {label: {...}}}``.
    """
    if not preds:
        return {}

    def pooled(sel, key):
        return np.concatenate([np.asarray(p[key])[int(p.get("warmup") or 0):] for p in sel])

    out = _all_metrics(pooled(preds, "y_pred"), pooled(preds, "y"))
    per: dict[str, dict] = {}
    for label in dict.fromkeys(p["condition"] for p in preds):
        sel = [p for p in preds if p["condition"] == label]
        per[label] = _all_metrics(pooled(sel, "y_pred"), pooled(sel, "y"))
    out["per_condition"] = per
    return out
