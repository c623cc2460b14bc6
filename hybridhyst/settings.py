"""Where the Hydra config tree is, and the numeric settings of one run (dtype, threads, seeds).

Below every package that runs something (apps, studies, discovery, training), so none of them reaches up
into ``cli`` for it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import os
import random
import types
import typing
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch

__all__ = ["CONF_DIR", "UnknownOption", "check_fields", "from_mapping", "intra_op_threads", "torch_settings"]

# The Hydra config tree is the repository's top-level ``conf/`` (install with ``pip install -e .`` so that
# it sits next to the package); HYBRIDHYST_CONF points elsewhere.
CONF_DIR = str(Path(os.environ.get("HYBRIDHYST_CONF", Path(__file__).resolve().parents[1] / "conf")))


@contextlib.contextmanager
def torch_settings(dtype: str = "float64", threads: int | None = None, seed: int | None = 0):
    """Default dtype, intra-op threads and seeds for one run; restored afterwards.

    The simulator's per-step cost is Python overhead on small tensors, so one thread is usually fastest.
    """
    if dtype not in ("float32", "float64"):
        raise ValueError(f"dtype must be 'float32' or 'float64', got {dtype!r}")
    old_dtype, old_threads = torch.get_default_dtype(), torch.get_num_threads()
    torch.set_default_dtype(getattr(torch, dtype))
    if threads:
        torch.set_num_threads(int(threads))
    if seed is not None:
        random.seed(seed)
        np.random.seed(seed)
        torch.manual_seed(seed)
    try:
        yield
    finally:
        torch.set_default_dtype(old_dtype)
        torch.set_num_threads(old_threads)


@contextlib.contextmanager
def intra_op_threads(n: int | None):
    """torch's intra-op threads set to ``n`` for a block (None: left as they are), restored afterwards.

    Identification and discovery spend their time in the compiled loops and in many small tensor operations,
    where torch's threads only wait for each other: with two processes on a 2-core machine (pytest-xdist, a
    test bed's workers) torch's default threads made discovery 5-16x slower than one thread each."""
    old = torch.get_num_threads()
    if n:
        torch.set_num_threads(int(n))
    try:
        yield
    finally:
        torch.set_num_threads(old)


def _cast(value, hint, key: str):
    """``value`` as the type ``hint`` names: int, float, bool, str, a dataclass (from a mapping), unions of them
    (the first that takes the value), containers as they are."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        args = typing.get_args(hint)
        if value is None:
            if type(None) in args:
                return None
            raise ValueError(f"{key} must not be null")
        errors = []
        for arg in (a for a in args if a is not type(None)):
            try:
                return _cast(value, arg, key)
            except ValueError as e:
                errors.append(str(e))
        raise ValueError(" or ".join(errors))
    if dataclasses.is_dataclass(hint) and isinstance(hint, type):
        if isinstance(value, hint):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"{key} must be a mapping of {sorted(f.name for f in dataclasses.fields(hint))}")
        return from_mapping(hint, value, key)
    if hint is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{key} must be true or false, got {value!r}")
        return value
    if hint in (int, float):
        whole = hint is int
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (whole and float(value) != int(value)):
            raise ValueError(f"{key} must be {'a whole number' if whole else 'a number'}, got {value!r}")
        return hint(value)
    if hint is str:
        if not isinstance(value, str):
            raise ValueError(f"{key} must be a string, got {value!r}")
        return value
    return value


class UnknownOption(TypeError, ValueError):
    """An option a settings object does not have: a ``TypeError`` for a Python call, a ``ValueError`` (the one-line
    config error) for an app."""


def check_fields(cls, keys, where: str, renamed: Mapping[str, str] | None = None) -> None:
    """An ``UnknownOption`` for the first of ``keys`` that is not a field of the dataclass ``cls``, naming what it was
    renamed to (``renamed``) or the closest field: the one check of every settings object's names."""
    fields = [f.name for f in dataclasses.fields(cls) if f.init]
    for key in keys:
        if key in fields:
            continue
        if renamed and key in renamed:
            hint = f"{where}.{key} was renamed: use {renamed[key]}; "
        else:
            close = difflib.get_close_matches(str(key), fields, n=1)
            hint = f"did you mean {where}.{close[0]}? " if close else ""
        raise UnknownOption(f"unknown config key {where}.{key}: {hint}{where} takes {sorted(fields)}")


def from_mapping(cls, mapping: Mapping | None, where: str, **given):
    """An instance of the dataclass ``cls`` from a config block ``mapping`` (plain or OmegaConf) with ``given``
    laid over it: the one typed schema every settings object is read through. A key ``cls`` does not have is a
    one-line error naming ``where.key`` and the closest field; a value of the wrong type names the key and the type
    it needs. Missing keys take the field's default."""
    hints = typing.get_type_hints(cls)
    values = dict(mapping or {})
    values.update(given)
    check_fields(cls, values, where)
    return cls(**{key: _cast(_plain(value), hints[key], f"{where}.{key}") for key, value in values.items()})


def _plain(value):
    """OmegaConf containers as plain Python (without importing OmegaConf here)."""
    if hasattr(value, "_metadata") and hasattr(value, "_get_node"):
        from omegaconf import OmegaConf

        return OmegaConf.to_container(value, resolve=True)
    return value
