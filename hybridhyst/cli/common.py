"""What the Hydra apps share: config errors as one-line messages, app checks, and re-exports of the run
directory and atomic writes (``hybridhyst.files``), settings (``hybridhyst.settings``) and the config readers
(``hybridhyst.training.config``).

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
import logging
import math
import os
import re
import sys
from collections.abc import Callable

from omegaconf import DictConfig, OmegaConf

from ..files import atomic_write, jsonable, write_json  # noqa: F401 (the apps' run-directory I/O)
from ..runs import (  # noqa: F401 (the apps' run directories: one run each, complete or absent)
    RunInterrupted,
    claim,
    interruptible,
    mark_complete,
    prepare_run_dir,
    release,
    run_dir_path,
)
from ..settings import CONF_DIR, torch_settings  # noqa: F401 (re-exported for the apps)
from ..simulate.api import RESOLVED
from ..training.config import (  # noqa: F401 (the one config reader of every app, re-exported)
    check_kwargs,
    check_model_data,
    instantiate,
    load_records,
    split_options,
    to_plain,
)
from .overrides import check_overrides, check_search_path, cut_short_message

__all__ = [
    "CONF_DIR",
    "atomic_write",
    "check_kwargs",
    "check_model_data",
    "config_error_message",
    "edge_line",
    "guarded",
    "hydra_entry",
    "instantiate",
    "jsonable",
    "load_records",
    "prepare_run_dir",
    "say",
    "split_options",
    "torch_settings",
    "write_json",
    "write_model",
]


def write_model(run_dir, model, config_name: str, what: str, records=()) -> str:
    """Write a fitted model where every app can use it again: ``model.pt`` (its state dict, for
    ``hybridhyst-train nominal_state=``) and ``model/<config_name>.yaml`` (its config with the fitted values,
    ``physics.model_config``); return the override that selects it, ``'hydra.searchpath=[file://<run dir>]'
    model=<config_name>``. ``what`` heads the YAML file (e.g. "discovered by hybridhyst-discover"). A condition or
    control channel the model reads (a trend discovery added) whose unit the model does not name takes the unit
    ``records`` give it, so that a later run on data in another unit is refused rather than misread."""
    from pathlib import Path

    import torch

    from ..physics import model_config
    from ..physics.models import conditions_used

    for name in conditions_used(model):
        unit = next((r.units.get(name) for r in records if r.units.get(name)), None)
        if unit and name not in model.units:
            model.units[name] = unit
    run_dir = Path(run_dir).resolve()
    atomic_write(run_dir / "model.pt", lambda p: torch.save(model.state_dict(), p))
    (run_dir / "model").mkdir(exist_ok=True)
    header = (f"# The model {what}, with its fitted values: select it in any app with\n"
              f"#   'hydra.searchpath=[file://{run_dir}]' model={config_name}\n"
              f"# Network weights, where the model has any, are in {run_dir / 'model.pt'} (nominal_state=).\n")
    atomic_write(run_dir / "model" / f"{config_name}.yaml", header + OmegaConf.to_yaml(model_config(model)))
    return f"'hydra.searchpath=[file://{run_dir}]' model={config_name}"


def resolution_note(info: dict, settings: str) -> str:
    """One sentence on the sub-steps per sample an app chose by step doubling ('' where it did not choose, or
    kept one): ``info`` has ``substeps`` and ``resolution``; ``settings`` is the app's config group (fit, identify)."""
    change, substeps = info.get("resolution"), info.get("substeps", 1)
    if change is None or (isinstance(change, float) and math.isnan(change)):
        return ""
    if not change <= RESOLVED:  # also inf: diverged at the finest step tried
        return (f"Not resolved: at {substeps} sub-steps per sample ({settings}.max_substeps) halving the step still "
                f"changes the response by {100 * change:.2g} %; raise {settings}.max_substeps or keep more samples "
                "per cycle before trusting these values.")
    if substeps == 1:
        return ""
    return (f"Integrated with {substeps} sub-steps per sample interval, chosen by step doubling (halving the step "
            f"changes the response by {100 * change:.2g} %); fewer let the explicit scheme diverge or shape the loops.")


