"""Choosing records by operating condition: the matching rules behind ``RecordSet.select`` and ``.split``.

A condition query is either

* a mapping ``{condition: value or [values]}``: a record matches when, for every condition, its value
  equals one of the listed values (numbers compare with a relative tolerance of 1e-9, so 0.1 + 0.2
  matches 0.3); or
* a callable ``query(record) -> bool``; or
* a list of mappings: a record matches when it matches any of them (e.g. hold out the 1.5 in tests
  *and* the earthquake records: ``[{"amplitude_in": 1.5, "kind": "characterisation"}, {"kind": "earthquake"}]``).

One convention in every app (``conf/*.yaml``): ``split.select`` is a mapping (the records used),
``split.held_out`` (test) and ``split.val`` (validation) are lists of mappings; a single mapping is the
one-element list, and ``null`` or ``[]`` is none (``as_queries``).

Every listed value must match at least one record of the set: a held-out value that matches nothing is
almost always a typo, and silently holding out nothing would make a test split meaningless.
"""

from __future__ import annotations

import difflib
import numbers
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np

from .records import TRAVEL_BEFORE

__all__ = ["Split", "as_queries", "check_conditions", "condition_mask"]

Query = Mapping[str, object] | Callable[[object], bool]


class Split(NamedTuple):
    """Train / validation / test record sets (``train, val, test = records.split(...)``)."""

    train: object
    val: object
    test: object


def _is_number(v) -> bool:
    return isinstance(v, numbers.Number) and not isinstance(v, bool)


def _equal(a, b) -> bool:
    if _is_number(a) and _is_number(b):
        return bool(np.isclose(float(a), float(b), rtol=1e-9, atol=0.0))
    return a == b


def _values(value) -> list:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, set, frozenset, np.ndarray)):
        return [value]
    return [v.item() if isinstance(v, np.generic) else v for v in value]


def _available(records, key: str) -> list:
    found = []
    for r in records:
        if key in r.conditions and not any(_equal(r.conditions[key], f) for f in found):
            found.append(r.conditions[key])
    try:
        return sorted(found)
    except TypeError:
        return found


def as_queries(query, what: str = "held-out") -> list[Mapping] | Callable:
    """A held-out / validation query as a list of mappings (any matches), or the callable itself.

    ``None`` and ``[]`` are no query (``[]``); a mapping is the one-element list ``[mapping]``; a list
    (or tuple) of mappings is kept. Anything else, or an empty mapping (which would match every record),
    is a ``ValueError`` naming ``what``.
    """
    if query is None:
        return []
    if callable(query):
        return query
    items = [query] if isinstance(query, Mapping) else query
    if isinstance(items, (str, bytes)) or not isinstance(items, (list, tuple)) or \
            not all(isinstance(q, Mapping) for q in items):
        raise ValueError(f"{what} conditions must be a list of {{condition: [values]}} mappings (a single mapping "
                         f"is one query; null for none), got {query!r}")
    for q in items:
        if not q:
            raise ValueError(f"{what} query {{}} names no condition, so it would match every record; give "
                             f"{{condition: [values]}}, or null for no {what} records")
    return list(items)


