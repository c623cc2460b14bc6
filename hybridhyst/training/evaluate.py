"""Predictions on whole records and metrics per split and per operating condition (physical units)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import torch

from ..analysis.metrics import split_metrics

__all__ = ["predict_split", "split_metrics", "predictions_frame"]


def predict_split(module, dm, split: str, nominal: bool = False) -> list[dict]:
    """Whole-record predictions of ``split`` ("train", "val" or "test"): one dict per record with its name,
    condition label, t, x, y (measured), y_pred and y_nominal (None without a nominal model).

    ``nominal``: the module's nominal model alone (``simulate_nominal``; modules with a nominal model only):
    y_pred = y_nominal = the nominal's response, whatever the module adds to it."""
    if nominal and not hasattr(module, "simulate_nominal"):
        raise ValueError(f"module {type(module).__name__} has no nominal model")
    if not len(dm.records(split)):
        return []
    was_training = module.training
    module.eval()
    out = []
    try:
        with torch.no_grad():
            for i, (rec, label) in enumerate(zip(dm.records(split), dm.labels(split))):
                batch = {k: v[None] for k, v in dm.whole(split)[i].items()}
                batch = {k: v.to(module.device) for k, v in batch.items()}
                if nominal:
                    y = y_nom = module.simulate_nominal(batch)
                else:
                    res = module(batch)
                    y, y_nom = res["y"], res.get("nominal")
                out.append({"record": rec.name, "condition": label, "split": split,
                            "t": batch["t"][0].cpu().numpy(), "x": batch["u"][0].cpu().numpy(),
                            "y": batch["y"][0].cpu().numpy(), "y_pred": y[0].cpu().numpy(),
                            "y_nominal": None if y_nom is None else y_nom[0].cpu().numpy(),
                            "warmup": rec.warmup})
    finally:
        module.train(was_training)
    return out


def predictions_frame(preds: list[dict]) -> pd.DataFrame:
    """Long table of predictions: record, split, condition, t, x, y, y_pred, y_nominal (NaN if none)."""
    frames = []
    for p in preds:
        n = len(p["t"])
        frames.append(pd.DataFrame({
            "record": p["record"], "split": p["split"], "condition": p["condition"], "t": p["t"], "x": p["x"],
            "y": p["y"], "y_pred": p["y_pred"],
            "y_nominal": np.full(n, np.nan) if p["y_nominal"] is None else p["y_nominal"]}))
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["record", "split", "condition", "t", "x", "y", "y_pred", "y_nominal"])