def check_app(cfg: DictConfig, app: str) -> None:
    """The checks every app makes of its composed config first: experiment configs say which app they belong to
    (``app:``), and one meant for another app is refused; in the app's own Hydra run, the command line's overrides
    are checked against the config they change (``overrides.check_overrides``: text where a number is held, a
    ``+`` key the app would ignore), each a one-line ``ValueError`` naming the key and the fix."""
    if cfg.get("app", app) != app:
        name = _experiment_choice() or cfg.get("experiment_name")
        what, again = (f"experiment {name}", f" experiment={name}") if name else ("this configuration", "")
        raise ValueError(f"{what} is for hybridhyst-{cfg.app}, not hybridhyst-{app}: run it with "
                         f"hybridhyst-{cfg.app}{again}, or choose an experiment of hybridhyst-{app}")
    check_overrides(cfg, app)


def _experiment_choice() -> str | None:
    """The ``experiment=`` option of this Hydra run (the file name), None outside one or without an experiment."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return None
    return (HydraConfig.get().runtime.get("choices") or {}).get("experiment")


# -- errors ---------------------------------------------------------------------------------------------------
_VALUE_HINTS = {
    "split.held_out": "'split.held_out=[{<condition>: [<values>]}]' (null: no held-out records)",
    "split.val": "'split.val=[{<condition>: [<values>]}]' (null: no validation records)",
    "split.select": "'split.select={<condition>: [<values>]}' (null: every record)",
    "data.path": "data.path=<file.csv, or a pattern 'runs/*.csv'>",
}
_NEEDS_VALUE = {"fit": {"split.held_out"}}  # keys an app refuses as null (fit scores only held-out records)


def _value_hint(key: str, cfg) -> str:
    hint = _VALUE_HINTS.get(key, f"{key}=<value>")
    app = cfg.get("app") if hasattr(cfg, "get") else None
    return hint.split(" (null")[0] if key in _NEEDS_VALUE.get(app, ()) else hint


def _missing_keys(cfg) -> list[str]:
    """Keys of ``cfg`` whose value is ``???`` (nodes that cannot be read are skipped)."""
    from omegaconf import DictConfig, ListConfig

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
        hints = " ".join(_value_hint(k, cfg) for k in missing)
        what = f"config key {missing[0]} needs" if len(missing) == 1 else f"config keys {', '.join(missing)} need"
        return f"{what} a value (??? in the config): add {hints} to the command line"
    if isinstance(exc, InterpolationResolutionError):
        return (f"config key {key}: its interpolation does not resolve ({detail}); set {key}=<value> or fix the "
                f"reference")
    if isinstance(exc, (ConfigAttributeError, ConfigKeyError)):
        parent = getattr(exc, "parent_node", None)
        siblings = [str(k) for k in parent.keys()] if parent is not None and hasattr(parent, "keys") else []
        prefix = str(key).rsplit(".", 1)[0] + "." if "." in str(key) else ""
        added = _added_keys()  # in a run, only a key the command line added can be the misspelling
        offered = [f"{prefix}{k}" for k in siblings if added is None or f"{prefix}{k}" in added]
        close = difflib.get_close_matches(str(key), offered, n=1, cutoff=0.6)
        hint = f"; is {close[0]} a misspelling of it? " if close else "; "
        none = " (null for none)" if "(null" in _value_hint(str(key), cfg) else ""
        return (f"config key {key} is missing (deleted or misspelt){hint}restore it (drop the '~{key}' override) "
                f"or set it with '+{key}=<value>'{none}")
    return f"config key {key}: {detail}"


def edge_line(at_bounds: dict, how: str) -> str:
    """The sentence for coordinates that ended at an edge of identification's search box (``at_bounds``:
    ``{name: "lower" | "upper"}``); ``how``: the app's keys that widen the box."""
    groups: dict[str, list[tuple[str, str]]] = {}  # a network's weights, name[i], are one entry with counts
    for n, side in at_bounds.items():
        groups.setdefault(re.sub(r"\[\d+\]$", "[...]", n), []).append((n, side))
    edges = ", ".join(f"{members[0][0]} ({members[0][1]} edge)" if len(members) == 1 else
                      f"{group} ({len(members)} entries: {sum(s == 'lower' for _, s in members)} at the lower edge, "
                      f"{sum(s == 'upper' for _, s in members)} at the upper)" for group, members in groups.items())
    return (f"At the edge of the search box: {edges}. The box, not the data, set these values: widen it ({how}) "
            "or start nearer (the value in the model config).")


