"""A run's life in its run directory: one process at a time, results complete or absent, interruptions that say so.

Below every package that writes a run directory (apps, studies), beside ``hybridhyst.files`` (how a file is
written). Three rules, each one object here:

- **One run per run directory** (``claim``): the run holds an exclusive ``flock`` on ``.lock`` (which names its
  process and host); a second process is refused with a one-line error while the first holds it. The lock
  ends with its process however that ends, so a killed run never blocks the next; the process that holds a
  directory may claim it again (a test or a study calling several apps in turn).
- **Complete or absent** (``begin_results``, ``mark_complete``, ``require_complete``): a run removes the
  marker ``complete.json`` before it writes anything and writes it after its last result, atomically, listing
  the files it wrote. A model config, a state dict or a report read from a run directory without the marker
  was left by a run that did not finish, and is refused.
- **Interrupted runs say so** (``interruptible``, ``RunInterrupted``): SIGTERM and SIGINT raise
  ``RunInterrupted`` in the main thread, a ``BaseException`` that no library's ``except Exception`` swallows
  (Lightning, which turns its own SIGTERM into an exit code 0, composes its handler with this one); the app
  writes what it can, prints one line and exits with 128 + the signal number.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import json
import os
import signal
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from .files import atomic_write, write_json

__all__ = ["COMPLETE", "LOCK", "RunInterrupted", "begin_results", "claim", "inside", "interruptible",
           "is_complete", "is_run_dir", "mark_complete", "prepare_run_dir", "release", "require_complete",
           "run_dir_path"]

LOCK = ".lock"
COMPLETE = "complete.json"
_HELD: dict[Path, int] = {}  # run directories this process holds -> the open, locked .lock file


class RunInterrupted(BaseException):
    """Raised in the main thread by SIGTERM or SIGINT while ``interruptible`` is active."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        self.signame = signal.Signals(self.signum).name
        super().__init__(f"interrupted by {self.signame}")

    @property
    def exit_code(self) -> int:
        """The shell's convention for a process ended by a signal: 128 + its number (130 for SIGINT, 143 for
        SIGTERM)."""
        return 128 + self.signum


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """While active (main thread only; elsewhere a no-op), SIGTERM and SIGINT raise ``RunInterrupted``; the
    previous handlers are restored on exit. After the first signal every further one is ignored, inside (where
    Lightning may have put this handler back) and after the block (the signals stay ignored while the app
    writes what it can, prints its line and exits), so the run's last writes are not cut short."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signals = (signal.SIGTERM, signal.SIGINT)
    previous = {s: signal.getsignal(s) for s in signals}

    interrupted: list[int] = []

    def handler(signum, frame):
        for s in signals:
            signal.signal(s, signal.SIG_IGN)
        if interrupted:  # called again (a handler chain kept a reference to this one): already ending
            return
        interrupted.append(signum)
        raise RunInterrupted(signum)

    for s in signals:
        signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_IGN if interrupted else h if h is not None else signal.SIG_DFL)


def _holder(lock: Path) -> dict:
    """What the lock file says of the run that holds it (for the message); {} where it cannot be read."""
    try:
        held = json.loads(lock.read_text(encoding="utf-8"))
        return held if isinstance(held, dict) else {}
    except (OSError, ValueError):
        return {}


def claim(run_dir: Path | str) -> Path:
    """Hold ``run_dir`` for this process (created if needed) or raise ``ValueError`` naming the run that holds it.

    The hold is an exclusive ``flock`` on ``<run dir>/.lock``, kept for as long as the process holds the
    directory: the kernel (on a network file system, its lock manager) ends it with the process however that
    ends, SIGKILL included, so a killed run's lock is free at once and no stale lock is ever taken over by
    guessing. The file's text (process id, host, start) only names the holder in the message. Released by
    ``release`` (the apps' ``guarded`` calls it) or at the process's exit."""
    run_dir = Path(run_dir).resolve()
    if run_dir in _HELD:
        return run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    lock = run_dir / LOCK
    while True:
        fd = os.open(lock, os.O_CREAT | os.O_RDWR, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            held = _holder(lock)
            raise ValueError(f"run directory {run_dir} is in use by another run (process {held.get('pid', '?')} on "
                             f"{held.get('host', '?')}, since {held.get('started', '?')}): give this run another "
                             "hydra.run.dir=..., or wait for that run to end") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:  # not a file the run before us unlinked while we waited for it: ours
            break
        os.close(fd)
    me = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    os.ftruncate(fd, 0)
    os.write(fd, json.dumps(me).encode())
    _HELD[run_dir] = fd
    return run_dir


def release(run_dir: Path | str | None = None) -> None:
    """Give up ``run_dir`` (every directory this process holds when None): the lock file is removed while still
    held, then let go."""
    dirs = list(_HELD) if run_dir is None else [Path(run_dir).resolve()]
    for d in dirs:
        fd = _HELD.pop(d, None)
        if fd is None:
            continue
        with contextlib.suppress(OSError):
            (d / LOCK).unlink()
        os.close(fd)


def begin_results(run_dir: Path | str) -> None:
    """A run starts writing ``run_dir``: an earlier run's completion marker is removed first, so that what
    this run leaves if it is cut short is never taken for finished results."""
    with contextlib.suppress(FileNotFoundError):
        (Path(run_dir) / COMPLETE).unlink()


def mark_complete(run_dir: Path | str, app: str, files: list[str] | None = None) -> Path:
    """Write ``complete.json`` (atomically, after every result): the app, when, and the files it wrote (those
    of ``files`` that exist, relative to ``run_dir``)."""
    run_dir = Path(run_dir)
    listed = sorted(f for f in (files or []) if (run_dir / f).exists())
    return write_json(run_dir / COMPLETE, {"app": app, "finished": time.strftime("%Y-%m-%d %H:%M:%S"),
                                           "files": listed})


def is_complete(run_dir: Path | str) -> bool:
    return (Path(run_dir) / COMPLETE).is_file()


def is_run_dir(path: Path | str) -> bool:
    """Whether ``path`` is a directory a hybridhyst app wrote (Hydra's ``.hydra/``, a completion marker, or the
    ``model.pt`` beside a written model config), as opposed to a folder of the user's own model configs."""
    path = Path(path)
    return (path / ".hydra").is_dir() or (path / COMPLETE).is_file() or (path / "model.pt").is_file()


def require_complete(run_dir: Path | str, what: str, file: str | None = None) -> None:
    """``ValueError`` unless the run that wrote ``run_dir`` finished (``complete.json``) and, where ``file`` (a path
    relative to ``run_dir``) is given, wrote that file itself (it is listed there: not one an earlier run left);
    ``what`` names what is being read (e.g. "the model config model/discovered.yaml")."""
    run_dir = Path(run_dir)
    if not is_complete(run_dir):
        raise ValueError(f"{what} comes from run directory {run_dir}, whose run did not finish (no {COMPLETE}: it "
                         "was interrupted, failed or is still running, or wrote its results before hybridhyst marked "
                         "finished runs); its files may be partial: re-run it, or use a finished run (a run directory "
                         f"you know is whole: python -m hybridhyst.runs {run_dir} marks it)")
    if file is not None:
        try:
            listed = json.loads((run_dir / COMPLETE).read_text(encoding="utf-8")).get("files") or []
        except (OSError, ValueError, AttributeError):
            listed = []
        if Path(file).as_posix() not in listed:
            raise ValueError(f"{what} in run directory {run_dir} was not written by the run that finished there (its "
                             f"{COMPLETE} does not list {Path(file).as_posix()}): an earlier run's file; not read")


def inside(path: Path | str, root: Path | str) -> bool:
    """Whether ``path`` lies inside ``root`` once both are resolved (links followed)."""
    try:
        Path(path).resolve().relative_to(Path(root).resolve())
    except ValueError:
        return False
    return True


def run_dir_path(cfg) -> Path:
    """The run directory of a Hydra config: Hydra's output dir under ``@hydra.main``, else ``cfg.run_dir``,
    else the cwd (nothing is created)."""
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized():
        return Path(HydraConfig.get().runtime.output_dir)
    return Path(cfg.get("run_dir") or os.getcwd())


def prepare_run_dir(cfg) -> Path:
    """``run_dir_path(cfg)``, claimed for this run (``claim``: refused while another run uses it), its earlier
    completion marker removed (``begin_results``), with the resolved config written there as ``config.yaml``."""
    from omegaconf import OmegaConf

    path = run_dir_path(cfg)
    claim(path)
    begin_results(path)
    atomic_write(path / "config.yaml", OmegaConf.to_yaml(cfg, resolve=True))
    return path


atexit.register(release)


def _main(argv: list[str] | None = None) -> int:
    """``python -m hybridhyst.runs DIR``: mark a run directory whose run you know finished (one written before
    hybridhyst marked finished runs) as complete, listing the files it holds."""
    import sys

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or not Path(argv[0]).is_dir():
        print("usage: python -m hybridhyst.runs RUN_DIR  (marks a finished run directory complete)", file=sys.stderr)
        return 2
    run_dir = Path(argv[0])
    files = [p.relative_to(run_dir).as_posix() for p in run_dir.rglob("*")
             if p.is_file() and ".hydra" not in p.parts and p.name not in (LOCK, COMPLETE)]
    print(mark_complete(run_dir, "marked by hand", files))
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())  # a run that ends without ``release`` (an uncaught error) frees its directories too
