"""Reproductions of the seed papers as studies run by ``hybridhyst-study experiment=<name>``.

A study is a function ``study(options: dict, out: StudyOutput) -> dict`` in one module per seed paper; it
uses the library (physics, simulate, identify, training, analysis) and writes its tables and figures
through ``out``. The returned dict becomes ``summary.json``. ``options["reduced"]`` asks for the small
version that CI runs (same code path, fewer conditions/epochs). Studies are registered by name in
``STUDIES`` ("module:function", imported on use so that one study's dependencies never slow another).
"""

from __future__ import annotations

import copy
import importlib
from collections.abc import Callable

from .output import StudyOutput as StudyOutput

STUDIES: dict[str, str] = {
    "vpptd_pinn_identification": "seed000:pinn_identification",
    "vpptd_dynamics": "seed001:vpptd_dynamics",
    "vpptd_loop_metrics": "seed002:loop_metrics",
    "piezo_hybrid_pinn": "seed003:hybrid_pinn_piezo",
    "symmetric_damper": "seed004:symmetric_damper",
}


def resolve_options(options: dict, required, study: str) -> dict:
    """A study's options: ``reduced_options`` merged over them when ``options["reduced"]`` (a dict value is
    merged one level deep), after checking that every ``required`` key is given."""
    missing = [k for k in required if k not in options]
    if missing:
        raise ValueError(f"{study} study: missing option(s) {missing}; see conf/experiment/{study}.yaml")
    opts = {k: copy.deepcopy(v) for k, v in options.items() if k != "reduced_options"}
    if options.get("reduced"):
        for key, value in (options.get("reduced_options") or {}).items():
            opts[key] = {**opts[key], **value} if isinstance(value, dict) and isinstance(opts.get(key), dict) else value
    return opts


def get_study(name: str) -> Callable[[dict, StudyOutput], dict]:
    """The study function registered as ``name`` (a clear error naming the known studies otherwise)."""
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r}; choose one of {sorted(STUDIES)}")
    module, func = STUDIES[name].split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), func)


__all__ = ["STUDIES", "StudyOutput", "get_study", "resolve_options"]
