"""The one progress bar of long work (searches, refinement, discovery, studies): tqdm, off when not wanted.

Below every package that runs long work, so each uses the same bar: ``progress(iterable, "what")`` wraps
an iterable, ``progress(total=n, desc="what")`` gives a bar advanced with ``update``; ``enabled=False``
gives a silent one (same interface), so callers never branch on it.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable

__all__ = ["progress"]


def progress(items: Iterable | None = None, desc: str = "", *, total: int | None = None, enabled: bool = True):
    """A tqdm bar over ``items`` (or of ``total`` steps) that clears itself when done; silent if not ``enabled``,
    and where nobody watches it: stderr not a terminal (a log redirected to a file would fill with the bar's
    carriage-return redraws) and not a notebook."""
    from tqdm.auto import tqdm

    shown = enabled and (_interactive(sys.stderr) or _notebook(tqdm))
    return tqdm(items, desc=desc, total=total, disable=not shown, leave=False, dynamic_ncols=True)


def _interactive(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # a replaced or closed stream
        return False


def _notebook(bar) -> bool:
    """Whether tqdm.auto chose its notebook bar (an IPython kernel, where stderr is no terminal but the bar shows)."""
    try:
        from tqdm.notebook import tqdm_notebook
    except ImportError:
        return False
    return issubclass(bar, tqdm_notebook)
