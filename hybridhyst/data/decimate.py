"""Decimation: the one way records are thinned to a coarser grid (fitting, identification, training, apps).

Every ``factor``-th sample is kept, without filtering: hysteresis loops are smooth at the scales used here,
and the simulator steps once per kept sample, so fewer samples are what make fits fast.
``decimation_factors`` picks a factor per record: about ``samples_per_cycle`` samples per loading cycle
when the record has a positive frequency condition (slow tests thin out more), else ``downsample``.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping, Sequence

from .records import Record

__all__ = ["decimate", "decimate_all", "decimation_factors"]


def decimate(record: Record, factor: int) -> Record:
    """Every ``factor``-th sample of ``record`` (samples 0, factor, 2·factor, ...); 1 returns it unchanged."""
    factor = int(factor)
    if factor < 1:
        raise ValueError(f"record {record.name!r}: decimation factor must be >= 1, got {factor}")
    return record if factor == 1 else record.slice(step=factor)


def decimate_all(records: Iterable[Record], factors: int | Mapping[str, int], what: str) -> list[Record]:
    """Each record thinned by ``factors`` (one factor, or one per record name; 1 where a name is missing),
    checked to keep at least 3 samples (``what`` names the use in the error)."""
    out = []
    for r in records:
        d = decimate(r, factors.get(r.name, 1) if isinstance(factors, Mapping) else factors)
        d.require_samples(3, f"{what} (after decimation)")
        out.append(d)
    return out


def decimation_factors(records: Sequence[Record], samples_per_cycle: int | None, downsample: int,
                       frequency: str = "frequency_hz") -> dict[str, int]:
    """Per-record factor: about ``samples_per_cycle`` samples per loading cycle when the record has a positive
    ``frequency`` condition, else every ``downsample``-th sample."""
    out = {}
    for r in records:
        f = r.conditions.get(frequency)
        if samples_per_cycle and isinstance(f, numbers.Number) and f > 0:
            out[r.name] = max(1, round(1.0 / (r.dt * f * samples_per_cycle)))
        else:
            out[r.name] = max(1, int(downsample))
    return out
