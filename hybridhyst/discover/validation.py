"""The loop's out-of-sample error of a fitted model: what every acceptance, comparison and removal is judged on.

Three ways (``discover(validation=...)``):

- ``"records"``: the RMSE on the validation records (on the training records when there are none). One
  simulation per model, at the sub-steps those records need (``simulated``); the validation records are of
  whatever kind the user holds out, often the same kind as the training records.
- ``"loco"``: leave one operating condition out. The training records are grouped by their operating
  conditions (records that share every condition value are one group); for each group the model is
  refitted on the other groups (Levenberg–Marquardt from its fitted values, every coordinate free, at its
  own sub-steps) and simulated on the held-out group. The error pools every group's held-out residual,
  and the validation records' residuals under the model fitted on all training records. A parameter made a
  function of a condition must then predict a level it was not fitted on, and an effect must carry over
  to an operating point it did not see; costs one refit per group for each model scored.
- ``"both"``: the two errors side by side, each judged on its own (``Score``): the validation records' RMSE
  and the leave-one-condition-out RMSE of the training groups alone. A change must lower *both* by the
  margin to be accepted, and may raise neither by more than the tolerance to be a removal. Each error
  alone has its failure mode: validation records of the training records' kind reward what those records
  share (an offset of one campaign), and a model refitted without one operating point is a poorer
  predictor whose refits a flexible term can steady. An effect must help on both.

Every score is a ``Score``: a float (the validation records' RMSE, or for ``"loco"`` the pooled
leave-one-out RMSE) that carries every error it stands for in ``parts``; ``improves`` and ``within`` compare
two scores part by part.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence

import numpy as np
import torch

from ..analysis.metrics import split_metrics
from ..data.records import Record
from ..simulate import SimulationSettings, simulate, simulate_resolved
from .fitting import polish, side_by_side

__all__ = ["VALIDATION", "Score", "Validation", "condition_groups", "errors", "improves", "parts", "predict",
           "record_metrics", "rmse_on", "within"]

VALIDATION = ("records", "loco", "both")


class Score(float):
    """An out-of-sample RMSE that may stand for several (``parts``: ``{name: RMSE}``, the first is the value)."""

    def __new__(cls, parts: dict[str, float]):
        parts = {k: (float(v) if math.isfinite(float(v)) else math.inf) for k, v in parts.items()}
        self = super().__new__(cls, next(iter(parts.values())))
        self.parts = parts
        return self

    def __reduce__(self):
        return Score, (self.parts,)

    @property
    def key(self) -> float:
        """One number to rank scores by: the geometric mean of the parts."""
        vals = list(self.parts.values())
        return math.inf if math.inf in vals else math.prod(vals) ** (1 / len(vals))  # one part: the value itself


def errors(score) -> list[float]:
    """The errors a score stands for (one for a plain number)."""
    return list(score.parts.values()) if isinstance(score, Score) else [float(score)]


def parts(**scores) -> dict:
    """``{"parts_<name>": {error: RMSE}}`` for each score that stands for several errors (for the report);
    nothing for a score of one."""
    return {f"parts_{k}": dict(v.parts) for k, v in scores.items() if len(getattr(v, "parts", ())) > 1}


def improves(new, old, margin: float) -> bool:
    """Whether ``new`` is below ``(1 - margin)`` times ``old`` in every part."""
    return all(n < (1 - margin) * o for n, o in zip(errors(new), errors(old), strict=True))


def within(new, old, tol: float) -> bool:
    """Whether ``new`` is at most ``(1 + tol)`` times ``old`` in every part."""
    return all(n <= (1 + tol) * o for n, o in zip(errors(new), errors(old), strict=True))


def simulated(model, records, sim: SimulationSettings, resolve: bool = True) -> tuple[list[np.ndarray], int]:
    """The model's response to each record (first output channel) and the sub-steps it took: ``sim``'s
    (the fit's, resolved on its training records) or more, where these records need finer steps
    (``simulate.simulate_resolved``: a held-out condition may make a state stiffer than any training one).
    ``resolve=False``: at ``sim``'s sub-steps (the records the model was fitted and resolved on: its training
    error is then the fit's own)."""
    if not records:
        return [], sim.substeps
    if not resolve:
        with torch.no_grad():
            out = simulate(model, list(records), settings=sim)
        return [o[:, 0].numpy() for o in out], sim.substeps
    out, substeps, _ = simulate_resolved(model, list(records), settings=sim)
    return [o[:, 0].numpy() for o in out], substeps


def predict(model, records, sim: SimulationSettings, resolve: bool = True) -> list[np.ndarray]:
    """The model's response to each record (first output channel), at the sub-steps they need (``simulated``)."""
    return simulated(model, records, sim, resolve)[0]


def record_metrics(records, preds, labels: Sequence[str] | None = None) -> dict:
    """Pooled RMSE and RMSE per condition label (``analysis.split_metrics``); {} without records."""
    from ..data.datamodule import condition_label

    out = split_metrics([{"condition": condition_label(r, labels), "y": np.asarray(r.y), "y_pred": p,
                          "warmup": r.warmup} for r, p in zip(records, preds)])
    if out:
        out["per_condition"] = {k: v["rmse"] for k, v in out["per_condition"].items()}
    return out


def rmse_on(model, records, sim: SimulationSettings, resolve: bool = True) -> float:
    """The model's pooled RMSE on ``records`` (inf without records; ``resolve`` as in ``simulated``)."""
    if not records:
        return math.inf
    return record_metrics(records, predict(model, records, sim, resolve)).get("rmse", math.inf)


def condition_groups(records: Sequence[Record]) -> list[list[Record]]:
    """Records grouped by their operating conditions (every condition's value, ``Record.operating``; records
    that share all of them are one operating point), in the order first seen."""
    groups: dict[tuple, list[Record]] = {}
    for r in records:
        key = tuple(sorted((k, repr(v)) for k, v in r.operating.items()))
        groups.setdefault(key, []).append(r)
    return list(groups.values())


class Validation:
    """``score(model, sim) -> Score`` out of sample, by ``kind`` (``VALIDATION``; module docstring).

    Raises ``ValueError`` for an unknown kind, and for ``"loco"`` when the training records hold fewer than two
    operating points (nothing to leave out); ``"both"`` is then ``"records"``, and says so in ``scored``."""

    def __init__(self, kind: str, train: Sequence[Record], val: Sequence[Record], *, lm_steps: int,
                 box_factor: float, workers: int = 1):
        if kind not in VALIDATION:
            raise ValueError(f"unknown validation {kind!r}; choose one of {list(VALIDATION)}")
        self.kind, self.train, self.val = kind, list(train), list(val)
        self.lm_steps, self.box_factor, self.workers = lm_steps, box_factor, workers
        self.groups = condition_groups(self.train) if kind != "records" else []
        if kind == "both" and len(self.groups) < 2:  # nothing to leave out: the validation records judge alone
            self.groups = []
        elif kind == "loco" and len(self.groups) < 2:
            raise ValueError(f"validation {kind!r} leaves one operating condition of the training records out at a "
                             f"time, but all {len(self.train)} training records share one; use "
                             "validation 'records' (the validation records' error)")

    @property
    def out_of_sample(self) -> bool:
        """Whether the score is out of sample (validation records, or leave-one-condition-out), not the
        training error."""
        return bool(self.val) or bool(self.groups)

    @property
    def scored(self) -> str:
        """Which error the score is, in words (for the report)."""
        loco = f"leave-one-condition-out over {len(self.groups)} training operating points"
        records = "the validation records" if self.val else "the training records (no validation records)"
        if self.kind == "loco":
            return loco + (" and the validation records" if self.val else "")
        if self.kind == "records" or not self.groups:
            return records + (" (one training operating point: nothing to leave out)" if self.kind == "both" else "")
        return f"{records} and, each on its own, {loco}"

    def __call__(self, model, sim: SimulationSettings) -> Score:
        if self.kind == "loco":
            return Score({"loco": self._loco(model, sim, list(self.val))})
        # "both" has groups unless it fell back; without validation records, the training error the fit resolved
        records = {"records": rmse_on(model, self.val or self.train, sim, resolve=bool(self.val))}
        return Score({**records, "loco": self._loco(model, sim, [])} if self.groups else records)

    def _loco(self, model, sim: SimulationSettings, val: list) -> float:
        """The pooled RMSE of each training group predicted by the model refitted on the others (the refits
        ``workers`` at a time), and of ``val`` predicted by the model itself."""
        def refit(i: int):
            rest = [r for j, g in enumerate(self.groups) if j != i for r in g]
            try:
                return polish(copy.deepcopy(model), rest, sim, self.lm_steps, self.box_factor,
                              step_doubling=False).model
            except (ValueError, RuntimeError):
                return None

        folds = side_by_side(refit, range(len(self.groups)), self.workers)
        if any(fold is None for fold in folds):
            return math.inf
        records, preds = list(val), predict(model, val, sim)
        for out, fold in zip(self.groups, folds):
            records += out
            preds += predict(fold, out, sim)
        rmse = record_metrics(records, preds).get("rmse", math.inf)
        return rmse if math.isfinite(rmse) else math.inf