def say(text: str, *, error: bool = False) -> None:
    """Print ``text`` (to stderr when ``error``) and write it to the run's log file too (Hydra's job log,
    ``<run dir>/<app>.log``: the root logger's file handlers only, so the terminal shows it once). Without this
    the log held nothing: the apps speak through the terminal, and a run's own record of what it said, or why
    it was refused, was lost with the terminal."""
    print(text, file=sys.stderr if error else sys.stdout, flush=True)
    root = logging.getLogger()
    files = [h for h in root.handlers if isinstance(h, logging.FileHandler)]
    if files:
        record = root.makeRecord("hybridhyst", logging.ERROR if error else logging.INFO, __file__, 0, text, None, None)
        for handler in files:
            handler.handle(record)


def _added_keys() -> set[str] | None:
    """The keys the command line added (``+key=value`` overrides of this run); None outside a Hydra run (a
    config composed by the compose API), where every sibling may be the misspelling."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return None
    task = HydraConfig.get().overrides.task
    return {o.lstrip("+").split("=", 1)[0] for o in task if o.startswith("+")}


def guarded(run: Callable[[DictConfig], dict], cfg: DictConfig) -> dict:
    """Call ``run(cfg)``; a ``ValueError``, a missing file or a config error (``OmegaConfBaseException``: a
    deleted or misspelt key, an unset ``???``, an interpolation that does not resolve) becomes
    ``error: <message>`` on one line and exit code 2.

    SIGTERM and SIGINT (``hybridhyst.runs.interruptible``) end the run within seconds with one line, what it
    kept and how to resume (``RunInterrupted.note``, set by the app; ``interrupted_note`` otherwise), and exit
    code 128 + the signal's number (130 for Ctrl-C, 143 for SIGTERM), never 0. In a multirun the sweep stops
    there with that code: a killed job fails its sweep, and the jobs after it are not launched. The run
    directory this process claimed (``prepare_run_dir``) is released at the end, whatever happened.

    ``HYBRIDHYST_TRACEBACK=1`` re-raises instead (for debugging). In a Hydra multirun an error is re-raised
    after the message: Hydra marks that job failed, runs the others and fails the sweep at the end
    (``sys.exit`` inside a job would stop the whole sweep).
    """
    from omegaconf.errors import OmegaConfBaseException

    try:
        with interruptible():
            return run(cfg)
    except RunInterrupted as exc:
        note = getattr(exc, "note", None) or interrupted_note(cfg)
        say(f"interrupted by {exc.signame}: {note}{_sweep_note(cfg)}", error=True)
        if os.environ.get("HYBRIDHYST_TRACEBACK"):
            raise
        raise SystemExit(exc.exit_code) from None
    except (ValueError, FileNotFoundError, OmegaConfBaseException) as exc:
        if isinstance(exc, OmegaConfBaseException):
            message = config_error_message(exc, cfg)
        else:
            message = " ".join(str(exc).split()) or type(exc).__name__
        say(f"error: {message}", error=True)
        if os.environ.get("HYBRIDHYST_TRACEBACK") or _multirun():
            raise
        sys.exit(2)
    finally:
        release()


def interrupted_note(cfg) -> str:
    """What an interrupted run left: no finished results in its run directory."""
    where = run_dir_path(cfg) if isinstance(cfg, DictConfig) else None
    return f"no finished results in {where} (no complete.json)" if where else "nothing was written"


def _claim_named_run_dir(argv: list[str]) -> None:
    """Claim the run directory a single run names on its command line (``hydra.run.dir=...``) before Hydra writes
    its ``.hydra/`` record and log there: a second run into a directory in use is refused before it touches any
    of the first run's files (``prepare_run_dir`` claims it again, as the same process, inside the run)."""
    if any(a in ("-m", "--multirun") for a in argv):
        return
    for arg in argv:
        found = re.match(r"^\+{0,2}hydra\.run\.dir=(.+)$", arg)
        if found and "${" not in found.group(1):
            claim(found.group(1).strip("'\""))


def _sweep_note(cfg) -> str:
    """The sentence an interrupted multirun job adds: the sweep stops, and how to go on."""
    if not _multirun():
        return ""
    again = ("launch the same command again with +skip_finished=true to run only the jobs that did not finish"
             if isinstance(cfg, DictConfig) and cfg.get("app") == "train" else "launch it again")
    return f"; the sweep stops here and its later jobs are not run: {again}"


# keys and config names that were renamed: a command written for the old name is told the new one
RENAMED = {"identify.method": "identify.search", "identify.ode_method": "simulation.method",
           "identify.substeps": "simulation.substeps", "fit.method": "simulation.method",
           "fit.substeps": "simulation.substeps", "fit.backend": "simulation.backend",
           "discover.method": "simulation.method", "discover.substeps": "simulation.substeps",
           "discover.backend": "simulation.backend", "solver.method": "simulation.method",
           "solver.substeps": "simulation.substeps", "solver.backend": "simulation.backend",
           "solver.resolve": "resolve", "solver.max_substeps": "max_substeps",
           "nominal_init.method": "nominal_init.start",
           "seed000_pinn_identification": "vpptd_pinn_identification", "seed001_vpptd_dynamics": "vpptd_dynamics",
           "seed002_loop_metrics": "vpptd_loop_metrics", "seed003_hybrid_pinn_piezo": "piezo_hybrid_pinn",
           "seed003_hybrid_pinn_piezo_training": "piezo_hybrid_pinn_training",
           "seed004_symmetric_damper": "symmetric_damper", "loss=seed000": "loss=pinn_recipe"}


def _renamed_hint(text: str) -> str:
    """"; renamed: old -> new" for an old key or config name in Hydra's message (a ``group=option`` as Hydra writes
    it, ``group/option``, too), else ""."""
    for old, new in RENAMED.items():
        if re.search(rf"(?<![\w.]){re.escape(old)}(?![\w])", text) or ("=" in old and old.replace("=", "/") in text):
            return f"; {old} was renamed {new}: give {new} instead"
    return ""


def _without_append_hint(message: str) -> str:
    """Hydra's message without its "To append to your config use +key=...": the key is misspelt or renamed, and
    appending it would add the wrong key."""
    return re.sub(r"; To append to your config use \S+?=.*?(?= \(|;|$)", "", message, count=1)


