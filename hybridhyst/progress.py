"""The one progress bar of long work (searches, refinement, discovery, studies): tqdm, off when not wanted.

Below every package that runs long work, so each uses the same bar: ``progress(iterable, "what")`` wraps
an iterable, ``progress(total=n, desc="what")`` gives a bar advanced with ``update``; ``enabled=False``
gives a silent one (same interface), so callers never branch on it.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["progress"]


def progress(items: Iterable | None = None, desc: str = "", *, total: int | None = None, enabled: bool = True):
    """A tqdm bar over ``items`` (or of ``total`` steps) that clears itself when done; silent if not ``enabled``."""
    from tqdm.auto import tqdm

    return tqdm(items, desc=desc, total=total, disable=not enabled, leave=False, dynamic_ncols=True)