def condition_mask(records: Sequence, query: Query | None, what: str, set_name: str = "") -> np.ndarray:
    """Boolean mask ``(len(records),)`` of the records matching ``query``.

    Parameters
    ----------
    records : the records (objects with ``.name`` and ``.conditions``).
    query : a ``{condition: value or [values]}`` mapping, a list of them (a record matching any matches),
        a callable ``query(record) -> bool``, or ``None`` / ``[]`` (matches nothing).
    what : how the query is described in messages ("held-out", "validation", "selected").
    set_name : name of the record set, for messages.

    Raises
    ------
    ValueError
        If a condition name exists in no record (naming the closest one) or a listed value matches no
        record (listing the available values).
    """
    n = len(records)
    if query is None:
        return np.zeros(n, dtype=bool)
    if callable(query):
        return np.array([bool(query(r)) for r in records], dtype=bool)
    if isinstance(query, (list, tuple)) and all(isinstance(q, Mapping) for q in query):
        mask = np.zeros(n, dtype=bool)
        for q in query:
            mask |= condition_mask(records, q, what, set_name)
        return mask
    if not isinstance(query, Mapping):
        raise ValueError(f"{what} conditions must be a mapping {{condition: values}}, a list of mappings or a "
                         f"callable, got {query!r}")
    mask = np.ones(n, dtype=bool)
    names = sorted({k for r in records for k in r.conditions})
    for key, value in query.items():
        if key not in names:
            close = difflib.get_close_matches(str(key), names, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ValueError(
                f"{what} condition {key!r} is not a condition of record set {set_name!r}; {hint}conditions are: {names}"
            )
        hits = np.zeros(n, dtype=bool)
        for v in _values(value):
            hit = np.array([key in r.conditions and _equal(r.conditions[key], v) for r in records], dtype=bool)
            if not hit.any():
                raise ValueError(
                    f"{what} condition {key}={v!r} matches no record; available values: {_available(records, key)}"
                )
            hits |= hit
        mask &= hits
    return mask


def _is_numeric(v) -> bool:
    return _is_number(v) and bool(np.isfinite(float(v)))


def check_conditions(split: Split, names: Sequence[str], what: str, min_train_values: int = 1) -> None:
    """Every record of ``split`` (train, validation and test) has a finite numeric value of each condition in
    ``names``, and the training records take at least ``min_train_values`` distinct values of it.

    For conditions a model uses as an input (a parameter as a function of the condition, a trend to be
    fitted, a network feature): a record without the condition cannot be simulated, and a condition
    that takes one value on the training records leaves its trend undetermined. ``what`` names the setting
    in the message (e.g. ``"discover.conditions"``).

    Raises
    ------
    ValueError
        Naming the condition and the records that lack it, or the training values.
    """
    parts = {"training": list(split.train), "validation": list(split.val), "test": list(split.test)}
    every = [r for recs in parts.values() for r in recs]
    known = sorted({k for r in every for k, v in r.conditions.items() if _is_numeric(v)})
    controls = sorted({k for r in every for k in r.controls})
    for name in names:
        if name in controls:  # a control channel (data.controls): numbers at every sample
            lacking = [r.name for r in every if name not in r.controls]
            if lacking:
                raise ValueError(f"{what}: control channel {name!r} is missing from {len(lacking)} of {len(every)} "
                                 f"records ({', '.join(lacking[:5])}); give every record the same data.controls")
            values = np.concatenate([r.controls[name] for r in parts["training"]] or [np.zeros(0)])
            if min_train_values > 1 and not (len(values) and values.max() > values.min()):
                raise ValueError(f"{what}: control {name!r} does not vary on the training records, too little to fit "
                                 f"how the model depends on it; drop it from {what}")
            continue
        lacking = [r.name for r in every if not _is_numeric(r.conditions.get(name))]
        if lacking:
            close = difflib.get_close_matches(str(name), known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close and close[0] != name else ""
            shown = ", ".join(lacking[:5]) + (f" and {len(lacking) - 5} more" if len(lacking) > 5 else "")
            usable = [k for k in known if all(_is_numeric(r.conditions.get(k)) for r in every)]
            if not any(name in r.conditions for r in every):
                also = f", control channels: {controls}" if controls else (
                    "; a signal that varies in time is read as a control channel: name its column in data.controls")
                if name == TRAVEL_BEFORE:  # a discovered drift carried between records reads it
                    also += (f"; {name!r} is the input's travel in the records before each, in the order they were "
                             "measured: hybridhyst.data.with_travel_before(records) adds it, or give it as a "
                             "column (data.conditions)")
                raise ValueError(f"{what}: no record has a condition {name!r}{hint}; numeric conditions of every "
                                 f"record: {usable}{also}")
            raise ValueError(f"{what}: condition {name!r}{hint} is not a number in {len(lacking)} of {len(every)} "
                             f"records ({shown}); numeric conditions of every record: {usable}")
        values = _available(parts["training"], name)
        if len(values) < min_train_values:
            raise ValueError(f"{what}: condition {name!r} takes {len(values)} value(s) {values} on the training "
                             f"records, too few to fit how the model depends on it (at least {min_train_values}); "
                             f"hold out fewer of its values or drop it from {what}")
