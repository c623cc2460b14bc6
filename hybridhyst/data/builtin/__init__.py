"""Datasets bundled with hybridhyst: ``load_builtin("brfd" | "boucwen" | "vpptd", **options)``.

* ``brfd``: measured banded rotary friction damper, 35 records (CC BY-SA 4.0, see ``files/brfd``);
* ``boucwen``: the Bouc–Wen system-identification benchmark, 3 records (MIT, see ``files/boucwen``);
* ``vpptd``: synthetic vacuum-packed-particle torsional damper loops simulated from seed 001 Table 1.

The data files live in ``files/`` inside the package; nothing is read from outside it. Synthetic datasets
are made by simulating a model, which this layer may not import: they live in ``hybridhyst.synth`` and
register their loader here (``register_builtin``) when ``hybridhyst`` is imported.
"""

from __future__ import annotations

import difflib
import inspect

from ..records import RecordSet
from .boucwen import load_boucwen
from .brfd import load_brfd

__all__ = ["BUILTINS", "load_builtin", "register_builtin"]

BUILTINS = {"brfd": load_brfd, "boucwen": load_boucwen}


def register_builtin(name: str, loader) -> None:
    """Make ``load_builtin(name, **options)`` call ``loader(**options)`` (a dataset made above this layer)."""
    if name in BUILTINS and BUILTINS[name] is not loader:
        raise ValueError(f"built-in dataset {name!r} is already registered")
    BUILTINS[name] = loader


def load_builtin(name: str, **options) -> RecordSet:
    """Load a bundled dataset by name.

    Parameters
    ----------
    name : "brfd", "boucwen" or "vpptd".
    **options : passed to the dataset's loader (``load_brfd``, ``load_boucwen``, ``load_vpptd``).

    Raises
    ------
    ValueError
        For an unknown dataset name or option (naming the closest one).
    """
    if name not in BUILTINS:
        close = difflib.get_close_matches(str(name), BUILTINS, n=1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise ValueError(f"unknown built-in dataset {name!r}; {hint}available: {sorted(BUILTINS)}")
    loader = BUILTINS[name]
    allowed = list(inspect.signature(loader).parameters)
    for key in options:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ValueError(f"built-in dataset {name!r} has no option {key!r}; {hint}options: {allowed}")
    return loader(**options)
