"""Measured or simulated loops: ``Record`` (one test) and ``RecordSet`` (many, with a conditions table)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

__all__ = ["TRAVEL_BEFORE", "Record", "RecordSet", "validate_channels", "with_travel_before"]

# the condition that says how far the input travelled before a record started (``with_travel_before``)
TRAVEL_BEFORE = "travel_before"


def _rows(mask: np.ndarray, rows: np.ndarray | None = None, limit: int = 5) -> str:
    idx = np.flatnonzero(mask) if rows is None else np.asarray(rows)[np.asarray(mask, dtype=bool)]
    if len(idx) == 0:
        return ""
    # group consecutive rows into ranges: "120-122, 400"
    groups, start, prev = [], idx[0], idx[0]
    for i in idx[1:]:
        if i != prev + 1:
            groups.append((start, prev))
            start = i
        prev = i
    groups.append((start, prev))
    text = ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in groups[:limit])
    return text + (f" and {len(groups) - limit} more ranges" if len(groups) > limit else "")


def _plain(value):
    """numpy scalars -> Python scalars, so conditions print as 0.5, not np.float64(0.5)."""
    return value.item() if isinstance(value, np.generic) else value


def validate_channels(where: str, channels: dict, labels: dict | None = None, rows: np.ndarray | None = None,
                      time: str = "t") -> dict[str, np.ndarray]:
    """Check the channels of one record and return them as float64 arrays.

    Parameters
    ----------
    where : what the record is, for messages (e.g. ``"file 'a.csv', record 'p=0.05'"``).
    channels : ``{channel: array (time,)}``; ``time`` names the time channel.
    labels : ``{channel: text}`` naming a channel in messages (default ``"channel 'x'"``), e.g.
        ``"column 'torque'"`` when reading a file.
    rows : row numbers reported in messages for each sample (default ``0 .. time-1``), e.g. the rows
        of the file the samples came from.

    Raises
    ------
    ValueError
        Naming the record, the channel and the offending rows, for a non-1-D channel, mismatched
        lengths, no samples, NaN/inf values, values absurd for the record (``ABSURD``), duplicate
        timestamps or time not increasing.
    """
    labels = {k: (labels or {}).get(k, f"channel {k!r}") for k in channels}
    arrays = {}
    for key, arr in channels.items():
        a = np.asarray(arr, dtype=np.float64)
        if a.ndim != 1:
            raise ValueError(f"{where}: {labels[key]} must be one-dimensional, got shape {a.shape}")
        arrays[key] = a
    n = len(arrays[time])
    for key, a in arrays.items():
        if len(a) != n:
            raise ValueError(
                f"{where}: {labels[key]} has {len(a)} samples but {labels[time]} has {n}; "
                "all channels of a record must have the same length"
            )
    if n == 0:
        raise ValueError(f"{where}: no samples; remove the empty record or check the file")
    rows = np.arange(n) if rows is None else np.asarray(rows)
    for key, a in arrays.items():
        bad = ~np.isfinite(a)
        if bad.any():
            kind = "NaN" if np.isnan(a[bad]).all() else "non-finite (NaN/inf)"
            raise ValueError(
                f"{where}: {labels[key]} has {int(bad.sum())} {kind} values (rows {_rows(bad, rows)}); "
                "drop or interpolate them"
            )
    for key, a in arrays.items():
        _check_magnitudes(where, a, labels[key], rows)
    dt = np.diff(arrays[time])
    if (dt == 0).any():
        raise ValueError(
            f"{where}: {labels[time]} has duplicate timestamps at rows {_rows(np.r_[dt == 0, False], rows)}; "
            "drop the repeated samples or average them"
        )
    if (dt < 0).any():
        raise ValueError(
            f"{where}: {labels[time]} is not increasing at rows {_rows(np.r_[dt < 0, False], rows)}; "
            "sort the samples by time or fix the time column"
        )
    return arrays


ABSURD = 1e8  # a value this many times the size of 99 % of its channel's values is a corrupt cell ...
ABSURD_FLOOR = 1e15  # ... if it is also this large: fill values (1e300, 3.4e38, 9.97e36), not an impulse among zeros


def _check_magnitudes(where: str, a: np.ndarray, label: str, rows: np.ndarray) -> None:
    """Refuse values absurd for their record: ``|v| > ABSURD · s``, where ``s`` is the size that 99 % of the
    channel's values stay within (the 99th percentile of ``|v|``; the median of the nonzero ``|v|`` when 99 %
    are zero). A 1e300 (or a float32 fill value such as 3.4e38) would otherwise pass every check and surface
    in training as an overflow blamed on the learning rate. It never fires on measurements: no sensor chain
    spans 1e8 (a 24-bit converter spans 1.7e7), and a legitimate spike is a few hundred times the signal, not
    a hundred million; the bundled records stay within 2.1 times their 99th percentile. Only values above
    ``ABSURD_FLOOR`` are refused, so an impulse among round-off zeros (99 % of the channel near 1e-16) is not."""
    size = np.abs(a)
    if len(size) < 2:
        return
    scale = float(np.quantile(size, 0.99, method="lower"))
    if scale == 0.0:
        nonzero = size[size > 0]
        scale = float(np.median(nonzero)) if len(nonzero) else 0.0
    bad = (size > ABSURD * scale) & (size > ABSURD_FLOOR) if scale > 0 else np.zeros(len(a), bool)
    if bad.any():
        raise ValueError(
            f"{where}: {label} has {int(bad.sum())} value(s) absurd for this record (rows {_rows(bad, rows)}, "
            f"e.g. {a[bad][0]:.4g}; 99 % of its values are within ±{scale:.4g}): a corrupt cell, an export error "
            "or a fill value for missing data; fix or remove those rows"
        )


@dataclass
class Record:
    """One test: time t [s], excitation x, response y, optional extra channels, conditions, units.

    Arrays are float64 numpy of shape ``(time,)``. ``units`` maps channel names ("t", "x", "y" and the
    extra channels) to unit strings. ``conditions`` maps condition names (e.g. ``pressure_mpa``,
    ``frequency_hz``) to numbers or strings. ``warmup``: leading samples that are simulated but not
    scored (a periodic steady-state record extended by its own last samples, so that a model started
    from rest has settled when scoring begins). ``controls`` maps control channels to arrays ``(time,)``: operating
    conditions that vary within the record (an MR damper's coil voltage, an underpressure schedule); a parameter
    function of one is evaluated at every integration stage. Validated on construction: a ``ValueError`` names the
    record, the channel and the offending rows, and says how to fix it.
    """

    name: str
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    conditions: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    source: str = ""
    warmup: int = 0
    controls: dict = field(default_factory=dict)

    def __post_init__(self):
        where = f"record {self.name!r}" + (f" ({self.source})" if self.source else "")
        clash = sorted(set(self.controls) & (set(self.extra) | set(self.conditions) | {"t", "x", "y"}))
        if clash:
            raise ValueError(f"{where}: {clash} named both a control channel and a condition or channel; a control "
                             "varies in time (data.controls), a condition is one value per record: give each once")
        controls = {f"control {k}": v for k, v in self.controls.items()}
        labels = {f"control {k}": f"control channel {k!r}" for k in self.controls}
        arrays = validate_channels(where, {"t": self.t, "x": self.x, "y": self.y, **self.extra, **controls}, labels)
        self.t, self.x, self.y = arrays["t"], arrays["x"], arrays["y"]
        self.extra = {k: arrays[k] for k in self.extra}
        self.controls = {k: arrays[f"control {k}"] for k in self.controls}
        self.conditions = {k: _plain(v) for k, v in dict(self.conditions).items()}
        self.units = {"t": "s", **dict(self.units)}
        whole = isinstance(self.warmup, (int, np.integer, float, np.floating)) and not isinstance(self.warmup, bool)
        if not whole or not math.isfinite(self.warmup) or float(self.warmup) != int(self.warmup):
            raise ValueError(f"{where}: warmup is a whole number of samples, got {self.warmup!r}")
        self.warmup = int(self.warmup)
        if not 0 <= self.warmup < len(self.t):
            raise ValueError(f"{where}: warmup must be in [0, {len(self.t)}) samples, got {self.warmup}")

    def __len__(self) -> int:
        return len(self.t)

    def scored(self, values) -> np.ndarray:
        """``values`` along this record's samples (time first: a residual, a feature) at its scored samples, those
        after the ``warmup``."""
        return np.asarray(values)[self.warmup:]

    @property
    def operating(self) -> dict:
        """The conditions that say where the record was run (its operating point): ``conditions`` without the
        ones derived from the records' history (``TRAVEL_BEFORE``)."""
        return {k: v for k, v in self.conditions.items() if k != TRAVEL_BEFORE}

    @property
    def dt(self) -> float:
        """Median sample interval [s]."""
        return float(np.median(np.diff(self.t))) if len(self.t) > 1 else float("nan")

    @property
    def uniform(self) -> bool:
        d = np.diff(self.t)
        return bool(len(d) == 0 or np.allclose(d, d[0], rtol=1e-6, atol=0))

    def slice(self, start: int | None = None, stop: int | None = None, name: str | None = None,
              step: int | None = None) -> Record:
        """Samples ``start:stop:step`` as a new record (same conditions and units; a ``travel_before`` condition,
        the input's travel before the record, grows by the travel of the samples left out before the slice)."""
        sl = slice(start, stop, step)
        first, _, stride = sl.indices(len(self))
        if stride < 1:
            raise ValueError(f"record {self.name!r}: a slice keeps the samples in time order (step >= 1), "
                             f"got step {stride}")
        warmup = max(0, -(-(self.warmup - first) // stride))  # warm-up samples kept in the slice
        conditions = self.conditions
        if TRAVEL_BEFORE in conditions and first > 0:  # (with_travel_before): the history of the slice's start
            conditions = {**conditions, TRAVEL_BEFORE: float(conditions[TRAVEL_BEFORE]) + _travel(self.x[: first + 1])}
        t = self.t[sl]
        return Record(
            name=name or self.name, t=t, x=self.x[sl], y=self.y[sl], conditions=conditions,
            units=self.units, extra={k: v[sl] for k, v in self.extra.items()}, source=self.source,
            warmup=min(warmup, max(len(t) - 1, 0)), controls={k: v[sl] for k, v in self.controls.items()},
        )

    def with_noise(self, sd: float, seed) -> Record:
        """This record with white Gaussian noise of standard deviation ``sd`` (in y's unit) added to ``y``.

        ``seed`` is anything ``numpy.random.default_rng`` takes: an int or a sequence of ints (a record's
        noise then depends only on it), or a ``Generator`` (its stream continues). ``sd`` = 0 adds nothing.
        """
        sd = float(sd)
        if not (math.isfinite(sd) and sd >= 0):
            raise ValueError(f"record {self.name!r}: noise sd must be a non-negative number, got {sd!r}")
        if sd == 0:
            return self
        y = self.y + np.random.default_rng(seed).normal(0.0, sd, size=len(self))
        return dataclasses.replace(self, y=y, source=f"{self.source}; + noise sd {sd:g}".lstrip("; "))

    def require_samples(self, n: int, what: str = "this model") -> None:
        if len(self) < n:
            raise ValueError(
                f"record {self.name!r} has {len(self)} samples but {what} needs at least {n}; "
                "use a longer record or drop this one"
            )


class RecordSet:
    """An ordered collection of records and a table of their conditions (one row per record)."""

    def __init__(self, records: list[Record], name: str = ""):
        records = list(records)
        names = [r.name for r in records]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"record set {name!r}: duplicate record names {dup}; names must be unique")
        self.records = records
        self.name = name

    @property
    def conditions(self) -> pd.DataFrame:
        """One row per record, indexed by record name, one column per condition."""
        rows = [dict(r.conditions) for r in self.records]
        return pd.DataFrame(rows, index=pd.Index([r.name for r in self.records], name="record"))

    def __len__(self) -> int:
        return len(self.records)

    def __iter__(self):
        return iter(self.records)

    def __getitem__(self, key):
        if isinstance(key, str):
            for r in self.records:
                if r.name == key:
                    return r
            raise KeyError(f"no record named {key!r} in record set {self.name!r}")
        if isinstance(key, slice):
            return RecordSet(self.records[key], self.name)
        return self.records[key]

    @property
    def names(self) -> list[str]:
        return [r.name for r in self.records]

    def __repr__(self) -> str:
        return f"RecordSet({self.name!r}, {len(self)} records, conditions={list(self.conditions.columns)})"

    # -- choosing records by condition ---------------------------------------------------------------
    def select(self, query=None, /, **conditions) -> RecordSet:
        """The records matching a condition query, in their original order.

        Parameters
        ----------
        query : optional callable ``query(record) -> bool``.
        **conditions : ``condition=value`` or ``condition=[values]``; a record must match every
            condition given (and one of the listed values of each). Numbers match within a relative
            tolerance of 1e-9.

        Examples
        --------
        >>> records.select(tension_lb=36, amplitude_in=[0.5, 1.5])          # doctest: +SKIP
        >>> records.select(lambda r: r.conditions["pressure_mpa"] > 0.03)    # doctest: +SKIP

        Raises
        ------
        ValueError
            If a condition is unknown or a listed value matches no record.
        """
        from .splits import condition_mask

        mask = np.ones(len(self), dtype=bool)
        if query is not None:
            mask &= condition_mask(self.records, query, "selected", self.name)
        if conditions:
            mask &= condition_mask(self.records, conditions, "selected", self.name)
        return self._subset(mask)

    def split(self, held_out=None, val=None):
        """Train / validation / test sets by operating condition.

        Parameters
        ----------
        held_out : a list of ``{condition: [values]}`` queries (a record matching any is held out), a single
            such mapping (the one-element list), a callable ``(record) -> bool``, or ``None`` / ``[]`` for
            none: the test records (the conditions the model must generalise to), e.g.
            ``[{"amplitude_in": [1.0]}]``.
        val : the same kind of query for validation records, chosen among those not held out.

        Returns
        -------
        ``Split(train, val, test)``, a named tuple of ``RecordSet``; every record is in exactly one.

        Raises
        ------
        ValueError
            If a query is malformed or empty (``{}`` would match every record), a held-out or validation value
            matches no record, or no training record is left.
        """
        from .splits import Split, as_queries, condition_mask

        held_out, val = as_queries(held_out, "held-out"), as_queries(val, "validation")
        test = condition_mask(self.records, held_out, "held-out", self.name)
        valid = condition_mask(self.records, val, "validation", self.name) & ~test
        train = ~(test | valid)
        if not train.any():
            raise ValueError(
                f"split of record set {self.name!r} leaves no training records: held_out={held_out!r} and "
                f"val={val!r} cover all {len(self)} records; hold out fewer condition values"
            )
        return Split(self._subset(train), self._subset(valid), self._subset(test))

    def _subset(self, mask: np.ndarray) -> RecordSet:
        return RecordSet([r for r, keep in zip(self.records, mask, strict=True) if keep], self.name)

    def to_frame(self) -> pd.DataFrame:
        """Long table: one row per sample with columns record, t, x, y, extra and control channels and conditions.

        ``frame.attrs["units"]`` holds the units of the first record. ``read_table(path,
        record="record", conditions=[...])`` reads a saved frame back.
        """
        frames = []
        for r in self.records:
            cols = {"record": np.full(len(r), r.name, dtype=object), "t": r.t, "x": r.x, "y": r.y, **r.extra,
                    **r.controls}
            frame = pd.DataFrame(cols)
            for key, value in r.conditions.items():
                frame[key] = value
            frames.append(frame)
        if not frames:
            return pd.DataFrame(columns=["record", "t", "x", "y"])
        out = pd.concat(frames, ignore_index=True)
        out.attrs["units"] = dict(self.records[0].units)
        return out


def _travel(x) -> float:
    """The distance an input travels along its samples, Σ |Δx|."""
    return float(np.abs(np.diff(np.asarray(x, float))).sum())


def with_travel_before(records, name: str = TRAVEL_BEFORE) -> list[Record]:
    """The records, in the order they were measured, each with the condition ``name``: the distance the input x
    travelled in the records before it, Σ |Δx| over their samples after any warm-up (x's unit; 0 for the first),
    less the record's own warm-up travel (simulated first, but not measured).
    A drift with travel that a device carries from record to record (a spring that softens with use, a seal that
    wears in) starts each record where the records before it left it (``TravelEffect``'s ``s0``); motion between
    records that was not recorded is not in it. New records; the given ones are unchanged. A record that already
    has the condition keeps its own value (a ``ValueError`` if only some have it)."""
    records = list(records.records if isinstance(records, RecordSet) else records)
    have = [name in r.conditions for r in records]
    if all(have):
        return records
    if any(have):
        raise ValueError(f"condition {name!r} is given for some records only ("
                         f"{', '.join(r.name for r, h in zip(records, have) if h)}); give it for every record or "
                         "for none (it is then the travel of the records before each, in their order)")
    out, before = [], 0.0
    for r in records:
        # a warm-up is simulated before the record's first scored sample but was not measured: the record's value
        # is the travel before its simulated start, so that its scored samples start at ``before``
        warm = _travel(r.x[: r.warmup + 1])
        out.append(dataclasses.replace(r, conditions={**r.conditions, name: before - warm}))
        before += _travel(r.x[r.warmup:])
    return out
