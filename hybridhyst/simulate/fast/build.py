"""Build a model's generated C (``codegen``) with the system C compiler and load it: the compiled loops.

Each loop a model runs — ``forward`` (values), ``tangent`` (forward sensitivities), ``backward`` (the adjoint) — is
a shared library of its own, generated and built with the system C compiler (``cc``, or ``$CC``) when a call first
needs it (``PARTS``): a model that is only simulated never waits for its Jacobians, and a discovery step's candidates
(simulated and fitted by Levenberg–Marquardt) never build an adjoint. Well under two seconds for a model of the
library's effects, where numba took 10–45 s (``experiments/performance``). Libraries are loaded through ctypes, which
releases the GIL: the rows of a batch run on several threads. They are cached on disk (``$HYBRIDHYST_CACHE`` or
``~/.cache/hybridhyst``) keyed by the hash of their source and the compiler flags, found again from the equations'
hash without generating the source.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .codegen import equations_key, generate_source
from .equations import Equations


def _cache_dir() -> Path:
    root = os.environ.get("HYBRIDHYST_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "hybridhyst")
    path = Path(root) / "fast"
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".write-test.{os.getpid()}.{threading.get_ident()}"  # one per writer: none unlinks another's
        probe.write_text("ok")
        probe.unlink()
    except OSError:
        path = Path(tempfile.gettempdir()) / "hybridhyst-fast"
        path.mkdir(parents=True, exist_ok=True)
    return path


_MODULES: dict[str, object] = {}
_LOCK = threading.Lock()
# -O3 (HYBRIDHYST_OPT sets another level): the main job's warm run up to 7 % faster than at -O2 (by run), each
# model's build about 0.1-0.2 s slower, the same numbers (no fast-math, no FMA contraction on the baseline x86-64
# target): scripts/bench_build.py --opt-levels
OPT = os.environ.get("HYBRIDHYST_OPT", "-O3")
# A library holds one loop (PARTS), the only caller of its Jacobian kernels: GCC inlines a static function called once
# whatever its size, and the adjoint of the model of every effect took 3.8 s to build instead of 1.5 s with the kernels
# called as they are where the library held every loop (the same numbers: inlining changes no arithmetic). Where the
# compiler does not know the flag it is left out.
_ONCE = "-fno-inline-functions-called-once"


@functools.cache
def _flags() -> tuple[str, ...]:
    """The compiler flags of every library (the level ``OPT``, position-independent, no errno from libm)."""
    flags = (OPT, "-fPIC", "-shared", "-std=gnu99", "-fno-math-errno")
    probe = subprocess.run([compiler(), _ONCE, "-x", "c", "-fsyntax-only", "-"], input="", capture_output=True,
                           text=True)
    return flags + (_ONCE,) if probe.returncode == 0 and not probe.stderr.strip() else flags


def compiler() -> str:
    """The C compiler the fast path builds models with: ``$CC`` or the first of cc, gcc, clang on PATH."""
    for name in [os.environ.get("CC")] + ["cc", "gcc", "clang"]:
        if name and shutil.which(name):
            return name
    raise RuntimeError("the fast backend builds each model with a C compiler and found none (set CC, or install gcc "
                       "or clang); simulate(..., backend='reference') runs without one, more slowly")


def _write(path: Path, text: str) -> None:
    tmp = path.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _build(src: str, digest: str, flags: tuple[str, ...] = ()) -> Path:
    """The shared library of ``src`` (compiled with the extra ``flags``) in the cache, built now if it is not there
    (written under a temporary name and renamed, so processes building the same model at once never load half a
    file)."""
    lib = _cache_dir() / f"hh_{digest}.so"
    if lib.exists():
        return lib
    c_file = _cache_dir() / f"hh_{digest}.c"
    _write(c_file, src)
    tmp = lib.with_suffix(f".{os.getpid()}.{threading.get_ident()}.so")
    cmd = [compiler(), *_flags(), *flags, "-o", str(tmp), str(c_file), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building the model's compiled loops failed ({' '.join(cmd)}):\n{done.stderr[-3000:]}")
    os.replace(tmp, lib)
    return lib


# each loop's library: the source it is built from (codegen.SOURCES) and the macro that selects it in loops.c
PARTS = {"forward": ("values", "-DHH_FORWARD"), "tangent": ("derivatives", "-DHH_TANGENT"),
         "backward": ("derivatives", "-DHH_BACKWARD")}


@functools.cache
def _settings_key() -> str:
    """What an index file's name holds beside the equations' hash: this file (``PARTS``, the flags), the level
    asked for and the compiler named by ``$CC`` (another level finds its own libraries, not the ones built at
    this)."""
    text = Path(__file__).read_bytes() + f" {OPT} {os.environ.get('CC', '')}".encode()
    return hashlib.sha1(text).hexdigest()[:8]


def _source(eq: Equations, key: str, kind: str) -> str:
    """One of the generated sources of the equations with hash ``key``: read back from the cache, else generated
    and kept there (the tangent and the adjoint share one: the second to be built, in this process or another,
    reads it)."""
    path = _cache_dir() / f"src_{key}.{kind}.c"
    try:
        return path.read_text()
    except OSError:
        src = generate_source(eq, kind)
        _write(path, src)
        return src


def _library(eq: Equations, key: str, part: str) -> Path:
    """The library of one loop (``PARTS``) of the equations with hash ``key``: found again through an index file
    next to it (no source generated), else built from its source."""
    kind, flag = PARTS[part]
    index = _cache_dir() / f"eq_{key}.{part}.{_settings_key()}.txt"
    digest = index.read_text().strip() if index.exists() else ""
    lib = _cache_dir() / f"hh_{digest}.so"
    if not digest or not lib.exists():
        src = _source(eq, key, kind)
        digest = hashlib.sha1(" ".join([*_flags(), flag, src]).encode()).hexdigest()[:16]
        lib = _build(src, digest, (flag,))
        _write(index, digest)
    return lib


def _compiled(eq: Equations) -> Compiled:
    """The one ``Compiled`` of these equations in this process (nothing built yet for a new one)."""
    key = equations_key(eq)
    with _LOCK:
        module = _MODULES.get(key)
        if module is None:
            module = _MODULES[key] = Compiled(eq, key)
        return module


def compile_equations(eq: Equations) -> Compiled:
    """The compiled loops of these equations, their forward loop built (on first use, then loaded from the disk
    cache; the tangent and the adjoint when a call first needs them).

    Libraries are found again by the hash of the equations (an index file next to them), so a model seen
    before — in this process or an earlier one — skips the source generation as well as the build.
    """
    module = _compiled(eq)
    module.load("forward")
    return module


def prebuild(jobs: list[tuple[Equations, tuple[str, ...]]], workers: int | None = None) -> None:
    """Build several models' loops at once (one compiler process each, ``workers`` at a time): a discovery step's
    candidates are built side by side instead of one after the other. ``jobs``: each model's equations and the
    loops (``PARTS``) to build."""
    todo = [(module, part) for eq, parts in jobs for module in [_compiled(eq)] for part in parts
            if part not in module._fns]
    if len(todo) < 2:
        for module, part in todo:
            module.load(part)
        return
    with ThreadPoolExecutor(max_workers=workers or row_threads()) as pool:
        list(pool.map(lambda job: job[0].load(job[1]), todo))


def row_threads() -> int:
    """Threads the loops spread a batch's rows over: ``$HYBRIDHYST_FAST_THREADS`` or the cores this process
    may use."""
    env = os.environ.get("HYBRIDHYST_FAST_THREADS")
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


_POOL: ThreadPoolExecutor | None = None
_MIN_ROW_WORK = int(os.environ.get("HYBRIDHYST_FAST_MIN_WORK", "20000"))  # sample-steps per thread below which
# one thread runs the batch (handing work to a thread costs tens of µs)


def _after_fork() -> None:
    """A forked child (a process pool's worker) has none of its parent's threads: a fresh pool and fresh locks
    (one its parent's thread held at the fork would never be released here)."""
    global _POOL, _LOCK
    _POOL, _LOCK = None, threading.Lock()
    for module in _MODULES.values():
        module._locks = {part: threading.Lock() for part in PARTS}


os.register_at_fork(after_in_child=_after_fork)


def _pointer(a: np.ndarray | None) -> int | None:
    """The array's data address; None (a NULL pointer) for an array not given."""
    return None if a is None else a.ctypes.data


def _check(name: str, arrays: dict, B: int, T: int, NT: int, S: int, P: int, n_out: int, NI: int) -> None:
    """The loops index raw memory: every array float64, C-contiguous and of the shape they assume."""
    shapes = {"U": (B, T, NI), "h": (B, T - 1), "th": (B, NT), "s0": (B, S), "states": (B, T, S), "y": (B, T, n_out),
              "gy": (B, T, n_out), "gS": (B, T, S), "gth": (B, NT), "gU": (B, T, NI), "gs0": (B, S), "ds0": (B, S, NT),
              "want": (NT,), "dy": (B, T, n_out, NT), "dU": (B, T, NI), "dth": (B, NT)}
    for key, a in arrays.items():
        if a is None:  # an optional array not given (the loop takes NULL)
            continue
        if a.dtype != np.float64 or not a.flags.c_contiguous or a.shape != shapes.get(key, a.shape):
            raise ValueError(f"compiled {name}: {key} must be a C-contiguous float64 array of shape "
                             f"{shapes.get(key)}, got {a.dtype} {a.shape}")
    if NT < P:
        raise ValueError(f"compiled {name}: th has {NT} columns, fewer than the model's {P} parameters")


class Compiled:
    """One model's loops: ``forward``, ``backward`` and ``tangent`` over numpy float64 arrays (the layout of
    ``loops.c``), each built and loaded when first called (``load``), with the rows of a batch spread over threads
    (ctypes releases the GIL)."""

    def __init__(self, eq: Equations, key: str):
        self.eq, self.key = eq, key
        self.S, self.P, self.O, self.NI = len(eq.state), len(eq.params), len(eq.outputs), len(eq.inputs)
        self._fns: dict = {}
        self._locks = {part: threading.Lock() for part in PARTS}  # one build of each loop at a time

    def load(self, name: str):
        """The exported function of loop ``name`` (``PARTS``), built and loaded if it is not yet (a thread asking
        while another builds it waits for that build)."""
        fn = self._fns.get(name)
        if fn is not None:
            return fn
        with self._locks[name]:
            fn = self._fns.get(name)
            if fn is None:
                fn = getattr(ctypes.CDLL(str(_library(self.eq, self.key, name))), f"hh_{name}")
                # (b0, b1, T, NT, arrays..., nst, c, A, bw, sub, results...)
                n_before, n_after = {"forward": (4, 2), "backward": (6, 3), "tangent": (8, 2)}[name]
                L, V = ctypes.c_long, ctypes.c_void_p
                fn.argtypes = [L] * 4 + [V] * n_before + [L] + [V] * 3 + [L] + [V] * n_after
                fn.restype = None
                self._fns[name] = fn
            return fn

    def _run(self, name: str, B: int, T: int, arrays_before: dict, nst: int, tableau: list, sub: int,
             arrays_after: dict, NT: int) -> None:
        _check(name, {**arrays_before, **arrays_after}, B, T, NT, self.S, self.P, self.O, self.NI)
        c, A, bw = tableau
        if not (c.shape == bw.shape == (nst,) and A.shape == (nst, nst)) or int(sub) < 1:
            raise ValueError(f"compiled {name}: a tableau of {nst} stages and sub >= 1, got {A.shape}, sub {sub}")
        _check(name, {"c": c, "A": A, "bw": bw}, B, T, NT, self.S, self.P, self.O, self.NI)
        arrays_before, arrays_after = list(arrays_before.values()), list(arrays_after.values())
        fn = self.load(name)
        ptrs_before = [_pointer(a) for a in arrays_before]
        ptrs_tab = [_pointer(a) for a in tableau]
        ptrs_after = [_pointer(a) for a in arrays_after]

        def rows(b0, b1):
            fn(b0, b1, T, NT, *ptrs_before, nst, *ptrs_tab, sub, *ptrs_after)

        n = min(row_threads(), B, max(1, B * T * sub // _MIN_ROW_WORK))
        if threading.current_thread() is not threading.main_thread():
            n = 1  # a call from a worker thread (discovery's candidates in threads) keeps its rows to itself
        if n <= 1:
            rows(0, B)
            return
        global _POOL
        with _LOCK:
            if _POOL is None or _POOL._max_workers < n - 1:
                _POOL = ThreadPoolExecutor(max_workers=n - 1)
            pool = _POOL
        cuts = np.linspace(0, B, n + 1).round().astype(int)
        others = [pool.submit(rows, int(cuts[i]), int(cuts[i + 1])) for i in range(1, n)]
        rows(0, int(cuts[1]))  # the first share in this thread, the others in the pool's
        for f in others:
            f.result()

    def forward(self, U, h, th, s0, c, A, bw, sub, states, y):
        """States at the sample times and outputs: U (B,T,NI), h (B,T-1), th (B,NT), s0 (B,S)."""
        self._run("forward", U.shape[0], U.shape[1], {"U": U, "h": h, "th": th, "s0": s0}, c.shape[0], [c, A, bw],
                  sub, {"states": states, "y": y}, th.shape[1])

    def backward(self, U, h, th, states, gy, gS, c, A, bw, sub, gth, gU, gs0):
        """Exact adjoint of ``forward``: accumulates dL/dth, dL/dU, dL/ds0 from dL/dy and dL/d(states)."""
        self._run("backward", U.shape[0], U.shape[1], {"U": U, "h": h, "th": th, "states": states, "gy": gy, "gS": gS},
                  c.shape[0], [c, A, bw], sub, {"gth": gth, "gU": gU, "gs0": gs0}, th.shape[1])

    def tangent(self, U, h, th, s0, ds0, want, c, A, bw, sub, y, dy, dU=None, dth=None):
        """Outputs y (B,T,O) and their derivatives dy (B,T,O,NT) w.r.t. the columns of th (the parameters, then
        the networks' weights) asked for (want (NT,), nonzero; the others are 0), given ds0 (B,S,NT). Where the input
        moves with some columns (a delay): dU (B,T,NI) its derivative w.r.t. each row's delay and dth (B,NT) the
        delay's w.r.t. each column (both None: it moves with none)."""
        if (dU is None) != (dth is None):
            raise ValueError("compiled tangent: give both dU and dth, or neither")
        self._run("tangent", U.shape[0], U.shape[1], {"U": U, "h": h, "th": th, "s0": s0, "ds0": ds0, "want": want,
                                                      "dU": dU, "dth": dth},
                  c.shape[0], [c, A, bw], sub, {"y": y, "dy": dy}, th.shape[1])
