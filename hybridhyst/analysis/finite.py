"""Which records a simulation left non-finite, and from which sample: the one check every app runs on what it
simulated before it reports an error, a frequency or a loop figure derived from it.

An explicit scheme on a step too coarse for a state (a stiff spring, a sharp hysteretic loop) grows without
bound and overflows to ``inf``/``nan``; a metric pooled over such a record is ``nan`` or ``inf``, which JSON
stores as ``null`` and a summary line skips. So a diverged simulation used to end as a silent success. Every
app now calls ``check_finite`` on every record it simulated: without ``keep_going`` a divergence is a
``DivergenceError`` (a ``ValueError``: the apps' ``guarded`` turns it into one ``error: ...`` line and exit
code 2); with it, a ``warning: ...`` line, and the caller writes its results with the diverged records named.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["DivergenceError", "Diverged", "check_finite", "divergence_message", "nonfinite_records"]

SHOWN = 5  # records named in a message; the rest are counted


@dataclass(frozen=True)
class Diverged:
    """A record whose simulated response holds a non-finite value.

    ``sample``: the index (from 0) of its first non-finite sample on the grid that was simulated (a thinned
    grid where the record was decimated), ``t`` the time there (None where no times were given), ``samples``
    the samples simulated, ``split`` the part of the data it belongs to ("train", "held_out", ...; None: not
    said)."""

    record: str
    sample: int
    t: float | None
    samples: int
    split: str | None = None

    def describe(self, time_unit: str = "s") -> str:
        """``'rec_a' (held out) from sample 812 (t = 4.06 s)``."""
        part = f" ({self.split.replace('_', ' ')})" if self.split else ""
        when = f" (t = {self.t:.4g} {time_unit})".replace(" )", ")") if self.t is not None else ""
        return f"{self.record!r}{part} from sample {self.sample}{when}"

    def to_dict(self) -> dict:
        return asdict(self)


class DivergenceError(ValueError):
    """A simulation diverged on ``diverged`` (``Diverged`` entries); the message names them."""

    def __init__(self, message: str, diverged: Sequence[Diverged]):
        super().__init__(message)
        self.diverged = list(diverged)


def _first_nonfinite(values) -> int | None:
    """Index along the first axis of the first row holding a non-finite value; None if every value is finite."""
    if hasattr(values, "detach"):
        values = values.detach().cpu().numpy()
    a = np.asarray(values, dtype=np.float64)
    if a.ndim == 0:
        a = a.reshape(1)
    bad = ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    hits = np.flatnonzero(bad)
    return int(hits[0]) if hits.size else None


def nonfinite_records(predictions: Sequence, names: Sequence[str], times: Sequence | None = None,
                      splits: Sequence[str | None] | str | None = None) -> list[Diverged]:
    """The records whose simulated response is not finite everywhere, each with its first non-finite sample.

    Parameters
    ----------
    predictions : one array-like (numpy or torch) per record, time first: ``(time,)`` or ``(time, channels)``
        (a sample counts as non-finite when any channel is).
    names : the records' names, aligned with ``predictions``.
    times : each record's time grid (aligned; None: samples only).
    splits : each record's part of the data ("train", "val", "test", "held_out", ...), or one for all.

    Returns
    -------
    ``[Diverged, ...]`` in the order given; empty when every value is finite.
    """
    predictions, names = list(predictions), [str(n) for n in names]
    if len(predictions) != len(names):
        raise ValueError(f"nonfinite_records got {len(predictions)} predictions for {len(names)} record names")
    times = [None] * len(names) if times is None else list(times)
    parts = [splits] * len(names) if splits is None or isinstance(splits, str) else list(splits)
    found = []
    for y, name, t, part in zip(predictions, names, times, parts):
        i = _first_nonfinite(y)
        if i is None:
            continue
        at = None
        if t is not None:
            t = t.detach().cpu().numpy() if hasattr(t, "detach") else np.asarray(t)
            at = float(t[i]) if i < len(t) else None
        found.append(Diverged(record=name, sample=i, t=at, samples=int(np.shape(y)[0]) if np.ndim(y) else 1,
                              split=part))
    return found


def divergence_message(diverged: Sequence[Diverged], total: int, *, what: str = "the simulation",
                       time_unit: str = "s") -> str:
    """``the simulation diverged on 3 of 4 records: 'a' from sample 812 (t = 4.06 s), ...`` (the first ``SHOWN``
    named, the rest counted)."""
    shown = ", ".join(d.describe(time_unit) for d in diverged[:SHOWN])
    more = f" and {len(diverged) - SHOWN} more" if len(diverged) > SHOWN else ""
    noun = "record" if total == 1 else "records"
    return f"{what} diverged on {len(diverged)} of {total} {noun}: {shown}{more}"


def _stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def check_finite(predictions: Sequence, names: Sequence[str], times: Sequence | None = None, *,
                 splits: Sequence[str | None] | str | None = None, keep_going: bool = False, hint: str = "",
                 what: str = "the simulation", time_unit: str = "s",
                 warn: Callable[[str], None] | None = None) -> list[Diverged]:
    """Check every simulated record (``nonfinite_records``) and say which diverged, and from which sample.

    Without ``keep_going`` a divergence raises ``DivergenceError`` (a ``ValueError``; the apps' ``guarded``
    prints it as ``error: ...`` and exits with code 2):
    ``the simulation diverged on 1 of 4 records: 'rec_a' (held out) from sample 812 (t = 4.06 s); <hint>;
    keep_going=true writes the results anyway``. With ``keep_going`` the same text starts ``warning:`` and
    ends ``results written anyway (keep_going=true)``, goes to ``warn`` (default: stderr), and the diverged
    records are returned for the caller to name in its results. ``hint``: what to try, in the app's keys
    (e.g. "raise simulation.substeps or check the parameters"). Returns ``[]`` when every value is finite.
    """
    names = list(names)
    found = nonfinite_records(predictions, names, times, splits)
    if not found:
        return []
    message = divergence_message(found, len(names), what=what, time_unit=time_unit)
    hint = f"; {hint}" if hint else ""
    if not keep_going:
        raise DivergenceError(f"{message}{hint}; keep_going=true writes the results anyway", found)
    (warn or _stderr)(f"warning: {message}{hint}; results written anyway (keep_going=true)")
    return found
