"""Helpers shared by the Hydra apps: config location, run directory, atomic writes, error handling.

Every app is a plain ``run(cfg) -> dict`` (tests call it with a composed config) plus a thin
``@hydra.main`` wrapper that goes through ``guarded`` so that a ``ValueError`` (bad data, bad option)
ends the process with a one-line ``error: ...`` on stderr and exit code 2 instead of a traceback.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import random
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

__all__ = [
    "CONF_DIR",
    "atomic_write",
    "guarded",
    "instantiate",
    "jsonable",
    "parameter_table",
    "prepare_run_dir",
    "torch_settings",
    "write_json",
]

# The Hydra config tree is the repository's top-level ``conf/`` (install with ``pip install -e .`` so that
# it sits next to the package); HYBRIDHYST_CONF points elsewhere.
CONF_DIR = str(Path(os.environ.get("HYBRIDHYST_CONF", Path(__file__).resolve().parents[2] / "conf")))


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


@contextlib.contextmanager
def _atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path next to ``path`` that replaces it (``os.replace``) when the block succeeds."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; a result file gets the usual permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_write(path: Path | str, content: str | bytes | Callable[[Path], None]) -> Path:
    """Write ``content`` (text, bytes, or a function that writes a given path) to ``path`` atomically.

    An interrupted run never leaves a half-written file that a report would read.
    """
    path = Path(path)
    with _atomic_path(path) as tmp:
        if callable(content):
            content(tmp)
        elif isinstance(content, bytes):
            tmp.write_bytes(content)
        else:
            tmp.write_text(content, encoding="utf-8")
    return path


def jsonable(obj):
    """Plain-JSON version of ``obj``: numpy/torch scalars to floats, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, torch.Tensor):
        return jsonable(obj.detach().cpu().tolist())
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def to_plain(node):
    """An OmegaConf node as plain python containers (other values unchanged)."""
    from omegaconf import DictConfig, ListConfig, OmegaConf

    return OmegaConf.to_container(node, resolve=True) if isinstance(node, (DictConfig, ListConfig)) else node


def write_json(path: Path | str, obj) -> Path:
    """Atomic JSON write (temp file + ``os.replace``)."""
    return atomic_write(path, json.dumps(jsonable(obj), indent=2) + "\n")


def instantiate(node, **kwargs):
    """``hydra.utils.instantiate`` that re-raises a target's ``ValueError`` as itself (not wrapped)."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate as _instantiate

    try:
        return _instantiate(node, **kwargs)
    except InstantiationException as exc:
        cause = exc.__cause__
        if isinstance(cause, (ValueError, FileNotFoundError)):
            raise cause from None
        detail = f": {cause}" if cause is not None else ""
        raise ValueError(str(exc).splitlines()[0].rstrip(":") + detail) from exc


def parameter_table(model) -> dict[str, dict[str, dict]]:
    """{effect: {parameter: {"value": float or text, "unit": str, "fixed": bool}}} of a nominal model.

    Constant parameters give a number; condition-dependent ones their description (e.g. a polynomial).
    """
    from ..physics.parameters import Constant, Fixed

    out: dict[str, dict[str, dict]] = {}
    described = model.describe()
    for key, params in described.items():
        if key in getattr(model, "effects", {}):
            fns = dict(model.effects[key].params.items())
        else:
            fns = dict(getattr(model, "structure_params", {}).items())
        out[key] = {}
        for pname, info in params.items():
            fn = fns.get(pname)
            if isinstance(fn, (Constant, Fixed)):
                value = float(fn(None, 1)[0].detach())
            else:
                value = info["value"]
            out[key][pname] = {"value": value, "unit": info["unit"], "fixed": isinstance(fn, Fixed)}
    return out


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


def check_app(cfg: DictConfig, app: str) -> None:
    """Experiment configs say which app they belong to (``app:``); refuse one meant for another app."""
    if cfg.get("app", app) != app:
        raise ValueError(f"this configuration (experiment {cfg.get('experiment_name') or ''!s}) is for "
                         f"hybridhyst-{cfg.app}, not hybridhyst-{app}")


def guarded(run: Callable[[DictConfig], dict], cfg: DictConfig) -> dict:
    """Call ``run(cfg)``; a ``ValueError`` or a missing file becomes ``error: <message>`` and exit code 2.

    ``HYBRIDHYST_TRACEBACK=1`` re-raises instead (for debugging). In a Hydra multirun the exception is
    re-raised after the message: Hydra marks that job failed, runs the others and fails the sweep at the
    end (``sys.exit`` inside a job would stop the whole sweep).
    """
    try:
        return run(cfg)
    except (ValueError, FileNotFoundError) as exc:
        message = " ".join(str(exc).split()) or type(exc).__name__
        if os.environ.get("HYBRIDHYST_TRACEBACK") or _multirun():
            print(f"error: {message}", file=sys.stderr, flush=True)
            raise
        print(f"error: {message}", file=sys.stderr, flush=True)
        sys.exit(2)


def _multirun() -> bool:
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN
