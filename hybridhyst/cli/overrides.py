"""The command line's overrides checked against the config they change, before an app starts.

Hydra accepts ``fit.steps=abc`` (a string where the config holds a number: the app's cast fails later with
Python's "invalid literal for int()", naming no key) and ``+fit.stepz=10`` (a key the app never reads: silently
ignored). ``check_overrides`` compares each override with the app's *schema*, the config composed with the same
group choices (``model=``, ``data=``, ``experiment=``, ``hydra.*``) but without the value overrides, and refuses:

* a value override whose config value is a number (a boolean) given as text that is not one, naming the key;
* a key added with ``+`` (or ``++``) that is not in the schema, naming the closest key that is. Keys under
  free-form mappings are accepted: condition queries (``split.select``), keyword arguments that the code reading
  them checks itself (``datamodule``, ``identify``, ``nominal_init.settings``, ``trainer.extra``), an instantiated
  node's arguments (``model``, ``data``: the builder checks them), any mapping the config leaves empty or null
  (``conditions: {}``), and keys an app reads with a default (``+skip_finished=true`` for hybridhyst-train).

It runs only inside the app's own Hydra run (``HydraConfig`` names the app's config): a config composed with the
compose API has no record of its overrides, and an app called from another one's run (a study) is not checked
against that run's command line. A schema that cannot be composed skips the check: it never refuses a run that
would work.

``cut_short_message`` is the other half, for ``hydra_entry``: an unquoted mapping on the shell
(``data.units={t: s, x: deg}``) arrives as several arguments, and Hydra's parser error on the first says nothing
of quoting; the message shows the whole override, quoted.
"""

from __future__ import annotations

import difflib
import sys

from omegaconf import DictConfig, OmegaConf

from ..settings import CONF_DIR
from ..training.config import not_a_number

__all__ = ["check_overrides", "check_search_path", "cut_short_message"]

# mappings whose keys are free-form or checked by the code that reads them ('+key' under them is accepted)
FREE_FORM = ("split.select", "split.held_out", "split.val", "input.select", "conditions", "study_options",
             "nominal_init.settings", "identify", "discover.identify", "datamodule", "trainer.extra")
# keys an app reads with a default where its config leaves them out: '+key=value' sets them
OPTIONAL_KEYS = {"train": ("skip_finished", "loss.normalise")}
# keys whose number (boolean) in the config does not make text wrong: Lightning reads devices="auto" or "0,1";
# discover.conditions takes true, a condition's name or a list
TEXT_ALLOWED = ("trainer.devices", "discover.conditions")

_MISSING = object()


def check_overrides(cfg: DictConfig, app: str) -> None:
    """Refuse, with a one-line ``ValueError`` naming the key and the fix, a value override of a number (a boolean)
    that is not one and a ``+`` key that ``app`` would ignore (module docstring). Does nothing outside the app's
    own Hydra run."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return
    hydra_cfg = HydraConfig.get()
    if hydra_cfg.job.get("config_name") != app:
        return
    parsed = _parse(list(hydra_cfg.overrides.task))
    choices = set(hydra_cfg.runtime.get("choices") or {})
    structural = [o for o in parsed if _is_group(o, choices) or _is_hydra(o.key_or_group)]
    values = [o for o in parsed if all(o is not s for s in structural) and not o.is_delete()]
    if not values:
        return
    searchpath = [line for line in hydra_cfg.overrides.hydra if line.startswith("hydra.searchpath=")]
    schema = _schema(app, [*searchpath, *(o.input_line for o in structural)])
    if schema is None:
        return
    for o in values:
        key = o.key_or_group
        present = _node(schema, key) is not _MISSING
        if o.is_add() or (o.is_force_add() and not present):
            if not (present or key in OPTIONAL_KEYS.get(app, ()) or _free_form(schema, key)):
                raise ValueError(_unread_message(app, o, schema, cfg))
        else:
            _check_types(key, _plain(_node(cfg, key)), _plain(_node(schema, key)), _instantiated(schema, key))


def _parse(lines: list[str]) -> list:
    from hydra.core.override_parser.overrides_parser import OverridesParser

    try:
        return OverridesParser.create().parse_overrides(lines)
    except Exception:  # Hydra parsed them to compose this config: a failure here is not the user's
        return []


def _is_group(override, choices: set[str]) -> bool:
    key = override.key_or_group
    return key in choices or "/" in key or override.package is not None


def _is_hydra(key: str) -> bool:
    return key == "hydra" or key.startswith("hydra.")


def _schema(app: str, overrides: list[str]) -> DictConfig | None:
    """The app's config composed with ``overrides`` (group choices and ``hydra.*``) only; None where it cannot be."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.types import RunMode

    try:
        if GlobalHydra.instance().is_initialized():  # the app's run: its search path (hydra.searchpath) included
            return GlobalHydra.instance().hydra.compose_config(app, overrides, run_mode=RunMode.RUN, from_shell=True,
                                                               with_log_configuration=False)
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            return compose(app, overrides=overrides)
    except Exception:
        return None


