"""Measured or simulated loops: ``Record`` (one test) and ``RecordSet`` (many, with a conditions table)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

__all__ = ["Record", "RecordSet"]


def _rows(mask: np.ndarray, limit: int = 5) -> str:
    idx = np.flatnonzero(mask)
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


@dataclass
class Record:
    """One test: time t [s], excitation x, response y, optional extra channels, conditions, units.

    Arrays are float64 numpy of shape ``(time,)``. ``units`` maps channel names ("t", "x", "y" and the
    extra channels) to unit strings. ``conditions`` maps condition names (e.g. ``pressure_mpa``,
    ``frequency_hz``) to numbers or strings. Validated on construction: a ``ValueError`` names the
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

    def __post_init__(self):
        where = f"record {self.name!r}" + (f" ({self.source})" if self.source else "")
        channels = {"t": self.t, "x": self.x, "y": self.y, **self.extra}
        arrays = {}
        for key, arr in channels.items():
            a = np.asarray(arr, dtype=np.float64)
            if a.ndim != 1:
                raise ValueError(f"{where}: channel {key!r} must be one-dimensional, got shape {a.shape}")
            arrays[key] = a
        n = len(arrays["t"])
        for key, a in arrays.items():
            if len(a) != n:
                raise ValueError(
                    f"{where}: channel {key!r} has {len(a)} samples but time has {n}; "
                    "all channels of a record must have the same length"
                )
        if n == 0:
            raise ValueError(f"{where}: no samples; remove the empty record or check the file")
        for key, a in arrays.items():
            bad = ~np.isfinite(a)
            if bad.any():
                kind = "NaN" if np.isnan(a[bad]).all() else "non-finite (NaN/inf)"
                raise ValueError(
                    f"{where}: channel {key!r} has {int(bad.sum())} {kind} values (rows {_rows(bad)}); "
                    "drop or interpolate them"
                )
        dt = np.diff(arrays["t"])
        if (dt == 0).any():
            raise ValueError(
                f"{where}: duplicate timestamps at rows {_rows(np.r_[dt == 0, False])}; "
                "drop the repeated samples or average them"
            )
        if (dt < 0).any():
            raise ValueError(
                f"{where}: time is not increasing at rows {_rows(np.r_[dt < 0, False])}; "
                "sort the samples by time or fix the time column"
            )
        self.t, self.x, self.y = arrays["t"], arrays["x"], arrays["y"]
        self.extra = {k: arrays[k] for k in self.extra}
        self.conditions = dict(self.conditions)
        self.units = {"t": "s", **dict(self.units)}

    def __len__(self) -> int:
        return len(self.t)

    @property
    def dt(self) -> float:
        """Median sample interval [s]."""
        return float(np.median(np.diff(self.t))) if len(self.t) > 1 else float("nan")

    @property
    def uniform(self) -> bool:
        d = np.diff(self.t)
        return bool(len(d) == 0 or np.allclose(d, d[0], rtol=1e-6, atol=0))

    def slice(self, start: int | None = None, stop: int | None = None, name: str | None = None) -> "Record":
        """Samples ``start:stop`` as a new record (same conditions and units)."""
        sl = slice(start, stop)
        return Record(
            name=name or self.name, t=self.t[sl], x=self.x[sl], y=self.y[sl], conditions=self.conditions,
            units=self.units, extra={k: v[sl] for k, v in self.extra.items()}, source=self.source,
        )

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
