"""Where the Hydra config tree is, and the numeric settings of one run (dtype, threads, seeds).

Below every package that runs something (apps, studies, discovery, training), so none of them reaches up
into ``cli`` for it.
"""

from __future__ import annotations

import contextlib
import os
import random
from pathlib import Path

import numpy as np
import torch

__all__ = ["CONF_DIR", "intra_op_threads", "torch_settings"]

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
