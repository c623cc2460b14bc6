"""Helpers shared by the Hydra apps: config location, run directory, records and split, atomic writes, errors.

Every app is a plain ``run(cfg) -> dict`` (tests call it with a composed config) plus a thin
``@hydra.main`` wrapper that goes through ``guarded`` so that a ``ValueError`` (bad data, bad option) or a
config error (a deleted or misspelt key, a ``???`` value left unset, an interpolation that does not
resolve) ends the process with a one-line ``error: ...`` on stderr and exit code 2 instead of a traceback;
the console entry point ``main()`` calls it through ``hydra_entry``, which does the same for Hydra's own
composition errors (an override naming a key that is not in the config, an unknown group option).

Records are chosen the same way in every app (``split_options``): ``split.select`` (a mapping, the records
used), ``split.held_out`` (test) and ``split.val`` (validation), each a list of condition queries.
"""

from __future__ import annotations

import difflib
import inspect
import os
import sys
from collections.abc import Callable
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from ..files import atomic_write, jsonable, write_json  # noqa: F401 (the apps' run-directory I/O)
from ..settings import CONF_DIR, torch_settings  # noqa: F401 (re-exported for the apps)

__all__ = [
    "CONF_DIR",
    "atomic_write",
    "check_kwargs",
    "check_model_conditions",
    "config_error_message",
    "guarded",
    "hydra_entry",
    "instantiate",
    "jsonable",
    "load_records",
    "prepare_run_dir",
    "split_options",
    "torch_settings",
    "write_json",
]



def prepare_run_dir(cfg: DictConfig) -> Path:
    """The run directory: Hydra's output dir under ``@hydra.main``, else ``cfg.run_dir``, else the cwd.

    The resolved config is written there as ``config.yaml``.
    """
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized():
        path = Path(HydraConfig.get().runtime.output_dir)
    else:
        path = Path(cfg.get("run_dir") or os.getcwd())
    path.mkdir(parents=True, exist_ok=True)
    atomic_write(path / "config.yaml", OmegaConf.to_yaml(cfg, resolve=True))
    return path


def to_plain(node):
    """An OmegaConf node as plain python containers (other values unchanged); a ``???`` value inside it is
    an error naming its key (``MissingMandatoryValue``, a one-line message through ``guarded``)."""
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


def check_app(cfg: DictConfig, app: str) -> None:
    """Experiment configs say which app they belong to (``app:``); refuse one meant for another app."""
    if cfg.get("app", app) != app:
        raise ValueError(f"this configuration (experiment {cfg.get('experiment_name') or ''!s}) is for "
                         f"hybridhyst-{cfg.app}, not hybridhyst-{app}")


# -- records and split: one convention for every app -----------------------------------------------------------
SPLIT_KEYS = ("select", "held_out", "val")


def split_options(cfg: DictConfig, keys: tuple[str, ...] = SPLIT_KEYS) -> dict:
    """``{"select": mapping or None, "held_out": [queries], "val": [queries]}`` from ``cfg.split``.

    ``split.select`` is a mapping ``{condition: value or [values]}`` (or a list of them: any matches);
    ``split.held_out`` and ``split.val`` are lists of such queries (``RecordSet.split``), a single mapping
    being the one-element list and ``null`` none. ``keys`` are the keys the app reads (identify: select
    only); each must be present (a deleted key is a config error naming it) and set (``???`` is an error).
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


def load_records(cfg: DictConfig, select=None, where: str = "split.select"):
    """The records of ``cfg.data`` (instantiated) that match ``select`` (``where``, e.g. ``split.select``: a
    mapping, a list of mappings, or None for every record): the one load-select-check path of the apps.
    A selection that leaves no record is a ``ValueError`` naming ``where``."""
    records = instantiate(cfg.data, _convert_="all")
    if select:
        records = records.select(select)
    if len(records) == 0:
        raise ValueError(f"{where} {select} leaves no records of {records.name!r}")
    return records


def check_kwargs(options: dict, fn: Callable, where: str, reserved: tuple[str, ...] = ()) -> dict:
    """``options`` (a config section passed as keyword arguments to ``fn``) when every key is a keyword of
    ``fn`` other than ``reserved`` (the ones the app passes itself); else a ``ValueError`` naming the key
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