def _node(cfg, key: str):
    """The node at dotted ``key`` (not resolved), or ``_MISSING`` where there is none."""
    node = cfg
    for part in key.split("."):
        if not isinstance(node, DictConfig) or part not in node:
            return _MISSING
        node = node._get_node(part)
    return node


def _plain(node):
    """A node's value as plain Python (resolved where it resolves), ``_MISSING`` for none or one that does not."""
    if node is _MISSING:
        return _MISSING
    try:
        if isinstance(node, DictConfig) or OmegaConf.is_list(node):
            return OmegaConf.to_container(node, resolve=True)
        return node._dereference_node()._value()
    except Exception:
        return _MISSING


def _instantiated(schema, key: str) -> bool:
    """Whether ``key`` lies in a node built by its ``_target_`` (a model's, a dataset's arguments)."""
    parts = key.split(".")
    for i in range(len(parts)):
        node = _node(schema, ".".join(parts[:i])) if i else schema
        if isinstance(node, DictConfig) and "_target_" in node:
            return True
    return False


def _free_form(schema, key: str) -> bool:
    """Whether a key added at ``key`` lies in a free-form mapping of the schema (module docstring)."""
    parts = key.split(".")
    for i in range(1, len(parts)):
        prefix = ".".join(parts[:i])
        node = _node(schema, prefix)
        if node is _MISSING:
            return False
        if prefix in FREE_FORM or (isinstance(node, DictConfig) and "_target_" in node):
            return True
        value = _plain(node)
        if value is None or value == {}:
            return True
    return False


def _check_types(key: str, new, old, instantiated: bool) -> None:
    """``new`` given for ``key`` where the schema holds ``old``: text for a number or a boolean is refused."""
    if isinstance(old, dict) and isinstance(new, dict):
        for k in new.keys() & old.keys():
            _check_types(f"{key}.{k}", new[k], old[k], instantiated or "_target_" in old)
        return
    if key in TEXT_ALLOWED or new is _MISSING or old is _MISSING or new is None:
        return
    if isinstance(old, bool):
        if isinstance(new, str):
            raise ValueError(f"config key {key} must be true or false, got {new!r}: give {key}=true or {key}=false")
    elif isinstance(old, (int, float)):
        if isinstance(new, bool) or (isinstance(new, str) and not _is_number(new)):
            raise not_a_number(key, new, whole=isinstance(old, int) and not instantiated)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _paths(node, prefix: str = "") -> list[str]:
    """Every dotted key of a plain mapping (inner nodes and leaves), ``hydra`` left out."""
    out = []
    for k, v in node.items() if isinstance(node, dict) else ():
        path = f"{prefix}{k}"
        if path == "hydra":
            continue
        out.append(path)
        out += _paths(v, f"{path}.")
    return out


def _closest(key: str, paths: list[str]) -> str | None:
    close = difflib.get_close_matches(key, paths, n=1, cutoff=0.6)
    if close:
        return close[0]
    leaf = key.rsplit(".", 1)[-1]  # the right name in another place: '+select' for split.select
    same = [p for p in paths if difflib.SequenceMatcher(None, leaf, p.rsplit(".", 1)[-1]).ratio() >= 0.8]
    return same[0] if len(same) == 1 else None


