"""Files a run writes: its run directory, atomic writes (temp file + rename) and plain JSON.

Below every package that writes results (apps, reports, studies, discovery), so none of them reaches up into
``cli`` for it. An interrupted run never leaves a half-written file that a report would read.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import torch

__all__ = ["atomic_write", "jsonable", "prepare_run_dir", "run_dir_path", "write_json"]


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


def write_json(path: Path | str, obj) -> Path:
    """Atomic JSON write (temp file + ``os.replace``)."""
    return atomic_write(path, json.dumps(jsonable(obj), indent=2) + "\n")


def run_dir_path(cfg) -> Path:
    """The run directory of a Hydra config: Hydra's output dir under ``@hydra.main``, else ``cfg.run_dir``,
    else the cwd (nothing is created)."""
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized():
        return Path(HydraConfig.get().runtime.output_dir)
    return Path(cfg.get("run_dir") or os.getcwd())


def prepare_run_dir(cfg) -> Path:
    """``run_dir_path(cfg)``, created, with the resolved config written there as ``config.yaml``."""
    from omegaconf import OmegaConf

    path = run_dir_path(cfg)
    path.mkdir(parents=True, exist_ok=True)
    atomic_write(path / "config.yaml", OmegaConf.to_yaml(cfg, resolve=True))
    return path
