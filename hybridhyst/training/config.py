"""Reading a composed config: plain containers, instantiation, keyword checks, records and split.

Written once here, the lowest layer that reads whole app configs (the training builders read
``conf/train.yaml`` through these); every app (``hybridhyst.cli.common`` re-exports them) and any caller
below the apps (a study composing a config) get the same one-line errors.
"""

from __future__ import annotations

import difflib
import inspect
from collections.abc import Callable

__all__ = ["check_kwargs", "check_model_data", "config_number", "instantiate", "load_records", "not_a_number",
           "split_options", "to_plain"]

SPLIT_KEYS = ("select", "held_out", "val")


def to_plain(node):
    """An OmegaConf node as plain python containers (other values unchanged); a ``???`` value inside it is
    an error naming its key (``MissingMandatoryValue``)."""
    from omegaconf import DictConfig, ListConfig, OmegaConf

    if isinstance(node, (DictConfig, ListConfig)):
        return OmegaConf.to_container(node, resolve=True, throw_on_missing=True)
    return node


def instantiate(node, **kwargs):
    """``hydra.utils.instantiate`` of a config that may name only hybridhyst's own builders (``builders``),
    checked on every ``_target_`` of ``node`` before anything is built: a model config in someone else's run
    directory is data, never code. The check is made on the config with its interpolations resolved (a
    ``${oc.create:{_target_: ...}}`` or a reference to another node could otherwise bring a target in after it),
    and exactly that checked, plain config is what is built. A model config read from a run directory is used
    only if that run finished (``hybridhyst.runs.require_complete``). A target's ``ValueError`` is re-raised as
    itself (not wrapped)."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate as _instantiate
    from omegaconf import DictConfig, ListConfig, OmegaConf

    _check_source(node)
    group = _group(node)
    if isinstance(node, (DictConfig, ListConfig)):
        node = OmegaConf.to_container(node, resolve=True)
    _check_targets(node, group)
    try:
        return _instantiate(node, **kwargs)
    except InstantiationException as exc:
        from omegaconf.errors import OmegaConfBaseException

        cause = exc.__cause__
        if isinstance(cause, (ValueError, FileNotFoundError, OmegaConfBaseException)):
            raise cause from None
        detail = f": {cause}" if cause is not None else ""
        raise ValueError(str(exc).splitlines()[0].rstrip(":") + detail) from exc


def builders() -> set[str]:
    """The ``_target_`` values a config may name: the model builder, the named compositions and the data
    readers and loaders."""
    from ..physics.compositions import COMPOSITIONS

    return {"hybridhyst.physics.build_model", *(f"hybridhyst.physics.compositions.{n}" for n in COMPOSITIONS),
            *(f"hybridhyst.data.{n}" for n in ("load_builtin", "read", "read_table", "read_npz", "read_mat"))}


def _group(node) -> str:
    """The config key of ``node`` (``model``, ``data``); '' for a plain container."""
    from omegaconf import DictConfig

    return str(node._get_full_key(None)) if isinstance(node, DictConfig) else ""


def _check_targets(plain, group: str) -> None:
    """``ValueError`` naming the first ``_target_`` in ``plain`` (a resolved plain config; nested ones too) that is
    not one of ``builders``; ``group`` is its config key, for the message."""
    allowed = builders()

    def walk(value, path):
        if isinstance(value, dict):
            target = value.get("_target_")
            if target is not None and target not in allowed:
                where = _source_file(group) or "the config"
                key = ".".join(p for p in (*path, "_target_") if p)
                raise ValueError(f"{where}: {key} names {target!r}, which is not one of hybridhyst's builders "
                                 f"({', '.join(sorted(allowed))}); a config may only build hybridhyst models and "
                                 "data sets, so nothing was built")
            for k, v in value.items():
                walk(v, (*path, str(k)))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                walk(v, (*path, f"{i}"))

    walk(plain, (group,) if group else ())


def _source_file(group: str) -> str | None:
    """The file the running Hydra app read config group ``group`` from (the chosen option found on the
    search path), or None (no Hydra run, no such group, a packaged config)."""
    from pathlib import Path

    from hydra.core.hydra_config import HydraConfig

    if not group or not HydraConfig.initialized():
        return None
    runtime = HydraConfig.get().runtime
    choice = runtime.choices.get(group) if runtime.choices else None
    if not choice:
        return None
    for source in runtime.config_sources:
        if source.schema != "file":
            continue
        path = Path(source.path) / group / f"{choice}.yaml"
        if path.is_file():
            return str(path)
    return None


def _check_source(node) -> None:
    """A config group option read from a run directory (``'hydra.searchpath=[file://<run dir>]' model=discovered``)
    is used only when that run finished (its ``complete.json``): a run killed while writing leaves a model config
    without the results it belongs to."""
    from pathlib import Path

    from ..runs import is_run_dir, require_complete

    source = _source_file(_group(node))
    if source is None:
        return
    folder = Path(source).parent.parent
    if is_run_dir(folder):
        name = f"{Path(source).parent.name}/{Path(source).name}"
        require_complete(folder, f"the config {name}", name)


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


def not_a_number(key: str, value, whole: bool = False) -> ValueError:
    """The one-line error for config key ``key`` whose ``value`` is not a number (``whole``: not a whole one):
    the key, what it needs, and how to give it."""
    kind, form = ("a whole number", "<int>") if whole else ("a number", "<number>")
    return ValueError(f"config key {key} must be {kind}, got {value!r}: give {key}={form}")


def config_number(node, key: str, where: str, whole: bool = False) -> int | float:
    """``node[key]`` as an int (``whole``) or a float; a value that is not one (``'abc'``, ``true``, ``2.5`` for
    a whole number) is a ``ValueError`` naming the config key ``where`` (e.g. ``trainer.max_epochs``) and how to
    give it, not Python's ``invalid literal for int()``."""
    value = node[key]
    try:
        if isinstance(value, bool):
            raise TypeError(value)
        number = float(value)
        if whole and not number.is_integer():
            raise ValueError(value)
    except (TypeError, ValueError, OverflowError):
        raise not_a_number(where, value, whole) from None
    return int(number) if whole else number


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


