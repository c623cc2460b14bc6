"""Training data: condition splits, decimation, sequence windows with warm-up, normalisation, loaders.

``RecordDataModule`` is the one ``LightningDataModule`` of hybridhyst. It splits a ``RecordSet`` by
operating condition (``held_out`` → test, ``val`` → validation, the rest → training), thins every record
to a training grid, cuts training records into overlapping windows whose first ``warmup`` samples are
excluded from the loss (the simulated state forgets its start there), and fits a ``Normaliser`` on the
training records only (seed 003, Sec. 3.2). Validation, test and prediction loaders give whole records,
one per batch, so every metric is computed on complete loops in physical units.

A batch is a dict of tensors, ``(batch, time)`` unless noted:
``t`` [s] (time since the record's start), ``u``, ``du``, ``ddu``, ``dddu`` (excitation x and its first
three rates from second-order differences, as ``simulate`` computes the first two), ``y`` (measured
response), ``mask`` (1 where the loss counts), ``cond`` ``(batch, n_conditions)`` (the numeric
conditions in ``condition_names``), ``y0`` ``(batch, 2)`` (measured response and its rate at the window
start), ``index`` ``(batch,)`` (record number within the split) and ``start`` (first sample).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import lightning as L
import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset

from .decimate import decimate, decimate_all, decimation_factors
from .records import Record, RecordSet

__all__ = ["Normaliser", "RecordDataModule", "condition_label", "prepare_record"]


def condition_label(record: Record, names: Sequence[str] | None = None) -> str:
    """A readable label of a record's operating condition, e.g. ``"frequency_hz=1, amplitude_in=1.5"``;
    ``names`` picks the conditions shown (default: all non-empty ones); the record name if none."""
    keys = [k for k in (names or record.operating) if record.conditions.get(k) not in ("", None)]
    parts = [f"{k}={record.conditions[k]:g}" if isinstance(record.conditions[k], numbers.Number)
             else f"{k}={record.conditions[k]}" for k in keys]
    return ", ".join(parts) or record.name


def prepare_record(record: Record, factor: int = 1, controls: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """Thin ``record`` to every ``factor``-th sample; channels t (from 0), u, du, ddu, dddu and y (float64),
    ``controls`` ``(time, C)``: the record's control channels named ``controls``, in that order, and ``scored``:
    false at the leading samples that are simulated, not scored (``Record.warmup``, thinned with it)."""
    (r,) = decimate_all([record], factor, "training")
    t = np.asarray(r.t, dtype=np.float64) - float(r.t[0])
    u = np.asarray(r.x, dtype=np.float64)
    du = np.gradient(u, t, edge_order=2)
    ddu = np.gradient(du, t, edge_order=2)
    dddu = np.gradient(ddu, t, edge_order=2)
    ctl = np.stack([r.controls[c] for c in controls], axis=1) if controls else np.zeros((len(t), 0))
    return {"t": t, "u": u, "du": du, "ddu": ddu, "dddu": dddu, "y": np.asarray(r.y, dtype=np.float64),
            "controls": ctl, "scored": np.arange(len(t)) >= r.warmup}


@dataclass
class Normaliser:
    """Mean and standard deviation of each channel (t, u, du, ddu, y) and numeric condition, fitted on the
    training records only. ``scale(name, v)`` → (v − mean)/sd; ``unscale`` inverts it."""

    mean: dict[str, float] = field(default_factory=dict)
    sd: dict[str, float] = field(default_factory=dict)

    @classmethod
    def fit(cls, prepared: Sequence[dict], conditions: Sequence[Sequence[float]], names: Sequence[str],
            controls: Sequence[str] = ()):
        if not prepared:
            raise ValueError("cannot fit a normaliser on no training records")
        mean, sd = {}, {}
        for key in ("t", "u", "du", "ddu", "y"):
            v = np.concatenate([p[key] for p in prepared])
            mean[key], sd[key] = float(v.mean()), float(v.std())
        for j, name in enumerate(controls):  # control channels: over their samples
            v = np.concatenate([p["controls"][:, j] for p in prepared])
            mean[name], sd[name] = float(v.mean()), float(v.std())
        C = np.asarray(conditions, dtype=np.float64).reshape(len(prepared), len(names))
        for j, name in enumerate(names):
            mean[name], sd[name] = float(C[:, j].mean()), float(C[:, j].std())
        sd = {k: (v if v > 1e-12 * max(abs(mean[k]), 1.0) else 1.0) for k, v in sd.items()}  # constants: sd 1
        return cls(mean, sd)

    def scale(self, name: str, value):
        return (value - self.mean[name]) / self.sd[name]

    def unscale(self, name: str, value):
        return value * self.sd[name] + self.mean[name]

    def to_dict(self) -> dict:
        return {"mean": dict(self.mean), "sd": dict(self.sd)}

    @classmethod
    def from_dict(cls, d: Mapping) -> Normaliser:
        return cls(dict(d["mean"]), dict(d["sd"]))


class _Sequences(Dataset):
    """Windows ``(record, start)`` of length ``window`` (whole records when ``window`` is None)."""

    def __init__(self, prepared, cond, window: int | None, warmup: int, stride: int, keep: np.ndarray | None = None,
                 past: int = 0):
        self.prepared, self.cond, self.window, self.warmup, self.past = prepared, cond, window, warmup, int(past)
        if window is None:
            self.items = [(i, 0) for i in range(len(prepared))]
        else:
            self.items = []
            for i, p in enumerate(prepared):
                T = len(p["t"])
                starts = list(range(0, T - window + 1, stride))
                if starts and starts[-1] != T - window:
                    starts.append(T - window)  # the record's end is always covered
                self.items += [(i, s) for s in starts]
        if keep is not None:
            self.items = [self.items[k] for k in keep]

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, k: int) -> dict[str, torch.Tensor]:
        i, s = self.items[k]
        p = self.prepared[i]
        e = len(p["t"]) if self.window is None else s + self.window
        item = {key: torch.tensor(p[key][s:e]) for key in ("t", "u", "du", "ddu", "dddu", "y", "controls")}
        mask = torch.tensor(p["scored"][s:e], dtype=torch.float64)  # not the record's warm-up (``Record.warmup``)
        if self.window is not None and s > 0:
            mask[: self.warmup] = 0.0  # the state starts from rest: its first samples are not scored
        dy = np.gradient(p["y"][s: s + 3], p["t"][s: s + 3])[0] if e - s >= 3 else 0.0
        item.update(mask=mask, cond=torch.as_tensor(self.cond[i], dtype=torch.float64),
                    y0=torch.tensor([p["y"][s], dy], dtype=torch.float64), index=torch.tensor(i),
                    start=torch.tensor(s))
        if self.past:  # (u, y) over the `past` samples before the window, the first sample repeated before a record
            rows = np.clip(np.arange(s - self.past, s), 0, None)
            item["past"] = torch.as_tensor(np.stack([p["u"][rows], p["y"][rows]], axis=1), dtype=torch.float64)
        return item


class EpochShuffle(torch.utils.data.Sampler):
    """A random order that depends only on (seed, epoch): Lightning calls ``set_epoch`` before each epoch, so
    a run resumed from a checkpoint sees the same batches as an uninterrupted one."""

    def __init__(self, n: int, seed: int = 0):
        self.n, self.seed, self.epoch = int(n), int(seed), 0

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def __iter__(self):
        g = torch.Generator().manual_seed(self.seed * 1_000_003 + self.epoch)
        return iter(torch.randperm(self.n, generator=g).tolist())

    def __len__(self) -> int:
        return self.n


class RecordDataModule(L.LightningDataModule):
    """Condition-split records as training windows and whole validation/test records.

    Parameters
    ----------
    records : the ``RecordSet`` (or list of records).
    held_out, val : condition queries for the test and validation records (``RecordSet.split``), e.g.
        ``{"amplitude_in": [1.0]}``; None holds out nothing.
    conditions : numeric conditions fed to networks and parameter functions (e.g. ``["tension_lb"]``); a control
        channel named here (``Record.controls``) reaches the networks at every sample (``batch["controls"]``
        carries every control of the records, ``(batch, time, C)`` in the order of ``control_names``).
    window : training window length [samples on the thinned grid]; None trains on whole records.
    warmup : leading samples of each window (after the record's first) excluded from the loss.
    past : samples of (u, y) before each window given with it (``batch["past"]``, ``(batch, past, 2)``), for an
        encoder of the window's start state (``encoder.past`` of ``hybridhyst-train``); 0: none.
    stride : step between window starts (default ``window // 2``).
    samples_per_cycle, downsample, frequency_condition : thinning (``decimation_factors``).
    batch_size : windows per training batch; train_fraction : fraction of the training windows kept
        (a seeded random subset, for data-efficiency curves; the normaliser sees only the samples those
        windows cover); seed : its random seed (and of the batch order, fixed per epoch).
    label_conditions : conditions named in the per-condition labels (default: all).
    """

    def __init__(self, records, held_out=None, val=None, conditions: Sequence[str] = (), window: int | None = 256,
                 warmup: int = 32, stride: int | None = None, samples_per_cycle: int | None = None,
                 downsample: int = 1, frequency_condition: str = "frequency_hz", batch_size: int = 16,
                 train_fraction: float = 1.0, seed: int = 0, label_conditions: Sequence[str] | None = None,
                 num_workers: int = 0, past: int = 0):
        super().__init__()
        records = records if isinstance(records, RecordSet) else RecordSet(list(records))
        if len(records) == 0:
            raise ValueError("the data module got no records; check the data selection")
        if not 0.0 < float(train_fraction) <= 1.0:
            raise ValueError(f"train_fraction must be in (0, 1], got {train_fraction}")
        if window is not None and (int(window) < 3 or int(warmup) >= int(window)):
            raise ValueError(f"window ({window}) must be >= 3 samples and longer than warmup ({warmup})")
        self.split = records.split(held_out=held_out, val=val)
        self.control_names = sorted({k for r in records for k in r.controls})
        lacking = [r.name for r in records if set(r.controls) != set(self.control_names)]
        if lacking:
            raise ValueError(f"records {lacking[:5]} lack some of the control channels {self.control_names}; give "
                             "every record the same data.controls")
        self.condition_names = [c for c in conditions if c not in self.control_names]
        self.network_controls = [c for c in conditions if c in self.control_names]
        self.window = None if window is None else int(window)
        self.warmup, self.batch_size, self.num_workers = int(warmup), int(batch_size), int(num_workers)
        if int(past) < 0:
            raise ValueError(f"past must be >= 0 samples, got {past}")
        self.past = int(past)
        self.stride = int(stride) if stride else max(1, (self.window or 2) // 2)
        self.train_fraction, self.seed = float(train_fraction), int(seed)
        self.label_conditions = label_conditions
        self.factors = decimation_factors(records, samples_per_cycle, downsample, frequency_condition,
                                          "datamodule.frequency_condition")
        self.prepared = {name: [prepare_record(r, self.factors[r.name], self.control_names)
                                for r in getattr(self.split, name)] for name in ("train", "val", "test")}
        self.cond = {name: [self._condition_vector(r) for r in getattr(self.split, name)]
                     for name in ("train", "val", "test")}
        short = [(r.name, len(p["t"])) for r, p in zip(self.split.train, self.prepared["train"])
                 if self.window is not None and len(p["t"]) < self.window]
        if short:
            shortest = min(n for _, n in short)
            raise ValueError(f"training records shorter than the window ({self.window} samples after thinning): "
                             f"{short}; set datamodule.window below {shortest} (and datamodule.warmup below "
                             "that), thin less (datamodule.samples_per_cycle, datamodule.downsample), or "
                             "datamodule.window=null for whole records")
        self._train = self._make_train()
        kept = sorted({i for i, _ in self._train.items})  # records with at least one kept window
        self.normaliser = Normaliser.fit([self._kept_samples(i) for i in kept], [self.cond["train"][i] for i in kept],
                                         self.condition_names, self.control_names)

    def _kept_samples(self, i: int) -> dict[str, np.ndarray]:
        """The samples of training record i covered by the kept windows (train_fraction < 1 sees only them)."""
        p = self.prepared["train"][i]
        if self.window is None:
            return p
        mask = np.zeros(len(p["t"]), dtype=bool)
        for j, s in self._train.items:
            if j == i:
                mask[s: s + self.window] = True
        return {k: v[mask] for k, v in p.items()}

    def _condition_vector(self, r: Record) -> list[float]:
        out = []
        for name in self.condition_names:
            v = r.conditions.get(name)
            if not isinstance(v, numbers.Number) or isinstance(v, bool) or not math.isfinite(float(v)):
                raise ValueError(f"record {r.name!r}: condition {name!r} is {v!r}, not a number; "
                                 f"only numeric conditions can be network or parameter-function inputs")
            out.append(float(v))
        return out

    def _make_train(self) -> _Sequences:
        full = _Sequences(self.prepared["train"], self.cond["train"], self.window, self.warmup, self.stride)
        keep = None
        if self.train_fraction < 1.0:
            n = max(1, round(self.train_fraction * len(full)))
            keep = np.sort(np.random.default_rng(self.seed).choice(len(full), n, replace=False))
        return _Sequences(self.prepared["train"], self.cond["train"], self.window, self.warmup, self.stride, keep,
                          self.past)

    # -- what modules need to know ------------------------------------------------------------------
    def records(self, split: str) -> RecordSet:
        return getattr(self.split, split)

    def training_records(self) -> list[Record]:
        """The training records as training sees them: thinned by this module's factors; with
        ``train_fraction`` < 1 only the kept windows (one record each, named ``<record>@<start>``), so that a
        model fitted to them (the identified start of a nominal) sees no more data than the network."""
        records = list(self.split.train)
        thin = [decimate(r, self.factors[r.name]) for r in records]
        if self.train_fraction >= 1.0:
            return thin
        if self.window is None:
            return [thin[i] for i in sorted({i for i, _ in self._train.items})]
        out = []
        for i, s in self._train.items:
            r, f = records[i], self.factors[records[i].name]
            out.append(r.slice(s * f, (s + self.window) * f, step=f, name=f"{r.name}@{s}"))
        return out

    def labels(self, split: str) -> list[str]:
        """Condition label of each record of ``split`` (per-condition metrics)."""
        return [condition_label(r, self.label_conditions) for r in getattr(self.split, split)]

    @property
    def units(self) -> dict:
        return dict(self.split.train.records[0].units)

    # -- loaders -----------------------------------------------------------------------------------
    def whole(self, split: str) -> _Sequences:
        return _Sequences(self.prepared[split], self.cond[split], None, 0, 1, past=self.past)

    def train_dataloader(self):
        return DataLoader(self._train, batch_size=self.batch_size, sampler=EpochShuffle(len(self._train), self.seed),
                          num_workers=self.num_workers, drop_last=False)

    def _whole_loader(self, split: str):
        return DataLoader(self.whole(split), batch_size=1, shuffle=False, num_workers=self.num_workers)

    def val_dataloader(self):
        return self._whole_loader("val" if len(self.split.val) else "train")

    def test_dataloader(self):
        return self._whole_loader("test")

    def predict_dataloader(self):
        return self._whole_loader("test")
