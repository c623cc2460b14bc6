"""Files a run writes and reads: atomic writes (temp file + rename), plain JSON, weights-only loading (the run
directory itself: ``hybridhyst.runs``).

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

__all__ = ["atomic_write", "jsonable", "load_weights", "not_weights", "write_json"]


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


def not_weights(path: Path | str, exc: Exception) -> ValueError:
    """The error for a file that ``torch.load(weights_only=True)`` refused: not a torch file at all (empty,
    truncated, another format), or one holding objects other than tensors and plain values, which unpickling
    would have to run as code."""
    what = ("holds objects other than tensors, numbers and strings, which loading would have to run as code"
            if "Unsupported global" in str(exc) else
            "is not a torch file hybridhyst can read (empty, truncated or another format)")
    return ValueError(f"{path} {what}: not loaded (a file a run reads is data, never code); give a checkpoint or "
                      "model.pt written by hybridhyst")


def load_weights(path: Path | str):
    """``torch.load(path, weights_only=True)`` on the CPU: tensors and plain containers only, never code; a file
    that holds anything else is a ``ValueError`` (``not_weights``)."""
    import pickle

    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, EOFError, RuntimeError) as exc:
        raise not_weights(path, exc) from None