def _composition_message(exc: Exception) -> str:
    """One line for Hydra's composition errors (an override of a key that is not in the config, a value that
    cannot be merged, an unknown config group option, a malformed override)."""
    cut = cut_short_message(exc)
    if cut:
        return cut
    text = str(exc).split("Config search path", 1)[0]
    head, _, options = text.partition("Available options in")
    parts = [p.strip().rstrip(".:") for p in head.splitlines() if p.strip()]
    message = "; ".join(parts)
    if options:  # "Available options in 'data':\n\tbrfd\n\t..." -> "options of 'data': brfd, ..."
        group, _, names = options.partition(":")
        message += f"; options of {group.strip()}: {', '.join(n.strip() for n in names.split() if n.strip())}"
    deleted = re.search(r"Could not delete from config\. '([^']+)' does not exist", message)
    if deleted:  # Hydra says so for a key that is there but null, too
        key = deleted.group(1)
        message += (f" (or it is null: nothing to delete); to change it, drop '~{key}' and give {key}=<value> "
                    "instead")
    cause = exc.__cause__
    if cause is not None and hasattr(cause, "full_key"):
        message += f" ({' '.join(str(cause).splitlines()[0].split())})"
        if "Cannot merge DictConfig with ListConfig" in str(cause):
            message += _type_change_hint(text)
        parent, key = getattr(cause, "parent_node", None), getattr(cause, "key", None)
        siblings = [str(k) for k in parent.keys()] if parent is not None and hasattr(parent, "keys") else []
        close = difflib.get_close_matches(str(key), siblings, n=1, cutoff=0.6) if key is not None else []
        if close and close[0] != str(key):
            full = str(getattr(cause, "full_key", key))
            prefix = full.rsplit(".", 1)[0] + "." if "." in full else ""
            # a misspelling: Hydra's "To append to your config use +key=..." would add the misspelt key
            message = _without_append_hint(message)
            message += f"; did you mean {prefix}{close[0]}?"
    renamed = _renamed_hint(message)
    if renamed:
        message = _without_append_hint(message)
        message = re.sub(r"; did you mean [^;]*\?$", "", message) + renamed
    return message


def _type_change_hint(text: str) -> str:
    """The hint for a list given where the config holds a mapping, or the other way round (OmegaConf's message
    is the same both ways; the override's value says which): the form the key takes, and how to change it."""
    found = re.search(r"override\s+\+{0,2}([^\s=]+)=\s*(\S)", text)
    if found is None:
        return "; a list was given where the config holds a mapping, or the other way round"
    key, first = found.groups()
    held, other = ("a mapping", "list") if first == "[" else ("a list", "mapping")
    example = "[{...}]" if first == "[" else "{...}"
    return (f"; {key} holds {held}" + (": give one, e.g. a mapping in brackets [{...}]" if held == "a list" else "")
            + f"; to give a {other} instead, delete the key first: '~{key}' '+{key}={example}'")


def hydra_entry(hydra_main: Callable[[], None]) -> None:
    """Run an app's ``@hydra.main`` function so that a composition error (a misspelt key in an override, a
    mapping given where the config holds a list, an unknown ``data=`` option) is also a one-line
    ``error: ...`` with exit code 2, like the errors ``guarded`` handles inside the run. Hydra re-raises
    instead of printing when ``HYDRA_FULL_ERROR`` is set, which this sets for the call (unless the user
    set it, or ``HYBRIDHYST_TRACEBACK``, to see tracebacks); any other exception propagates unchanged.
    SIGTERM and SIGINT outside a run (between a sweep's jobs) end the process with one line and 128 + the
    signal's number, as they do inside one (``guarded``).
    """
    from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException

    try:
        check_search_path()
        _claim_named_run_dir(sys.argv[1:])
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        sys.exit(2)
    if os.environ.get("HYDRA_FULL_ERROR") or os.environ.get("HYBRIDHYST_TRACEBACK"):
        hydra_main()
        return
    os.environ["HYDRA_FULL_ERROR"] = "1"
    try:
        with interruptible():  # between a sweep's jobs too: a signal there stops the sweep with its exit code
            hydra_main()
    except (ConfigCompositionException, MissingConfigException, OverrideParseException) as exc:
        print(f"error: {_composition_message(exc)}", file=sys.stderr, flush=True)
        sys.exit(2)
    except RunInterrupted as exc:
        print(f"interrupted by {exc.signame} between runs; a sweep stops here and its later jobs are not run: launch "
              "the same command again (hybridhyst-train: with +skip_finished=true, to run only the jobs that did not "
              "finish)", file=sys.stderr, flush=True)
        sys.exit(exc.exit_code)
    finally:
        os.environ.pop("HYDRA_FULL_ERROR", None)
        release()


def _multirun() -> bool:
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN
