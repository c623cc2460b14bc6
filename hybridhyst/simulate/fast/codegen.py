"""Generate and compile (numba) the integration loops of one model with exact discrete adjoints.

For a model with S states, P parameters and O outputs, the generated module holds:
``rhs(s, u, du, ddu, th, f)`` and ``rhs_jac(..., f, fs, fth, fin)`` (values and Jacobians w.r.t.
state, parameters and inputs), the same pair for the outputs, and the loops ``forward``, ``backward`` and
``tangent`` (template below). ``backward`` is the exact adjoint of the discrete explicit Runge–Kutta
map on the sample grid with sub-steps — the same numbers as autograd through the reference loop;
``tangent`` the same map's forward sensitivities w.r.t. every parameter in one pass (whole Jacobians for
Levenberg–Marquardt). numba compiles each loop on its first call, so a model never fitted by least
squares never compiles ``tangent``.

A network inside the equations is a small MLP kernel (``_mlp_forward``) over its weights, which follow the
P parameters in ``th``; the Jacobian kernels hold every network's output fixed, and ``rhs_net_vjp`` /
``out_net_vjp`` add the networks' part of the chain rule by back-propagating the adjoint through them
(``_network_vjp``), reading the layers the Jacobian kernel left in a buffer at the same point.
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


_ACTIVATIONS = {"tanh": 0, "relu": 1, "gelu": 2, "silu": 3, "elu": 4}  # codes of _act / _dact below


def _buffer_layout(eq: Equations) -> tuple[list[tuple[int, int, int, int]], int]:
    """Per network (offset of Z, offset of A, layers, width) in one flat buffer of its layers' values, and
    the buffer's size: a Jacobian kernel writes a stage's layers there and the adjoint kernel reads them."""
    layout, at = [], 0
    for net in eq.networks:
        n_layers, width = len(net.widths) - 1, max(net.widths)
        layout.append((at, at + n_layers * width, n_layers, width))
        at += (2 * n_layers + 1) * width
    return layout, at


def _network_lines(eq: Equations, printer, evaluate: bool, read: set) -> list[str]:
    """The networks' layers as views of ``buf`` (``Z{k}`` before, ``A{k}`` after the activations) and their
    output symbols; with ``evaluate`` first the inputs from their expressions and a forward pass into them,
    for the networks whose outputs are ``read``."""
    lines = []
    for k, (net, (z_at, a_at, n_layers, width)) in enumerate(zip(eq.networks, _buffer_layout(eq)[0])):
        if evaluate and not read & set(net.outputs):
            continue
        lines.append(f"    Z{k} = buf[{z_at}:{a_at}].reshape(({n_layers}, {width}))")
        lines.append(f"    A{k} = buf[{a_at}:{a_at + (n_layers + 1) * width}].reshape(({n_layers + 1}, {width}))")
        if evaluate:
            lines.append(f"    nin{k} = np.empty({net.widths[0]})")
            lines += [f"    nin{k}[{a}] = {printer.doprint(e)}" for a, e in enumerate(net.inputs)]
            lines.append(f"    _mlp_forward(nin{k}, th, {net.offset}, {tuple(net.widths)}, "
                         f"{_ACTIVATIONS[net.activation]}, Z{k}, A{k})")
        lines += [f"    {o} = A{k}[{n_layers}, {j}]" for j, o in enumerate(net.outputs)]
    return lines


def _kernel(name: str, args: list[str], targets: list[tuple[str, sp.Expr]], printer, eq: Equations,
            head: list[str] | None = None, tail: list[str] | None = None, evaluate: bool = True) -> str:
    """A numba function assigning each ``target`` (e.g. ``f[0]``) its expression, with CSE. Where the
    targets read networks, their layers are in the argument ``buf`` (evaluated there first, or, without
    ``evaluate``, already there). ``head`` lines run first, ``tail`` lines last."""
    exprs = [e for _, e in targets]
    subs, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("cse"), optimizations="basic")
    lines = ["@njit(cache=True, inline='always', error_model='numpy')", f"def {name}({', '.join(args)}):"]
    lines += head or []
    lines += [f"    {s} = s[{i}]" for i, s in enumerate(eq.state)]
    lines += [f"    {p} = th[{i}]" for i, p in enumerate(eq.params)]
    if "buf" in args:
        lines += _network_lines(eq, printer, evaluate, set().union(*(e.free_symbols for e in exprs)))
    lines += [f"    {sym} = {printer.doprint(val)}" for sym, val in subs]
    lines += [f"    {tgt} = {printer.doprint(e)}" for (tgt, _), e in zip(targets, reduced)]
    lines += tail or []
    if len(lines) == 2:
        lines.append("    pass")
    return "\n".join(lines)


def _network_adjoint(name: str, exprs: list, printer, eq: Equations) -> str:
    """``name(s, u, du, ddu, th, w, lam, gth, gin, buf)``: the networks' part of the adjoint of ``exprs``
    (the right-hand side or the outputs) weighted by ``w``, with the networks' layers in ``buf`` (written by
    ``rhs_jac`` / ``out_jac`` at the same point): adds to ``lam`` (the state's adjoint), ``gth`` (the
    parameters' and the weights') and ``gin`` (u, du, ddu). ``rhs_jac`` / ``out_jac`` hold the rest of the
    Jacobians, with every network's outputs held: together they are the full chain rule."""
    args = ["s", "u", "du", "ddu", "th", "w", "lam", "gth", "gin", "buf"]
    head, targets, tail = [], [], []
    for k, net in enumerate(eq.networks):
        dfdn = [(f"dfdn{k}[{i}, {j}]", sp.diff(e, o)) for i, e in enumerate(exprs) for j, o in enumerate(net.outputs)]
        if all(e == 0 for _, e in dfdn):
            continue  # these expressions do not read this network
        n_in, n_out = net.widths[0], net.widths[-1]
        head += [f"    dfdn{k} = np.zeros(({len(exprs)}, {n_out}))",
                 f"    dins{k} = np.zeros(({n_in}, {len(eq.state)}))",
                 f"    dinth{k} = np.zeros(({n_in}, {len(eq.params)}))",
                 f"    dinin{k} = np.zeros(({n_in}, 3))"]
        targets += dfdn
        for a, e in enumerate(net.inputs):
            targets += [(f"dins{k}[{a}, {r}]", sp.diff(e, x)) for r, x in enumerate(eq.state)]
            targets += [(f"dinth{k}[{a}, {p}]", sp.diff(e, x)) for p, x in enumerate(eq.params)]
            targets += [(f"dinin{k}[{a}, {q}]", sp.diff(e, x)) for q, x in enumerate(eq.inputs)]
        tail.append(f"    _network_vjp(w, dfdn{k}, dins{k}, dinth{k}, dinin{k}, th, {net.offset}, {tuple(net.widths)}, "
                    f"{_ACTIVATIONS[net.activation]}, Z{k}, A{k}, lam, gth, gin)")
    targets = [(t, e) for t, e in targets if e != 0]  # the arrays start at zero
    return _kernel(name, args, targets, printer, eq, head=head, tail=tail, evaluate=False)


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
        f"NETS = {bool(eq.networks)}",
        f"NB = {max(_buffer_layout(eq)[1], 1)}  # the networks' layer values at one point",
        _kernel("bounds", args + ["lo", "hi", "dlo", "dhi"], b_full, printer, eq),
        _kernel("rhs", args + ["f", "buf"], f_t, printer, eq),
        _kernel("rhs_jac", args + ["f", "fs", "fth", "fin", "buf"], f_full, printer, eq),
        _kernel("out", args + ["g", "buf"], g_t, printer, eq),
        _kernel("out_jac", args + ["g", "gs", "gth", "gin", "buf"], g_full, printer, eq),
        _network_adjoint("rhs_net_vjp", eq.rhs, printer, eq),
        _network_adjoint("out_net_vjp", eq.outputs, printer, eq),
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