def check_model_conditions(model, split, what: str = "model") -> None:
    """Every record of ``split`` (``Split`` or a record set) has the conditions the model's parameter functions
    need (``physics.models.conditions_used``), as numbers; else a one-line ``ValueError`` naming the condition
    and records."""
    from ..data.splits import Split, check_conditions
    from ..physics.models import conditions_used

    names = conditions_used(model)
    if names:
        parts = split if isinstance(split, Split) else Split(list(split), [], [])
        check_conditions(parts, names, f"{what} (a parameter as a function of a condition)")


# -- errors ---------------------------------------------------------------------------------------------------
_VALUE_HINTS = {
    "split.held_out": "'split.held_out=[{<condition>: [<values>]}]' (null: no held-out records)",
    "split.val": "'split.val=[{<condition>: [<values>]}]' (null: no validation records)",
    "split.select": "'split.select={<condition>: [<values>]}' (null: every record)",
    "data.path": "data.path=<file.csv, or a pattern 'runs/*.csv'>",
}


def _missing_keys(cfg) -> list[str]:
    """Keys of ``cfg`` whose value is ``???`` (nodes that cannot be read are skipped)."""
    from omegaconf import DictConfig, ListConfig, OmegaConf

    out: list[str] = []

    def gather(node, prefix):
        keys = node.keys() if isinstance(node, DictConfig) else range(len(node))
        for key in keys:
            full = f"{prefix}{key}" if isinstance(node, DictConfig) else f"{prefix.rstrip('.')}[{key}]"
            try:
                if OmegaConf.is_missing(node, key):
                    out.append(full)
                    continue
                child = node._get_node(key)
                if isinstance(child, (DictConfig, ListConfig)) and not child._is_interpolation():
                    gather(child, f"{full}.")
            except Exception:  # an unresolvable interpolation: reported by its own error
                continue

    if isinstance(cfg, (DictConfig, ListConfig)):
        gather(cfg, "")
    return [k for k in out if not k.startswith("hydra.")]


def config_error_message(exc: Exception, cfg=None) -> str:
    """One line for an OmegaConf error: the key, what is wrong with it, and how to fix it on the command line."""
    from omegaconf.errors import (
        ConfigAttributeError,
        ConfigKeyError,
        InterpolationResolutionError,
        MissingMandatoryValue,
    )

    key = getattr(exc, "full_key", None) or getattr(exc, "key", None) or "?"
    detail = " ".join(str(exc).splitlines()[0].split()) if str(exc) else type(exc).__name__
    if isinstance(exc, MissingMandatoryValue):
        missing = _missing_keys(cfg) or [str(key)]
        if str(key) in missing:
            missing.remove(str(key))
        missing.insert(0, str(key))
        hints = " ".join(_VALUE_HINTS.get(k, f"{k}=<value>") for k in missing)
        what = f"config key {missing[0]} needs" if len(missing) == 1 else f"config keys {', '.join(missing)} need"
        return f"{what} a value (??? in the config): add {hints} to the command line"
    if isinstance(exc, InterpolationResolutionError):
        return (f"config key {key}: its interpolation does not resolve ({detail}); set {key}=<value> or fix the "
                f"reference")
    if isinstance(exc, (ConfigAttributeError, ConfigKeyError)):
        parent = getattr(exc, "parent_node", None)
        siblings = [str(k) for k in parent.keys()] if parent is not None and hasattr(parent, "keys") else []
        prefix = str(key).rsplit(".", 1)[0] + "." if "." in str(key) else ""
        leaf = str(key).rsplit(".", 1)[-1]
        close = difflib.get_close_matches(leaf, siblings, n=1, cutoff=0.6)
        hint = f"; is {prefix}{close[0]} a misspelling of it? " if close else "; "
        return (f"config key {key} is missing (deleted or misspelt){hint}restore it (drop the '~{key}' override) "
                f"or set it with '+{key}=<value>'" + (" (null for none)" if str(key) in _VALUE_HINTS else ""))
    return f"config key {key}: {detail}"


