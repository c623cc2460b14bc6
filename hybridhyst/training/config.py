"""Reading a composed config: plain containers, instantiation, keyword checks, records and split.

Written once here, the lowest layer that reads whole app configs (the training builders read
``conf/train.yaml`` through these); every app (``hybridhyst.cli.common`` re-exports them) and any caller
below the apps (a study composing a config) get the same one-line errors.
"""

from __future__ import annotations

import difflib
import inspect
from collections.abc import Callable

__all__ = ["check_kwargs", "check_model_data", "instantiate", "load_records", "split_options", "to_plain"]

SPLIT_KEYS = ("select", "held_out", "val")


def to_plain(node):
    """An OmegaConf node as plain python containers (other values unchanged); a ``???`` value inside it is
    an error naming its key (``MissingMandatoryValue``)."""
    from omegaconf import DictConfig, ListConfig, OmegaConf

    if isinstance(node, (DictConfig, ListConfig)):
        return OmegaConf.to_container(node, resolve=True, throw_on_missing=True)
    return node


def instantiate(node, **kwargs):
    """``hydra.utils.instantiate`` that re-raises a target's ``ValueError`` as itself (not wrapped)."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate as _instantiate

    try:
        return _instantiate(node, **kwargs)
    except InstantiationException as exc:
        from omegaconf.errors import OmegaConfBaseException

        cause = exc.__cause__
        if isinstance(cause, (ValueError, FileNotFoundError, OmegaConfBaseException)):
            raise cause from None
        detail = f": {cause}" if cause is not None else ""
        raise ValueError(str(exc).splitlines()[0].rstrip(":") + detail) from exc


def check_kwargs(options: dict, fn: Callable, where: str, reserved: tuple[str, ...] = ()) -> dict:
    """``options`` (a config section passed as keyword arguments to ``fn``) when every key is a keyword of
    ``fn`` other than ``reserved`` (the ones the caller passes itself); else a ``ValueError`` naming the key
    under ``where`` and the closest keyword."""
    params = inspect.signature(fn).parameters
    if any(p.kind == p.VAR_KEYWORD for p in params.values()):
        return options
    names = [n for n, p in params.items() if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
             and n not in ("self", *reserved)]
    for key in options:
        if key not in names:
            close = difflib.get_close_matches(str(key), names, n=1)
            hint = f"did you mean {where}.{close[0]}? " if close else ""
            raise ValueError(f"unknown config key {where}.{key}: {hint}{where} takes {sorted(names)}")
    return options


def split_options(cfg, keys: tuple[str, ...] = SPLIT_KEYS) -> dict:
    """``{"select": mapping or None, "held_out": [queries], "val": [queries]}`` from ``cfg.split``.

    ``split.select`` is a mapping ``{condition: value or [values]}`` (or a list of them: any matches);
    ``split.held_out`` and ``split.val`` are lists of such queries (``RecordSet.split``), a single mapping
    being the one-element list and ``null`` none. ``keys`` are the keys read; each must be present (a deleted
    key is a config error naming it) and set (``???`` is an error).
    """
    from ..data.splits import as_queries

    if "select" in cfg:
        raise ValueError("the record selection is split.select (a mapping {condition: [values]}), not a "
                         "top-level select: write split.select=... instead")
    node = cfg.split
    out = {key: to_plain(getattr(node, key)) for key in keys}  # attribute access: a deleted key is an error
    if "select" in out and out["select"] is not None:
        select = out["select"]
        if not isinstance(select, dict) and not (isinstance(select, list)
                                                  and all(isinstance(q, dict) for q in select)):
            raise ValueError(f"split.select must be a mapping {{condition: value or [values]}} (or null for every "
                             f"record), got {select!r}")
    for key, what in (("held_out", "held-out"), ("val", "validation")):
        if key in out:
            out[key] = as_queries(out[key], f"split.{key} ({what})")
    return out


def load_records(cfg, select=None, where: str = "split.select"):
    """The records of ``cfg.data`` (instantiated) that match ``select`` (``where``, e.g. ``split.select``: a
    mapping, a list of mappings, or None for every record): the one load-select-check path of every app.
    A selection that leaves no record is a ``ValueError`` naming ``where``."""
    records = instantiate(cfg.data, _convert_="all")
    if select:
        records = records.select(select)
    if len(records) == 0:
        raise ValueError(f"{where} {select} leaves no records of {records.name!r}")
    return records


def check_model_data(model, split, what: str = "model") -> str:
    """Every record of ``split`` (``Split`` or a record set) fits the model, else a one-line ``ValueError``: it has
    the conditions the model's parameter functions need (``physics.models.conditions_used``), as numbers, and the
    input and response units (``Record.units`` "x", "y") the model declares (``NominalModel.data_units``; nothing
    is converted). Units the model leaves symbolic are not checked. Records that declare no unit for a channel
    are taken to be in the model's (written into ``Record.units``, so reports label them): the returned sentence
    says so, for the app to show ('' where every record declared its units)."""
    from ..data.splits import Split, check_conditions
    from ..physics.models import conditions_used

    parts = split if isinstance(split, Split) else Split(list(split), [], [])
    names = conditions_used(model)
    if names:
        check_conditions(parts, names, f"{what} (a parameter as a function of a condition)")
    want, label = model.data_units(), {"x": "input", "y": "response"}
    records = [r for part in parts for r in (part or ())]
    for record in records:
        have = {k: record.units.get(k) for k in want}
        if any(v is not None and v != want[k] for k, v in have.items()):
            got = ", ".join(f"{label[k]} {have[k]!r}" for k in want)
            need = ", ".join(f"{label[k]} {want[k]!r}" for k in want)
            raise ValueError(f"record {record.name!r} has units {got} but the {what} {model.name!r} works in {need}: "
                             "nothing is converted; give data.units in the model's units (data.units.x is the input "
                             "column's, data.units.y the response's) or convert the data")
    assumed = {k: unit for k, unit in want.items() if any(r.units.get(k) is None for r in records)}
    for record in records:  # filled only once every record has passed the check
        record.units.update({k: unit for k, unit in assumed.items() if record.units.get(k) is None})
    if not assumed:
        return ""
    taken = ", ".join(f"{label[k]} in {u}" for k, u in assumed.items())
    return (f"note: the records declare no units for {' and '.join(label[k] for k in assumed)} (data.units): they are "
            f"taken to be the {what} {model.name!r}'s ({taken}); nothing is checked or converted")
