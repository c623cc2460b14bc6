"""Records of one data set that disagree in scale the way a unit mix does: ms among s, rad among deg.

Each reader reads every record with the same units (``units=``, ``data.units``) and converts nothing, so a
record exported in other units passes every per-record check. ``check_scales`` compares, per data set:

* the time column: each record's median sample interval and duration (per loading cycle when every record
  has a positive frequency condition, a name holding ``freq`` or ending ``_hz``);
* the input column: each record's amplitude (half its 0.5-99.5 % range; per unit of the amplitude condition
  when every record has a positive one, a name holding ``amp``).

A record is named when its value is a unit factor (1000 for ms/s; 57.3 for rad/deg, 1000 for m/mm, 25.4 for
in/mm) off the others' and no condition of it differs from theirs by about that factor:

* an **error** when most records agree (within ±25 % of their median: at least two, and more than half of
  the records) and the record is off theirs by the factor within 5 % (for time: the sample interval within
  5 %, the duration within 2×): nothing but a unit mix explains that;
* a **warning** (``UserWarning``) when the records vary more but one lies about the factor beyond all the
  others: it may be a real difference (a slower test, a smaller amplitude).

Legitimate spreads (BRFD: amplitudes 0.5/1/1.5 in and earthquake histories, 0.25-2 Hz at one sample rate;
sample rates scaled with the loading frequency) are explained by the conditions or are no unit factor.
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Sequence

import numpy as np

from .records import Record

__all__ = ["check_scales"]

# {factor: (the unit with the smaller numbers, the one with the larger)}
TIME_FACTORS = {1000.0: ("s", "ms")}
INPUT_FACTORS = {180 / math.pi: ("rad", "deg"), 1000.0: ("m", "mm"), 25.4: ("in", "mm")}
AGREE, FITS, DURATION = math.log(1.25), math.log(1.05), math.log(2.0)


def check_scales(records: Sequence[Record], time: str | None, input: str) -> None:
    """Raise (or warn) for a record whose time or input scale differs from the others' by a unit factor.

    ``time`` and ``input`` describe the columns in messages (``"column 't'"``); ``time=None`` (time made from
    the sample rate) skips the time check. Fewer than three records are not compared.
    """
    records = list(records)
    if len(records) < 3:
        return
    if time is not None:
        per = _per_unit(records, ("freq", "_hz"))
        dt = np.array([r.dt for r in records]) * per
        span = np.array([r.t[-1] - r.t[0] for r in records]) * per
        _compare(records, dt, TIME_FACTORS, f"time {time}", "sample interval", span)
    amplitude = np.array([np.diff(np.quantile(r.x, [0.005, 0.995]))[0] / 2 for r in records])
    _compare(records, amplitude / _per_unit(records, ("amp",)), INPUT_FACTORS, f"input {input}", "amplitude")


def _positive(v) -> bool:
    return isinstance(v, numbers.Number) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _per_unit(records: list[Record], words: tuple[str, ...]) -> np.ndarray:
    """The values of the first condition named like ``words`` that is positive in every record, else ones."""
    for name in dict.fromkeys(k for r in records for k in r.conditions):
        if any(w in name.lower() for w in words) and all(_positive(r.conditions.get(name)) for r in records):
            return np.array([float(r.conditions[name]) for r in records])
    return np.ones(len(records))


def _explained(records: list[Record], i: int, others: np.ndarray, ratio: float) -> bool:
    """Whether a numeric condition of record i differs from the others' by about ``ratio`` (or its inverse)."""
    for name, v in records[i].conditions.items():
        ref = [records[j].conditions.get(name) for j in np.flatnonzero(others)]
        if _positive(v) and ref and all(_positive(c) for c in ref):
            off = abs(math.log(v / float(np.median(ref))))
            if abs(off - abs(math.log(ratio))) < math.log(2.0):
                return True
    return False


def _compare(records, values, factors, column: str, what: str, span=None) -> None:
    """Judge each record that the majority (within ±25 % of the median, at least two and more than half of the
    records) leaves out against it; without such a majority, each record against all the others."""
    if not np.all(np.isfinite(values) & (values > 0)):
        return
    logs = np.log(values)
    agree = np.abs(logs - np.median(logs)) <= AGREE
    majority = bool(agree.sum() >= 2 and agree.sum() > len(records) / 2)
    for i in np.flatnonzero(~agree) if majority else range(len(records)):
        others = agree if majority else np.arange(len(records)) != i
        ratio = math.exp(logs[i] - float(np.median(logs[others])))
        for factor, units in factors.items():
            off = abs(abs(math.log(ratio)) - math.log(factor))
            if off > math.log(2.0) or _explained(records, i, others, ratio):
                continue
            if span is not None and abs(abs(math.log(span[i] / np.median(span[others]))) - math.log(factor)) \
                    > DURATION:
                continue
            shown = f"{values[i]:.4g} against {np.median(values[others]):.4g}"
            if majority and off <= FITS:
                raise ValueError(_message(records[i], column, what, ratio, factor, units, shown, error=True))
            if np.abs(logs[others] - logs[i]).min() >= math.log(factor / 2):
                warnings.warn(_message(records[i], column, what, ratio, factor, units, shown, error=False),
                              UserWarning, stacklevel=5)
                break


def _message(record: Record, column: str, what: str, ratio: float, factor: float, units: tuple[str, str],
             shown: str, error: bool) -> str:
    fewer, more = units
    mine, theirs = (fewer, more) if ratio < 1 else (more, fewer)
    convert = f"{'multiply' if ratio < 1 else 'divide'} it by {factor:.4g}"
    where = f"file {record.source!r}, record {record.name!r}" if record.source else f"record {record.name!r}"
    if error:
        return (f"{where}: {column} is in {mine}, not {theirs}? its {what} is {ratio:.4g}× the other records' "
                f"({shown}), a unit factor that no condition explains; every record of a data set shares one unit "
                f"per column (data.units), and nothing is converted: {convert} (convert the record to {theirs}), "
                "or give the condition that makes it differ")
    return (f"{where}: {column} in {mine}, not {theirs}? its {what} is {ratio:.4g}× the other records' ({shown}); "
            f"if so, {convert} (data.units is one unit per column for every record)")