# the generator's own source: a changed template or kernel generator must not find the sources it wrote before
_GENERATOR = hashlib.sha1(Path(__file__).read_bytes()).hexdigest()[:16]


def _equations_key(eq: Equations) -> str:
    """A hash of the equations themselves (cheap next to generating their source: CSE and Jacobians) and of
    this generator."""
    text = repr((eq.state, eq.inputs, eq.params, eq.rhs, eq.outputs, eq.lower, eq.upper, eq.networks, PARALLEL,
                 _GENERATOR))
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
    return a ** n * math.log(a) if a > 0 else 0.0


@njit(cache=True, inline='always', error_model='numpy')
def _act(z, kind):
    """Activation by code: 0 tanh, 1 relu, 2 gelu (erf), 3 silu, 4 elu (as torch.nn)."""
    if kind == 0:
        return math.tanh(z)
    if kind == 1:
        return z if z > 0.0 else 0.0
    if kind == 2:
        return 0.5 * z * (1.0 + math.erf(z / math.sqrt(2.0)))
    if kind == 3:
        return z / (1.0 + math.exp(-z))
    return z if z > 0.0 else math.exp(z) - 1.0


@njit(cache=True, inline='always', error_model='numpy')
def _dact(z, a, kind):
    """Derivative of the activation at z (a = its value), with torch's conventions at the kinks."""
    if kind == 0:
        return 1.0 - a * a
    if kind == 1:
        return 1.0 if z > 0.0 else 0.0
    if kind == 2:
        return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0))) + z * math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
    if kind == 3:
        sg = 1.0 / (1.0 + math.exp(-z))
        return sg * (1.0 + z * (1.0 - sg))
    return 1.0 if z > 0.0 else math.exp(z)


