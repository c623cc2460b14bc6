"""Which conditions and control channels the loop may make parameters depend on, read from the records."""

from __future__ import annotations

import math

from ..data.records import Record, RecordSet
from ..data.splits import Split, check_conditions
from ..identify.space import condition_ranges

__all__ = ["as_records", "control_ranges", "numeric_conditions", "trend_conditions"]


def as_records(records) -> list[Record]:
    return list(records.records if isinstance(records, RecordSet) else records)


def numeric_conditions(records) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for r in records:
        for k, v in r.conditions.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)):
                out.setdefault(k, []).append(float(v))
    return {k: v for k, v in out.items() if len(v) == len(records)}


def trend_conditions(conditions, parts: Split) -> dict[str, list[float]]:
    """``{condition: training values}`` the loop may make parameters depend on: those named (each a number in
    every record, training, validation and test, with at least two training values; else a one-line error),
    or with ``True`` every condition that is a number in every record (one that a validation or test record
    lacks could not be evaluated there, so it is not offered)."""
    if not conditions:
        return {}
    train = list(parts.train)
    if isinstance(conditions, bool):
        usable = numeric_conditions([*train, *parts.val, *parts.test])
        return {k: v for k, v in numeric_conditions(train).items() if k in usable}
    if isinstance(conditions, str):
        raise ValueError(f"conditions must be true, false or a list of condition names, got {conditions!r}")
    check_conditions(parts, list(conditions), "discover conditions", min_train_values=2)
    values = numeric_conditions(train)
    return {c: values[c] for c in conditions if c in values}  # (the others are control channels: _controls)


def control_ranges(conditions, train) -> dict[str, list[float]]:
    """``{control: [lowest, highest]}`` over the training records of the control channels a parameter may follow:
    every control the records carry (``conditions`` true) or those named; none with ``conditions`` false."""
    if not conditions:
        return {}
    names = {c for c in train[0].controls if all(c in r.controls for r in train)}
    if not isinstance(conditions, bool):
        names &= set(conditions)
    return {c: list(span) for c, span in condition_ranges(train).items() if c in names}