def _unread_message(app: str, override, schema, cfg) -> str:
    key, line = override.key_or_group, override.input_line
    value = line.split("=", 1)[1] if "=" in line else ""
    paths = _paths(OmegaConf.to_container(schema, resolve=False))
    close = _closest(key, paths)
    head = f"config key {key} (added with '+') is not one hybridhyst-{app} reads: it would be ignored"
    if close is not None:
        given = f"{close}={value}" if _node(cfg, close) is not _MISSING else f"'+{close}={value}'"
        return f"{head}; did you mean {close}? give {given} instead of '{line}'"
    parent = key.rsplit(".", 1)[0] if "." in key else ""
    siblings = _plain(_node(schema, parent)) if parent else None
    known = f" ({parent} has {', '.join(map(str, siblings))})" if isinstance(siblings, dict) and siblings else ""
    return f"{head}; drop '{line}'{known}"


def cut_short_message(exc: Exception, argv: list[str] | None = None) -> str:
    """The message for an override the shell cut short ('' for any other error): an unquoted mapping or list with
    spaces (``data.units={t: s, x: deg}``) reaches Hydra as several arguments, the first of which does not parse
    (``OverrideParseException.override``). The override is put back together from the command line (``argv``:
    ``sys.argv[1:]``) and shown quoted."""
    broken = getattr(exc, "override", None)
    if not isinstance(broken, str) or _unclosed(broken) <= 0:
        return ""
    args = list(sys.argv[1:] if argv is None else argv)
    whole = broken
    if broken in args:
        rest = args[args.index(broken) + 1:]
        while rest and _unclosed(whole) > 0:
            whole += " " + rest.pop(0)
    detail = " ".join(str(getattr(exc, "message", "") or exc).splitlines()[0].split())
    return (f"override '{broken}' is cut short ({detail}): the shell splits an unquoted mapping or list at its "
            f"spaces; quote the whole override: '{whole}'")


def _unclosed(text: str) -> int:
    """Brackets and braces opened in ``text`` and not closed (quoted text skipped)."""
    depth, quote = 0, None
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
    return depth


def check_search_path(argv: list[str] | None = None) -> None:
    """Refuse, before Hydra reads anything, a run directory on ``hydra.searchpath`` whose config files set Hydra's
    own settings: a ``# @package`` directive, a ``defaults`` list or a ``hydra`` key (callbacks, launchers,
    sweepers), which Hydra instantiates before any app code runs. A model config that an app writes into its run
    directory (``model/<name>.yaml``) has none of them; a folder of the user's own configs (not a run directory)
    is the user's and is not checked. Hydra's own record of the run (``.hydra/``) is not a config group an override
    can name (a group's name cannot start with a dot), so it is not read either."""
    import re
    from pathlib import Path

    import yaml

    from ..runs import is_run_dir

    argv = sys.argv[1:] if argv is None else argv
    folders = [Path(p) for arg in argv if re.match(r"^\+{0,2}hydra\.searchpath=", arg)
               for p in re.findall(r"file://([^,\]\s'\"]+)", arg)]
    for folder in folders:
        if not is_run_dir(folder):
            continue
        files = [*folder.glob("*.yaml"), *(f for f in folder.glob("*/*.yaml") if not f.parent.name.startswith("."))]
        for file in sorted(files):
            text = file.read_text(encoding="utf-8", errors="replace")
            try:
                top = yaml.safe_load(text)
            except yaml.YAMLError:
                top = None
            keys = set(top) if isinstance(top, dict) else set()
            if re.search(r"^\s*#\s*@package", text, flags=re.M) or keys & {"hydra", "defaults"}:
                raise ValueError(f"{file}: a config in run directory {folder} sets Hydra's own settings (a "
                                 "'# @package' line, 'defaults' or 'hydra'), which can run code before any check: not "
                                 "read; a run directory's model config is plain effects and values (model/<name>.yaml "
                                 "as hybridhyst writes it)")
