"""The loop's out-of-sample error of a fitted model: what every acceptance, comparison and removal is judged on.

Two ways (``discover(validation=...)``):

- ``"records"``: the RMSE on the validation records (on the training records when there are none). One
  simulation per model; the validation records are of whatever kind the user holds out, often the same
  kind as the training records.
- ``"loco"``: leave one operating condition out. The training records are grouped by their operating
  conditions (records that share every condition value are one group); for each group the model is
  refitted on the other groups (Levenberg–Marquardt from its fitted values, every coordinate free, at its
  own sub-steps) and simulated on the held-out group. The error pools every group's held-out residual,
  and the validation records' residuals under the model fitted on all training records. A parameter made a
  function of a condition must then predict a level it was not fitted on, and an effect must carry over
  to an operating point it did not see; costs one refit per group for each model scored.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence

import numpy as np
import torch

from ..analysis.metrics import split_metrics
from ..data.records import Record
from ..simulate import simulate
from .fitting import polish

__all__ = ["VALIDATION", "Validation", "condition_groups", "predict", "record_metrics", "rmse_on"]

VALIDATION = ("records", "loco")


def predict(model, records, sim: dict) -> list[np.ndarray]:
    """The model's response to each record (first output channel), simulated with ``sim``."""
    if not records:
        return []
    with torch.no_grad():
        out = simulate(model, list(records), method=sim["method"], substeps=sim["substeps"], backend=sim["backend"])
    return [o[:, 0].numpy() for o in out]


def record_metrics(records, preds, labels: Sequence[str] | None = None) -> dict:
    """Pooled RMSE and RMSE per condition label (``analysis.split_metrics``); {} without records."""
    from ..data.datamodule import condition_label

    out = split_metrics([{"condition": condition_label(r, labels), "y": np.asarray(r.y), "y_pred": p,
                          "warmup": r.warmup} for r, p in zip(records, preds)])
    if out:
        out["per_condition"] = {k: v["rmse"] for k, v in out["per_condition"].items()}
    return out


def rmse_on(model, records, sim: dict) -> float:
    """The model's pooled RMSE on ``records`` (inf without records)."""
    return record_metrics(records, predict(model, records, sim)).get("rmse", math.inf) if records else math.inf


def condition_groups(records: Sequence[Record]) -> list[list[Record]]:
    """Records grouped by their operating conditions (every condition's value; records that share all of
    them are one operating point), in the order first seen."""
    groups: dict[tuple, list[Record]] = {}
    for r in records:
        key = tuple(sorted((k, repr(v)) for k, v in r.conditions.items()))
        groups.setdefault(key, []).append(r)
    return list(groups.values())


class Validation:
    """``score(model, sim) -> RMSE`` out of sample, by ``kind`` (``VALIDATION``; module docstring).

    Raises ``ValueError`` for an unknown kind, and for ``"loco"`` when the training records hold fewer than
    two operating points (nothing to leave out)."""

    def __init__(self, kind: str, train: Sequence[Record], val: Sequence[Record], *, lm_steps: int,
                 box_factor: float):
        if kind not in VALIDATION:
            raise ValueError(f"unknown validation {kind!r}; choose one of {list(VALIDATION)}")
        self.kind, self.train, self.val = kind, list(train), list(val)
        self.lm_steps, self.box_factor = lm_steps, box_factor
        self.groups = condition_groups(self.train) if kind == "loco" else []
        if kind == "loco" and len(self.groups) < 2:
            raise ValueError("validation 'loco' leaves one operating condition of the training records out at a "
                             f"time, but all {len(self.train)} training records share one; use "
                             "validation 'records' (the validation records' error)")

    @property
    def out_of_sample(self) -> bool:
        """Whether the score is out of sample (validation records, or leave-one-condition-out), not the
        training error."""
        return bool(self.val) or self.kind == "loco"

    @property
    def scored(self) -> str:
        """Which error the score is, in words (for the report)."""
        if self.kind == "loco":
            what = f"leave-one-condition-out over {len(self.groups)} training operating points"
            return what + (" and the validation records" if self.val else "")
        return "the validation records" if self.val else "the training records (no validation records)"

    def __call__(self, model, sim: dict) -> float:
        if self.kind == "records":
            return rmse_on(model, self.val or self.train, sim)
        records, preds = list(self.val), predict(model, self.val, sim)
        for i, out in enumerate(self.groups):
            rest = [r for j, g in enumerate(self.groups) if j != i for r in g]
            try:
                fold = polish(copy.deepcopy(model), rest, sim, self.lm_steps, self.box_factor,
                              step_doubling=False)
            except (ValueError, RuntimeError):
                return math.inf
            records += out
            preds += predict(fold.model, out, sim)
        rmse = record_metrics(records, preds).get("rmse", math.inf)
        return rmse if math.isfinite(rmse) else math.inf
