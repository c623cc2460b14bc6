"""The one progress bar of long work (searches, refinement, discovery, studies): tqdm on a terminal, plain lines
in a log, off when not wanted.

Below every package that runs long work, so each uses the same bar: ``progress(iterable, "what")`` wraps
an iterable, ``progress(total=n, desc="what")`` gives a bar advanced with ``update``; ``enabled=False``
gives a silent one (same interface), so callers never branch on it.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable

__all__ = ["INTERVAL_S", "Lines", "progress"]


INTERVAL_S = 10.0  # at most one plain line per this many seconds where stderr is not a terminal


def progress(items: Iterable | None = None, desc: str = "", *, total: int | None = None, enabled: bool = True):
    """A tqdm bar over ``items`` (or of ``total`` steps) that clears itself when done, where someone watches it
    (stderr a terminal, or a notebook); silent if not ``enabled``.

    Where stderr is not a terminal (a job's output redirected to a file) a redrawn bar would fill the file with
    carriage returns, and no output at all left a 21-minute job silent: there, ``Lines`` writes a plain line
    (what, step/total, elapsed) once work has gone on for ``INTERVAL_S``, at most one line per ``INTERVAL_S`` over
    every bar of the process, and one when work that wrote a line ends. Short work writes nothing."""
    from tqdm.auto import tqdm

    if not enabled:
        return tqdm(items, desc=desc, total=total, disable=True)
    if _interactive(sys.stderr) or _notebook(tqdm):
        return tqdm(items, desc=desc, total=total, leave=False, dynamic_ncols=True)
    return Lines(items, desc, total=total)


class Lines:
    """The bar's interface (iteration, ``update``, ``set_postfix``, ``close``, a context manager) as plain lines on
    stderr: ``<desc>: <n>/<total> (<elapsed> s[, postfix])``, written by ``update`` when this bar has run for
    ``INTERVAL_S`` and no bar has written for ``INTERVAL_S``, and by ``close`` when this bar wrote before
    (``<desc>: done, <n>/<total> in <elapsed> s``)."""

    disable = False
    last_line = -float("inf")  # monotonic time of the last line any bar wrote (one clock for the whole process)

    def __init__(self, items: Iterable | None = None, desc: str = "", *, total: int | None = None,
                 stream=None, interval: float | None = None):
        if total is None and items is not None and hasattr(items, "__len__"):
            total = len(items)
        self.items, self.desc, self.total, self.n = items, desc or "working", total, 0
        self.stream, self.interval = stream, INTERVAL_S if interval is None else float(interval)
        self.start, self.postfix, self.wrote, self.closed = time.monotonic(), "", False, False

    def _write(self, text: str) -> None:
        print(text, file=self.stream or sys.stderr, flush=True)
        self.wrote = True
        Lines.last_line = time.monotonic()

    def _where(self) -> str:
        return f"{self.n}/{self.total}" if self.total else f"{self.n}"

    def update(self, n: int = 1) -> None:
        self.n += n
        now = time.monotonic()
        if now - self.start >= self.interval and now - Lines.last_line >= self.interval:
            post = f", {self.postfix}" if self.postfix else ""
            self._write(f"{self.desc}: {self._where()} ({now - self.start:.0f} s{post})")

    def set_postfix(self, ordered_dict=None, refresh: bool = True, **kwargs) -> None:
        values = {**dict(ordered_dict or {}), **kwargs}
        self.postfix = ", ".join(f"{k}={v}" for k, v in values.items())

    def set_description(self, desc: str = "", refresh: bool = True) -> None:
        self.desc = desc or self.desc

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self.wrote:
            self._write(f"{self.desc}: done, {self._where()} in {time.monotonic() - self.start:.0f} s")

    def __iter__(self):
        try:
            for item in self.items:
                yield item
                self.update(1)
        finally:
            self.close()

    def __len__(self) -> int:
        return int(self.total or 0)

    def __bool__(self) -> bool:  # a bar is truthy whatever its length (``if bar:`` never means "has steps")
        return True

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


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
