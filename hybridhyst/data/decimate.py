"""Decimation: the one way records are thinned to a coarser grid (fitting, identification, training, apps).

Every ``factor``-th sample is kept, without filtering: hysteresis loops are smooth at the scales used here,
and the simulator steps once per kept sample, so fewer samples are what make fits fast.
``decimation_factors`` picks a factor per record: about ``samples_per_cycle`` samples per loading cycle
when the record has a positive frequency condition (slow tests thin out more), else ``downsample``. The
condition's name is configured (``frequency_hz`` by default); a configured name that no record has is an error.
"""

from __future__ import annotations

import difflib
import numbers
from collections.abc import Iterable, Mapping, Sequence

from .records import Record

__all__ = ["DEFAULT_FREQUENCY", "decimate", "decimate_all", "decimation_factors"]

DEFAULT_FREQUENCY = "frequency_hz"  # the condition giving a record's loading frequency [Hz] unless configured


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
                       frequency: str | None = "frequency_hz",
                       setting: str = "the frequency_condition setting") -> dict[str, int]:
    """Per-record factor: about ``samples_per_cycle`` samples per loading cycle when the record has a positive
    ``frequency`` condition [Hz], else every ``downsample``-th sample.

    ``frequency`` names the condition (``None``, ``""`` or ``"none"``: no frequency condition, every record
    thinned by ``downsample``); ``setting`` names the config key that set it, for messages
    (``fit.frequency_condition``, ``thinning.frequency_condition``, ``datamodule.frequency_condition``).

    Raises
    ------
    ValueError
        When ``samples_per_cycle`` is set and the frequency condition would be silently ignored: a name other
        than the default ``frequency_hz`` that no record has, no record with a positive number in it, or the
        default absent while a condition named like a frequency (``freq_hz``) is there.
    """
    if frequency is not None and str(frequency).strip().lower() in ("", "none", "null"):
        frequency = None
    if samples_per_cycle and frequency is not None and records:
        _check_frequency_condition(records, str(frequency), setting)
    out = {}
    for r in records:
        f = r.conditions.get(frequency) if frequency is not None else None
        if samples_per_cycle and isinstance(f, numbers.Number) and not isinstance(f, bool) and f > 0:
            out[r.name] = max(1, round(1.0 / (r.dt * f * samples_per_cycle)))
        else:
            out[r.name] = max(1, int(downsample))
    return out


def _check_frequency_condition(records: Sequence[Record], frequency: str, setting: str) -> None:
    names = list(dict.fromkeys(k for r in records for k in r.conditions))
    fix = f"name the records' loading-frequency condition [Hz] with {setting}=<condition>, or set {setting}=null " \
          "to thin every record by the downsample setting"
    if any(frequency in r.conditions for r in records):
        values = [r.conditions[frequency] for r in records if frequency in r.conditions]
        if not any(isinstance(v, numbers.Number) and not isinstance(v, bool) and v > 0 for v in values):
            raise ValueError(f"{setting}={frequency!r}: the condition is not a positive number [Hz] in any record "
                             f"(values {list(dict.fromkeys(values))[:5]}), so no record would be thinned per loading "
                             f"cycle; {fix}")
        return
    alike = [k for k in names if "freq" in k.lower()] or difflib.get_close_matches(frequency, names, n=1, cutoff=0.6)
    if frequency != DEFAULT_FREQUENCY:
        hint = f"did you mean {alike[0]!r}? " if alike else ""
        raise ValueError(f"{setting}={frequency!r}: no record has a condition {frequency!r}; {hint}conditions are "
                         f"{names}; {fix}")
    if alike:
        raise ValueError(f"{setting}={frequency!r} (the default): no record has a condition {frequency!r}, but they "
                         f"have {alike[0]!r}, which is not used: those records would not be thinned per loading "
                         f"cycle; set {setting}={alike[0]} if it is the loading frequency [Hz], or {setting}=null")