def check_model_data(model, split, what: str = "model", read_elsewhere=()) -> str:
    """Every record of ``split`` (``Split`` or a record set) fits the model, else a one-line ``ValueError``: it has
    the conditions the model's parameter functions need (``physics.models.conditions_used``), as numbers, and the
    input and response units (``Record.units`` "x", "y") the model declares (``NominalModel.data_units``; nothing
    is converted), and a control channel's unit where both name one. Units the model leaves symbolic are not
    checked. Records that declare no unit for a channel are taken to be in the model's (written into
    ``Record.units``, so reports label them): the returned notes say so, and name control channels that neither
    the model nor anything else reads (``read_elsewhere``: a network's inputs, ``datamodule.conditions``), for the
    app to show ('' where there is nothing to say)."""
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
    for record in records:  # a control channel's unit, where both the record and the model name one
        for control in record.controls:
            have, need = record.units.get(control), model.units.get(control)
            if have is not None and need is not None and have != need:
                raise ValueError(f"record {record.name!r} has control {control!r} in {have!r} but the {what} "
                                 f"{model.name!r} reads it in {need!r}: nothing is converted; give data.units."
                                 f"{control} in the model's unit or convert the data")
    assumed = {k: unit for k, unit in want.items() if any(r.units.get(k) is None for r in records)}
    for record in records:  # filled only once every record has passed the check
        record.units.update({k: unit for k, unit in assumed.items() if record.units.get(k) is None})
    notes = []
    unread = sorted({c for r in records for c in r.controls} - set(names) - set(read_elsewhere))
    if unread:
        notes.append(f"note: the records carry the control channel(s) {unread} (data.controls), which the {what} "
                     f"{model.name!r} does not read: no parameter function or effect names them "
                     "(hybridhyst-discover offers them to every parameter)")
    if assumed:
        taken = ", ".join(f"{label[k]} in {u}" for k, u in assumed.items())
        notes.append(f"note: the records declare no units for {' and '.join(label[k] for k in assumed)} (data.units): "
                     f"they are taken to be the {what} {model.name!r}'s ({taken}); nothing is checked or converted")
    return "\n".join(notes)