@njit(cache=True, error_model='numpy')
def _mlp_forward(x, th, off, widths, act, Z, A):
    """An MLP (torch layout: per layer its weight (out, in) row by row, then its bias, from th[off]) at x:
    Z[l] before and A[l + 1] after layer l's activation (none after the last); A[0] = x."""
    L = len(widths) - 1
    for i in range(widths[0]):
        A[0, i] = x[i]
    o = off
    for l in range(L):
        a, b = widths[l], widths[l + 1]
        for j in range(b):
            acc = th[o + a * b + j]
            for i in range(a):
                acc += th[o + j * a + i] * A[l, i]
            Z[l, j] = acc
            A[l + 1, j] = acc if l == L - 1 else _act(acc, act)
        o += (a + 1) * b


@njit(cache=True, error_model='numpy')
def _network_vjp(w, dfdn, dins, dinth, dinin, th, off, widths, act, Z, A, lam, gth, gin):
    """Back-propagate v = dfdn^T w through the MLP evaluated in Z, A: its weights' gradient into gth[off:],
    its inputs' gradient through their Jacobians into lam (state), gth[:P] (parameters) and gin (inputs)."""
    L = len(widths) - 1
    width = A.shape[1]
    g = np.zeros(width)
    gp = np.zeros(width)
    for j in range(widths[L]):
        acc = 0.0
        for i in range(dfdn.shape[0]):
            acc += dfdn[i, j] * w[i]
        g[j] = acc
    offs = np.empty(L, np.int64)
    o = off
    for l in range(L):
        offs[l] = o
        o += (widths[l] + 1) * widths[l + 1]
    for l in range(L - 1, -1, -1):
        a, b = widths[l], widths[l + 1]
        o = offs[l]
        for i in range(a):
            gp[i] = 0.0
        for j in range(b):
            gj = g[j]
            if gj != 0.0:
                gth[o + a * b + j] += gj
                for i in range(a):
                    gth[o + j * a + i] += gj * A[l, i]
                    gp[i] += th[o + j * a + i] * gj
        if l > 0:
            for i in range(a):
                g[i] = gp[i] * _dact(Z[l - 1, i], A[l, i], act)
    for a in range(widths[0]):
        ga = gp[a]
        if ga != 0.0:
            for r in range(dins.shape[1]):
                lam[r] += ga * dins[a, r]
            for p in range(dinth.shape[1]):
                gth[p] += ga * dinth[a, p]
            for q in range(3):
                gin[q] += ga * dinin[a, q]'''

LOOPS = '''@njit(cache=True, parallel=PARALLEL, error_model='numpy')
def forward(U, h, th, s0, c, A, bw, sub, states, y):
    """States at sample times and outputs; U (B,T,3), h (B,T-1) (each row its own grid), th (B,P), s0 (B,S).
    Rows in parallel."""
    for b in prange(U.shape[0]):
        forward_row(b, U, h, th, s0, c, A, bw, sub, states, y)


@njit(cache=True, parallel=PARALLEL, error_model='numpy')
def backward(U, h, th, states, gy, gS, c, A, bw, sub, gth, gU, gs0):
    """Exact adjoint of ``forward``: accumulates dL/dth, dL/dU, dL/ds0 from dL/dy and dL/d(states at the
    samples). Rows in parallel."""
    for b in prange(U.shape[0]):
        backward_row(b, U, h, th, states, gy, gS, c, A, bw, sub, gth, gU, gs0)


@njit(cache=True, parallel=PARALLEL, error_model='numpy')
def tangent(U, h, th, s0, ds0, c, A, bw, sub, y, dy):
    """Outputs y (B,T,O) and their derivatives dy (B,T,O,P) w.r.t. every parameter (forward sensitivities:
    the exact derivative of the same discrete map as ``forward``), given the initial state's ds0 (B,S,P).
    Without networks (their outputs are held in the Jacobian kernels). Rows in parallel."""
    for b in prange(U.shape[0]):
        tangent_row(b, U, h, th, s0, ds0, c, A, bw, sub, y, dy)


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
def substep(b, k, m, st, K, Y, hk, U, th, c, A, bw, sub, buf):
    """Advance ``st`` in place by sub-step m of interval k."""
    for j in range(c.shape[0]):
        stage_state(st, K, j, hk, A, Y)
        uu, dd, aa = stage_input(U, b, k, (m + c[j]) / sub)
        rhs(Y, uu, dd, aa, th[b], K[j], buf)
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
    buf = np.zeros(NB)
    st = s0[b].copy()
    g = np.zeros(O)
    lo, hi, fl = np.zeros(S), np.zeros(S), np.zeros(S)
    dlo, dhi = np.zeros((S, P)), np.zeros((S, P))
    if HAS_BOUNDS:
        bounds(st, 0.0, 0.0, 0.0, th[b], lo, hi, dlo, dhi)
    states[b, 0, :] = st
    for k in range(T - 1):
        for m in range(sub):
            substep(b, k, m, st, K, Y, h[b, k] / sub, U, th, c, A, bw, sub, buf)
            if HAS_BOUNDS:
                project(st, lo, hi, fl)
        states[b, k + 1, :] = st
    for k in range(T):
        out(states[b, k], U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], g, buf)
        y[b, k, :] = g


@njit(cache=True, error_model='numpy')
def tangent_row(b, U, h, th, s0, ds0, c, A, bw, sub, y, dy):
    T = U.shape[1]
    nst = c.shape[0]
    K = np.zeros((nst, S))
    dK = np.zeros((nst, S, P))
    Y = np.zeros(S)
    dY = np.zeros((S, P))
    FS, FT, FI = np.zeros((S, S)), np.zeros((S, P)), np.zeros((S, 3))
    g, gs, gt, gi = np.zeros(O), np.zeros((O, S)), np.zeros((O, P)), np.zeros((O, 3))
    buf = np.zeros(NB)
    st = s0[b].copy()
    sig = ds0[b].copy()  # d(state)/d(parameters), (S, P)
    lo, hi, fl = np.zeros(S), np.zeros(S), np.zeros(S)
    dlo, dhi = np.zeros((S, P)), np.zeros((S, P))
    if HAS_BOUNDS:
        bounds(st, 0.0, 0.0, 0.0, th[b], lo, hi, dlo, dhi)
    for k in range(T):
        out_jac(st, U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], g, gs, gt, gi, buf)
        for o in range(O):
            y[b, k, o] = g[o]
            for p in range(P):
                acc = gt[o, p]
                for i in range(S):
                    acc += gs[o, i] * sig[i, p]
                dy[b, k, o, p] = acc
        if k == T - 1:
            break
        hk = h[b, k] / sub
        for m in range(sub):
            for j in range(nst):  # stage j: Y_j = s + hk sum_l A_jl K_l, K_j = f(Y_j); the same for tangents
                stage_state(st, K, j, hk, A, Y)
                for i in range(S):
                    for p in range(P):
                        acc = sig[i, p]
                        for l in range(j):
                            acc += hk * A[j, l] * dK[l, i, p]
                        dY[i, p] = acc
                uu, dd, aa = stage_input(U, b, k, (m + c[j]) / sub)
                rhs_jac(Y, uu, dd, aa, th[b], K[j], FS, FT, FI, buf)
                for i in range(S):
                    for p in range(P):
                        acc = FT[i, p]
                        for r in range(S):
                            acc += FS[i, r] * dY[r, p]
                        dK[j, i, p] = acc
            for i in range(S):
                acc = 0.0
                for j in range(nst):
                    acc += bw[j] * K[j, i]
                st[i] += hk * acc
                for p in range(P):
                    acc = 0.0
                    for j in range(nst):
                        acc += bw[j] * dK[j, i, p]
                    sig[i, p] += hk * acc
            if HAS_BOUNDS:  # a state held at a bound follows the bound
                project(st, lo, hi, fl)
                for i in range(S):
                    if fl[i] != 0.0:
                        for p in range(P):
                            sig[i, p] = dhi[i, p] if fl[i] > 0 else dlo[i, p]


@njit(cache=True, error_model='numpy')
def backward_row(b, U, h, th, states, gy, gS, c, A, bw, sub, gth, gU, gs0):
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
    UIN = np.zeros((nst, 3))
    buf = np.zeros((nst + 1, NB))  # the networks' layers at each stage (the last row: at the sample)
    gin = np.zeros(3)
    st = np.zeros(S)
    lo, hi, flags = np.zeros(S), np.zeros(S), np.zeros((sub, S))
    dlo, dhi = np.zeros((S, P)), np.zeros((S, P))
    if HAS_BOUNDS:
        bounds(states[b, 0], 0.0, 0.0, 0.0, th[b], lo, hi, dlo, dhi)
    for k in range(T - 1, -1, -1):
        # output y_k = g(s_k, U_k, th)
        out_jac(states[b, k], U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], g, gs, gt, gi, buf[nst])
        for o in range(O):
            w = gy[b, k, o]
            if w != 0.0:
                for i in range(S):
                    lam[i] += gs[o, i] * w
                for p in range(P):
                    gth[b, p] += gt[o, p] * w
                for q in range(3):
                    gU[b, k, q] += gi[o, q] * w
        for i in range(S):  # the states' own cotangent (return_states)
            lam[i] += gS[b, k, i]
        if NETS:  # the networks' share of the output's adjoint
            gin[:] = 0.0
            out_net_vjp(states[b, k], U[b, k, 0], U[b, k, 1], U[b, k, 2], th[b], gy[b, k], lam, gth[b], gin,
                        buf[nst])
            for q in range(3):
                gU[b, k, q] += gin[q]
        if k == 0:
            break
        kk = k - 1
        hk = h[b, kk] / sub
        # recover the start state of every sub-step of interval kk (one sub-step without bounds: the sample's)
        st[:] = states[b, kk]
        if sub == 1 and not HAS_BOUNDS:
            sub_start[0, :] = st
        else:
            for m in range(sub):
                sub_start[m, :] = st
                substep(b, kk, m, st, K, Y, hk, U, th, c, A, bw, sub, buf[0])
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
                UIN[j, 0], UIN[j, 1], UIN[j, 2] = uu, dd, aa
                rhs_jac(Yst[j], uu, dd, aa, th[b], K[j], FS[j], FT[j], FI[j], buf[j])
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
                if NETS:  # the networks' share: their weights, and through their inputs the state's adjoint
                    gin[:] = 0.0
                    rhs_net_vjp(Yst[j], UIN[j, 0], UIN[j, 1], UIN[j, 2], th[b], lamK[j], lamY, gth[b], gin,
                                buf[j])
                    for q in range(3):
                        gU[b, kk, q] += gin[q] * (1.0 - fr)
                        gU[b, kk + 1, q] += gin[q] * fr
                for l in range(j):
                    for i in range(S):
                        lamK[l, i] += hk * A[j, l] * lamY[i]
                for i in range(S):
                    lam[i] += lamY[i]
    gs0[b, :] = lam'''
