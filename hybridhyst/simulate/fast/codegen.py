"""Generate and compile (numba) the integration loops of one model with exact discrete adjoints.

For a model with S states, P parameters and O outputs, the generated module holds:
``rhs(s, u, du, ddu, th, f)`` and ``rhs_jac(..., f, fs, fth, fin)`` (values and Jacobians w.r.t.
state, parameters and inputs), the same pair for the outputs, and the two loops ``forward`` and
``backward`` (template below). ``backward`` is the exact adjoint of the discrete explicit Runge–Kutta
map on the sample grid with sub-steps — the same numbers as autograd through the reference loop.
Generated sources are cached on disk (numba ``cache=True``) keyed by their hash.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from .equations import Equations


class _Printer(PythonCodePrinter):
    def _print_Sign(self, expr):
        return f"_sign({self._print(expr.args[0])})"

    def _print_Step(self, expr):
        return f"_step({self._print(expr.args[0])})"

    def _print_Absolute(self, expr):
        return f"abs({self._print(expr.args[0])})"

    def _print_AbsPow(self, expr):
        return f"_abs_pow({self._print(expr.args[0])}, {self._print(expr.args[1])})"

    def _print_AbsPowLog(self, expr):
        return f"_abs_pow_log({self._print(expr.args[0])}, {self._print(expr.args[1])})"


def _kernel(name: str, args: list[str], targets: list[tuple[str, sp.Expr]], printer, eq: Equations) -> str:
    """A numba function assigning each ``target`` (e.g. ``f[0]``) its expression, with CSE."""
    exprs = [e for _, e in targets]
    subs, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("cse"), optimizations="basic")
    lines = ["@njit(cache=True, inline='always', error_model='numpy')", f"def {name}({', '.join(args)}):"]
    lines += [f"    {s} = s[{i}]" for i, s in enumerate(eq.state)]
    lines += [f"    {p} = th[{i}]" for i, p in enumerate(eq.params)]
    lines += [f"    {sym} = {printer.doprint(val)}" for sym, val in subs]
    lines += [f"    {tgt} = {printer.doprint(e)}" for (tgt, _), e in zip(targets, reduced)]
    if len(lines) == 2:
        lines.append("    pass")
    return "\n".join(lines)


def generate_source(eq: Equations) -> str:
    printer = _Printer({"standard": "python3"})
    n_state, n_param, n_out = len(eq.state), len(eq.params), len(eq.outputs)
    args = ["s", "u", "du", "ddu", "th"]
    f_t = [(f"f[{i}]", e) for i, e in enumerate(eq.rhs)]
    g_t = [(f"g[{i}]", e) for i, e in enumerate(eq.outputs)]

    def jac(exprs, wrt, name):
        return [(f"{name}[{i}, {j}]", sp.diff(e, w)) for i, e in enumerate(exprs) for j, w in enumerate(wrt)]

    f_full = f_t + jac(eq.rhs, eq.state, "fs") + jac(eq.rhs, eq.params, "fth") + jac(eq.rhs, eq.inputs, "fin")
    g_full = (g_t + jac(eq.outputs, eq.state, "gs") + jac(eq.outputs, eq.params, "gth")
              + jac(eq.outputs, eq.inputs, "gin"))
    big = sp.Float(1e300)  # an unbounded state: a bound no state reaches
    lower = [(f"lo[{i}]", -big if e is None else e) for i, e in enumerate(eq.lower or [None] * n_state)]
    upper = [(f"hi[{i}]", big if e is None else e) for i, e in enumerate(eq.upper or [None] * n_state)]
    b_full = lower + upper + jac([e for _, e in lower], eq.params, "dlo") + jac([e for _, e in upper], eq.params, "dhi")
    parts = [
        HEADER,
        f"S, P, O = {n_state}, {n_param}, {n_out}",
        f"PARALLEL = {bool(PARALLEL)}",
        f"HAS_BOUNDS = {eq.lower is not None}",
        _kernel("bounds", args + ["lo", "hi", "dlo", "dhi"], b_full, printer, eq),
        _kernel("rhs", args + ["f"], f_t, printer, eq),
        _kernel("rhs_jac", args + ["f", "fs", "fth", "fin"], f_full, printer, eq),
        _kernel("out", args + ["g"], g_t, printer, eq),
        _kernel("out_jac", args + ["g", "gs", "gth", "gin"], g_full, printer, eq),
        LOOPS,
    ]
    return "\n\n\n".join(parts) + "\n"


def _cache_dir() -> Path:
    root = os.environ.get("HYBRIDHYST_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "hybridhyst")
    path = Path(root) / "fast"
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_text("ok")
        probe.unlink()
    except OSError:
        path = Path(tempfile.gettempdir()) / "hybridhyst-fast"
        path.mkdir(parents=True, exist_ok=True)
    return path


_MODULES: dict[str, object] = {}
# HYBRIDHYST_FAST_PARALLEL=1 runs the rows of a batch on all cores (numba prange). Off by default: the
# parallel build compiles 3-4x slower (9 s vs 31 s per model measured on the 2-core machine under load)
# and only pays off for large populations on machines with idle cores.
PARALLEL = os.environ.get("HYBRIDHYST_FAST_PARALLEL", "0") == "1"


def _equations_key(eq: Equations) -> str:
    """A hash of the equations themselves (cheap next to generating their source: CSE and Jacobians)."""
    text = repr((eq.state, eq.inputs, eq.params, eq.rhs, eq.outputs, eq.lower, eq.upper, PARALLEL))
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def _write(path: Path, text: str) -> None:
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def compile_equations(eq: Equations):
    """Import (compiling on first use) the generated module for these equations.

    Generated sources are found again by the hash of the equations (an index file next to them), so a model
    seen before — in this process or an earlier one — skips the source generation as well as the compile.
    """
    key = _equations_key(eq)
    if key in _MODULES:
        return _MODULES[key]
    index = _cache_dir() / f"eq_{key}.txt"
    digest = index.read_text().strip() if index.exists() else ""
    path = _cache_dir() / f"hh_fast_{digest}.py"
    if not digest or not path.exists():
        src = generate_source(eq)
        digest = hashlib.sha1(src.encode()).hexdigest()[:16]
        path = _cache_dir() / f"hh_fast_{digest}.py"
        if not path.exists() or path.read_text() != src:
            _write(path, src)
        _write(index, digest)
    name = f"hybridhyst_fast_{digest}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _MODULES[key] = module
    return module


HEADER = '''"""Generated by hybridhyst.simulate.fast.codegen — do not edit."""
import math
import numpy as np
from numba import njit, prange


@njit(cache=True, inline='always', error_model='numpy')
def _sign(x):
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


@njit(cache=True, inline='always', error_model='numpy')
def _step(x):
    return 1.0 if x >= 0 else 0.0


@njit(cache=True, inline='always', error_model='numpy')
def _abs_pow(z, n):
    a = abs(z)
    return a ** n if a > 0 else 0.0


@njit(cache=True, inline='always', error_model='numpy')
def _abs_pow_log(z, n):
    a = abs(z)
    return a ** n * math.log(a) if a > 0 else 0.0'''

LOOPS = '''@njit(cache=True, parallel=PARALLEL, error_model='numpy')
def forward(U, h, th, s0, c, A, bw, sub, states, y):
    """States at sample times and outputs; U (B,T,3), h (B,T-1) (each row its own grid), th (B,P), s0 (B,S).
    Rows in parallel."""
    for b in prange(U.shape[0]):
        forward_row(b, U, h, th, s0, c, A, bw, sub, states, y)


@njit(cache=True, parallel=PARALLEL, error_model='numpy')
def backward(U, h, th, states, gy, c, A, bw, sub, gth, gU, gs0):
    """Exact adjoint of ``forward``: accumulates dL/dth, dL/dU, dL/ds0 from dL/dy. Rows in parallel."""
    for b in prange(U.shape[0]):
        backward_row(b, U, h, th, states, gy, c, A, bw, sub, gth, gU, gs0)


@njit(cache=True, inline='always', error_model='numpy')
def stage_state(st, K, j, hk, A, Y):
    """Y = st + hk * sum_l A[j, l] K[l] (the state at stage j)."""
    for i in range(S):
        acc = st[i]
        for l in range(j):
            acc += hk * A[j, l] * K[l, i]
        Y[i] = acc


@njit(cache=True, inline='always', error_model='numpy')
def stage_input(U, b, k, fr):
    """The input (u, du, ddu) a fraction ``fr`` into sample interval k (linear interpolation)."""
    return (U[b, k, 0] + (U[b, k + 1, 0] - U[b, k, 0]) * fr,
            U[b, k, 1] + (U[b, k + 1, 1] - U[b, k, 1]) * fr,
            U[b, k, 2] + (U[b, k + 1, 2] - U[b, k, 2]) * fr)


@njit(cache=True, inline='always', error_model='numpy')
def substep(b, k, m, st, K, Y, hk, U, th, c, A, bw, sub):
    """Advance ``st`` in place by sub-step m of interval k."""
    for j in range(c.shape[0]):
        stage_state(st, K, j, hk, A, Y)
        uu, dd, aa = stage_input(U, b, k, (m + c[j]) / sub)
        rhs(Y, uu, dd, aa, th[b], K[j])
    for i in range(S):
        acc = 0.0
        for j in range(c.shape[0]):
            acc += bw[j] * K[j, i]
        st[i] += hk * acc


@njit(cache=True, inline='always', error_model='numpy')
def project(st, lo, hi, fl):
    """Project the state onto its bounds; fl[i] = 1 / -1 where the upper / lower bound was taken, else 0."""
    for i in range(S):
        if st[i] > hi[i]:
            st[i] = hi[i]
            fl[i] = 1.0
        elif st[i] < lo[i]:
            st[i] = lo[i]
            fl[i] = -1.0
        else:
            fl[i] = 0.0


@njit(cache=True, error_model='numpy')
def forward_row(b, U, h, th, s0, c, A, bw, sub, states, y):
    T = U.shape[1]
    K = np.zeros((c.shape[0], S))
    Y = np.zeros(S)
    st = s0[b].copy()
    g = np.zeros(O)
    lo, hi, fl = np.zeros(S), np.zeros(S), np.zeros(S)
    dlo, dhi = np.zeros((S, P)), np.zeros((S, P))
    if HAS_BOUNDS:
        bounds(st, 0.0, 0.0, 0.0, th[b], lo, hi, dlo, dhi)
    states[b, 0, :] = st
    for k in range(T - 1):
        for m in range(sub):
            substep(b, k, m, st, K, Y, h[b, k] / sub, U, th, c, A, bw, sub)
            if HAS_BOUNDS:
                project(st, lo, hi, fl)
        states[b, k + 1, :] = st
    for k in range(T):
        out(states[b, k], U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], g)
        y[b, k, :] = g


@njit(cache=True, error_model='numpy')
def backward_row(b, U, h, th, states, gy, c, A, bw, sub, gth, gU, gs0):
    T = U.shape[1]
    nst = c.shape[0]
    lam = np.zeros(S)
    g = np.zeros(O)
    gs = np.zeros((O, S))
    gt = np.zeros((O, P))
    gi = np.zeros((O, 3))
    K = np.zeros((nst, S))
    Y = np.zeros(S)
    Yst = np.zeros((nst, S))
    FS = np.zeros((nst, S, S))
    FT = np.zeros((nst, S, P))
    FI = np.zeros((nst, S, 3))
    sub_start = np.zeros((sub, S))
    lamK = np.zeros((nst, S))
    lamY = np.zeros(S)
    st = np.zeros(S)
    lo, hi, flags = np.zeros(S), np.zeros(S), np.zeros((sub, S))
    dlo, dhi = np.zeros((S, P)), np.zeros((S, P))
    if HAS_BOUNDS:
        bounds(states[b, 0], 0.0, 0.0, 0.0, th[b], lo, hi, dlo, dhi)
    for k in range(T - 1, -1, -1):
        # output y_k = g(s_k, U_k, th)
        out_jac(states[b, k], U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], g, gs, gt, gi)
        for o in range(O):
            w = gy[b, k, o]
            if w != 0.0:
                for i in range(S):
                    lam[i] += gs[o, i] * w
                for p in range(P):
                    gth[b, p] += gt[o, p] * w
                for q in range(3):
                    gU[b, k, q] += gi[o, q] * w
        if k == 0:
            break
        kk = k - 1
        hk = h[b, kk] / sub
        # recover the start state of every sub-step of interval kk
        st[:] = states[b, kk]
        for m in range(sub):
            sub_start[m, :] = st
            substep(b, kk, m, st, K, Y, hk, U, th, c, A, bw, sub)
            if HAS_BOUNDS:
                project(st, lo, hi, flags[m])
        for m in range(sub - 1, -1, -1):
            if HAS_BOUNDS:  # adjoint of the projection: a state held at a bound follows the bound
                for i in range(S):
                    if flags[m, i] != 0.0:
                        for p in range(P):
                            gth[b, p] += (dhi[i, p] if flags[m, i] > 0 else dlo[i, p]) * lam[i]
                        lam[i] = 0.0
            # stages of sub-step m with their Jacobians
            for j in range(nst):
                stage_state(sub_start[m], K, j, hk, A, Yst[j])
                uu, dd, aa = stage_input(U, b, kk, (m + c[j]) / sub)
                rhs_jac(Yst[j], uu, dd, aa, th[b], K[j], FS[j], FT[j], FI[j])
            # adjoint of s' = s + hk sum_j bw_j K_j, K_j = f(Y_j), Y_j = s + hk sum_l A_jl K_l
            for j in range(nst):
                for i in range(S):
                    lamK[j, i] = hk * bw[j] * lam[i]
            for j in range(nst - 1, -1, -1):
                fr = (m + c[j]) / sub
                for i in range(S):
                    acc = 0.0
                    for r in range(S):
                        acc += FS[j, r, i] * lamK[j, r]
                    lamY[i] = acc
                for p in range(P):
                    acc = 0.0
                    for r in range(S):
                        acc += FT[j, r, p] * lamK[j, r]
                    gth[b, p] += acc
                for q in range(3):
                    acc = 0.0
                    for r in range(S):
                        acc += FI[j, r, q] * lamK[j, r]
                    gU[b, kk, q] += acc * (1.0 - fr)
                    gU[b, kk + 1, q] += acc * fr
                for l in range(j):
                    for i in range(S):
                        lamK[l, i] += hk * A[j, l] * lamY[i]
                for i in range(S):
                    lam[i] += lamY[i]
    gs0[b, :] = lam'''