def guarded(run: Callable[[DictConfig], dict], cfg: DictConfig) -> dict:
    """Call ``run(cfg)``; a ``ValueError``, a missing file or a config error (``OmegaConfBaseException``: a
    deleted or misspelt key, an unset ``???``, an interpolation that does not resolve) becomes
    ``error: <message>`` on one line and exit code 2.

    ``HYBRIDHYST_TRACEBACK=1`` re-raises instead (for debugging). In a Hydra multirun the exception is
    re-raised after the message: Hydra marks that job failed, runs the others and fails the sweep at the
    end (``sys.exit`` inside a job would stop the whole sweep).
    """
    from omegaconf.errors import OmegaConfBaseException

    try:
        return run(cfg)
    except (ValueError, FileNotFoundError, OmegaConfBaseException) as exc:
        if isinstance(exc, OmegaConfBaseException):
            message = config_error_message(exc, cfg)
        else:
            message = " ".join(str(exc).split()) or type(exc).__name__
        if os.environ.get("HYBRIDHYST_TRACEBACK") or _multirun():
            print(f"error: {message}", file=sys.stderr, flush=True)
            raise
        print(f"error: {message}", file=sys.stderr, flush=True)
        sys.exit(2)


def _composition_message(exc: Exception) -> str:
    """One line for Hydra's composition errors (an override of a key that is not in the config, a value that
    cannot be merged, an unknown config group option, a malformed override)."""
    text = str(exc).split("Config search path", 1)[0]
    head, _, options = text.partition("Available options in")
    parts = [p.strip().rstrip(".:") for p in head.splitlines() if p.strip()]
    message = "; ".join(parts)
    if options:  # "Available options in 'data':\n\tbrfd\n\t..." -> "options of 'data': brfd, ..."
        group, _, names = options.partition(":")
        message += f"; options of {group.strip()}: {', '.join(n.strip() for n in names.split() if n.strip())}"
    cause = exc.__cause__
    if cause is not None and hasattr(cause, "full_key"):
        message += f" ({' '.join(str(cause).splitlines()[0].split())})"
        if "Cannot merge DictConfig with ListConfig" in str(cause):
            message += "; that key holds a list: give one, e.g. a mapping in brackets [{...}]"
        parent, key = getattr(cause, "parent_node", None), getattr(cause, "key", None)
        siblings = [str(k) for k in parent.keys()] if parent is not None and hasattr(parent, "keys") else []
        close = difflib.get_close_matches(str(key), siblings, n=1, cutoff=0.6) if key is not None else []
        if close and close[0] != str(key):
            full = str(getattr(cause, "full_key", key))
            prefix = full.rsplit(".", 1)[0] + "." if "." in full else ""
            message += f"; did you mean {prefix}{close[0]}?"
    return message


def hydra_entry(hydra_main: Callable[[], None]) -> None:
    """Run an app's ``@hydra.main`` function so that a composition error (a misspelt key in an override, a
    mapping given where the config holds a list, an unknown ``data=`` option) is also a one-line
    ``error: ...`` with exit code 2, like the errors ``guarded`` handles inside the run. Hydra re-raises
    instead of printing when ``HYDRA_FULL_ERROR`` is set, which this sets for the call (unless the user
    set it, or ``HYBRIDHYST_TRACEBACK``, to see tracebacks); any other exception propagates unchanged.
    """
    from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException

    if os.environ.get("HYDRA_FULL_ERROR") or os.environ.get("HYBRIDHYST_TRACEBACK"):
        hydra_main()
        return
    os.environ["HYDRA_FULL_ERROR"] = "1"
    try:
        hydra_main()
    except (ConfigCompositionException, MissingConfigException, OverrideParseException) as exc:
        print(f"error: {_composition_message(exc)}", file=sys.stderr, flush=True)
        sys.exit(2)
    finally:
        os.environ.pop("HYDRA_FULL_ERROR", None)


def _multirun() -> bool:
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN
