"""Records → batches: the one place where a list of records becomes tensors for the simulator.

Records of the same length travel as one batch; each row keeps its own time grid, so records with jittered
or shifted timestamps are simulated on their own samples (a batch never borrows one record's grid for the
others). Used by ``simulate`` (records in, one output per record), ``identify.RecordsProblem`` (population ×
records) and the training modules.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["RecordBatch", "numeric_conditions", "record_batches", "record_channel", "record_controls"]


@dataclass
class RecordBatch:
    """Records of one length as tensors.

    index : positions of these records in the list given to ``record_batches``.
    t : ``(R, T)`` sample times, one row per record; inputs : ``(R, T, C)`` the input channels;
    y : ``(R, T)`` the responses; conditions : ``{name: (R,)}`` numeric conditions every record has.
    """

    index: list[int]
    t: torch.Tensor
    inputs: torch.Tensor
    y: torch.Tensor
    conditions: dict[str, torch.Tensor]


def record_channel(record, channel: str) -> np.ndarray:
    """One channel of a record: ``"x"`` (the excitation) or an extra channel such as ``"velocity"``."""
    if channel == "x":
        return record.x
    if channel in record.extra:
        return record.extra[channel]
    raise ValueError(f"record {record.name!r} has no channel {channel!r}; it has x, y and {sorted(record.extra)}")


def numeric_conditions(records: Sequence, dtype=torch.float64) -> dict[str, torch.Tensor]:
    """``{name: (R,)}`` for every condition that all ``records`` give as a number (categorical ones, such as
    a test kind, and conditions some records lack are not model inputs)."""
    keys = sorted({k for r in records for k in r.conditions})
    out = {}
    for k in keys:
        vals = [r.conditions.get(k) for r in records]
        if all(isinstance(v, numbers.Number) and not isinstance(v, bool) for v in vals):
            out[k] = torch.tensor([float(v) for v in vals], dtype=dtype)
    return out


def record_controls(records: Sequence, dtype=torch.float64) -> dict[str, torch.Tensor]:
    """``{name: (R, T)}`` for every control channel all ``records`` (of one length) carry; one that only some
    carry is an error (a model fitted to both would read it in some records and not in others)."""
    names = sorted({k for r in records for k in r.controls})
    lacking = {k: [r.name for r in records if k not in r.controls] for k in names}
    for k, missing in lacking.items():
        if missing:
            raise ValueError(f"control channel {k!r} is missing from record(s) {missing[:5]}; give every record the "
                             "same control channels (data.controls)")
    return {k: torch.as_tensor(np.stack([r.controls[k] for r in records]), dtype=dtype) for k in names}


def record_batches(records: Sequence, input_channels: Sequence[str] = ("x",),
                   dtype: torch.dtype = torch.float64) -> list[RecordBatch]:
    """Group ``records`` by length into batches (in order of first appearance)."""
    groups: dict[int, list[int]] = {}
    for i, r in enumerate(records):
        groups.setdefault(len(r), []).append(i)
    out = []
    for idx in groups.values():
        group = [records[i] for i in idx]
        inputs = np.stack([np.stack([record_channel(r, c) for c in input_channels], -1) for r in group])
        out.append(RecordBatch(index=idx, t=torch.as_tensor(np.stack([r.t for r in group]), dtype=dtype),
                               inputs=torch.as_tensor(inputs, dtype=dtype),
                               y=torch.as_tensor(np.stack([r.y for r in group]), dtype=dtype),
                               conditions={**numeric_conditions(group, dtype), **record_controls(group, dtype)}))
    return out
