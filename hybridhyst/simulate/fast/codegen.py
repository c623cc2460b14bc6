"""Generate and compile (C, the system compiler) the integration loops of one model with exact discrete adjoints.

For a model with S states, P parameters, O outputs and NI inputs (u, u̇, ü and the control channels),
the generated C holds the kernels ``rhs(s, in, th, f, buf)`` and ``rhs_jac(..., f, fs, fth, fin, buf)``
(values and Jacobians w.r.t. state, parameters and inputs), the same pair for the outputs, the state bounds,
and then the loops of ``loops.c`` (one per library, below): ``forward``, ``backward`` (the exact adjoint of the
discrete explicit Runge–Kutta map on the sample grid with sub-steps — the same numbers as autograd through the
reference loop) and ``tangent`` (the same map's forward sensitivities w.r.t. every parameter and network weight in
one pass: whole Jacobians for Levenberg–Marquardt; the networks' share of each Jacobian row is one
back-propagation through their layers, ``rhs_net_vjp`` with a unit weight). ``runtime.c`` comes first: the
non-smooth functions and the MLP kernels.

Powers and functions of the parameters alone (LuGre's 1/vs², a level's reciprocal) are not evaluated at every stage:
the kernels read them after the parameters in ``th``, where ``hoisted(th)`` writes them once per row (``_Printer``;
the same expressions printed the same way, so the same numbers). The forward sensitivities carry through the states
only the columns that reach them (``_state_columns``: ``LIVE``, ``RHS_NETS``).

A network inside the equations is a small MLP kernel (``_mlp_forward``) over its weights, which follow the
P parameters in ``th``; the Jacobian kernels hold every network's output fixed, and ``rhs_net_vjp`` /
``out_net_vjp`` add the networks' part of the chain rule by back-propagating the adjoint through them
(``_network_vjp``), reading the layers the Jacobian kernel left in a buffer at the same point.

Each model has two sources (``SOURCES``): ``values`` (the bounds, right-hand side and outputs: what the forward loop
reads; no derivative of anything but the bounds) and ``derivatives`` (every kernel: the tangent and the adjoint
loops). ``build.py`` builds the loops a call needs, one shared library each (``forward`` from the values source,
``tangent`` and ``backward`` from the derivatives source, chosen by ``-DHH_FORWARD`` / ``-DHH_TANGENT`` /
``-DHH_BACKWARD``), when a call first needs them: a model only simulated never generates its Jacobians. Every kernel is
the same expression printed the same way in either source (a hoisted value's index may differ), so the same numbers.
"""

from __future__ import annotations

import hashlib
import os
import threading
from contextlib import contextmanager
from pathlib import Path

import sympy as sp
from sympy.core import exprtools
from sympy.core.basic import Basic
from sympy.printing.c import C99CodePrinter

from .equations import Equations

_HERE = Path(__file__).parent
RUNTIME = (_HERE / "runtime.c").read_text()
LOOPS = (_HERE / "loops.c").read_text()


class _Printer(C99CodePrinter):
    """sympy's C99 printer with the equations' own functions; with ``params`` (the parameter symbols) a power or a
    function call of the parameters alone is read from ``th[first + k]`` instead of evaluated (its k-th entry of
    ``hoisted``): a row's parameters do not change along its record, so ``hoisted_kernel`` evaluates each once per row
    (the loops' ``with_hoisted``), the same expression printed the same way, so the same value."""

    def __init__(self, params=(), first: int = 0):
        super().__init__()
        self._params, self._first = frozenset(params), first
        self.hoisted: dict = {}

    def _print(self, expr, **kwargs):
        if (self._params and isinstance(expr, (sp.Pow, sp.Function)) and expr.free_symbols
                and expr.free_symbols <= self._params):
            return f"th[{self._first + self.hoisted.setdefault(expr, len(self.hoisted))}]"
        return super()._print(expr, **kwargs)

    def hoisted_kernel(self, eq: Equations) -> str:
        """``hoisted(th)``: writes every hoisted value after the ``first`` entries of ``th``."""
        plain = _Printer()
        lines = ["static inline void hoisted(double *th) {"]
        lines += [f"    const double {p} = th[{i}];" for i, p in enumerate(eq.params)]
        lines += [f"    th[{self._first + k}] = {plain.doprint(e)};" for e, k in self.hoisted.items()]
        lines += ["    (void)th;", "}"]
        return "\n".join(lines)

    def _print_Sign(self, expr):
        return f"_sign({self._print(expr.args[0])})"

    def _print_Step(self, expr):
        return f"_step({self._print(expr.args[0])})"

    def _print_Tanh(self, expr):
        return f"tanh({self._print(expr.args[0])})"

    def _print_Absolute(self, expr):
        return f"fabs({self._print(expr.args[0])})"

    def _print_AbsPow(self, expr):
        return f"_abs_pow({self._print(expr.args[0])}, {self._print(expr.args[1])})"

    def _print_AbsPowLog(self, expr):
        return f"_abs_pow_log({self._print(expr.args[0])}, {self._print(expr.args[1])})"


_ACTIVATIONS = {"tanh": 0, "relu": 1, "gelu": 2, "silu": 3, "elu": 4}  # codes of _act / _dact in runtime.c
# the kernels' arguments and their C types
_ARGS = {"s": "const double *s", "in": "const double *in", "th": "const double *th", "w": "const double *w"}


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
        lines.append(f"    double *Z{k} = buf + {z_at}, *A{k} = buf + {a_at};")
        if evaluate:
            lines.append(f"    double nin{k}[{net.widths[0]}];")
            lines += [f"    nin{k}[{a}] = {printer.doprint(e)};" for a, e in enumerate(net.inputs)]
            act = _ACTIVATIONS[net.activation]
            lines.append(f"    _mlp_forward(nin{k}, th, {net.offset}, W{k}, {n_layers}, {act}, Z{k}, A{k}, {width});")
        lines += [f"    const double {o} = A{k}[{n_layers * width + j}];" for j, o in enumerate(net.outputs)]
    return lines


def _kernel(name: str, args: list[str], targets: list[tuple[str, sp.Expr]], printer, eq: Equations,
            head: list[str] | None = None, tail: list[str] | None = None, evaluate: bool = True) -> str:
    """A C function assigning each ``target`` (e.g. ``f[0]``) its expression, with CSE. Where the targets
    read networks, their layers are in the argument ``buf`` (evaluated there first, or, without ``evaluate``,
    already there). ``head`` lines run first, ``tail`` lines last."""
    exprs = [e for _, e in targets]
    subs, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("cse"), optimizations="basic")
    signature = ", ".join(_ARGS.get(a, f"double *{a}") for a in args)
    lines = [f"static inline void {name}({signature}) {{"]
    lines += head or []
    lines += [f"    const double {s} = s[{i}];" for i, s in enumerate(eq.state)]
    lines += [f"    const double {u} = in[{i}];" for i, u in enumerate(eq.inputs)]
    lines += [f"    const double {p} = th[{i}];" for i, p in enumerate(eq.params)]
    if "buf" in args:
        lines += _network_lines(eq, printer, evaluate, set().union(*(e.free_symbols for e in exprs)))
    lines += [f"    const double {sym} = {printer.doprint(val)};" for sym, val in subs]
    lines += [f"    {tgt} = {printer.doprint(e)};" for (tgt, _), e in zip(targets, reduced)]
    lines += tail or []
    lines.append("}")
    return "\n".join(lines)


def _jac(exprs, wrt, name: str) -> list[tuple[str, sp.Expr]]:
    """Targets ``name[i * len(wrt) + j]`` = d exprs[i] / d wrt[j] (a row-major matrix); an entry whose symbol
    the expression lacks is 0 without asking sympy (which walks the whole expression for it: most entries)."""
    free = [sp.sympify(e).free_symbols for e in exprs]
    return [(f"{name}[{i * len(wrt) + j}]", sp.diff(e, w) if w in free[i] else sp.S.Zero)
            for i, e in enumerate(exprs) for j, w in enumerate(wrt)]


_GCD_LOCK = threading.RLock()
# a fork waits for a generation in progress: the child never inherits sympy's functions swapped, nor the lock held by
# a thread it does not have
os.register_at_fork(before=_GCD_LOCK.acquire, after_in_parent=_GCD_LOCK.release, after_in_child=_GCD_LOCK.release)


@contextmanager
def _shared_gcd_terms():
    """sympy's CSE preprocessing (``factor_terms``, part of ``optimizations="basic"``) calls ``gcd_terms`` on
    every sum inside every expression it is given, again for each expression that holds the same sum: a model's
    Jacobian entries share most of their sums (about a hundred distinct in seven to eight thousand calls for the
    models of every effect). While one model's source is generated, equal sums share one result: the same source,
    byte for byte, in about half the time for the largest models (``scripts/bench_build.py``). ``gcd_terms`` is a
    pure function of its arguments and of sympy's global ``evaluate`` / ``distribute`` switches (in the key); it is
    swapped in sympy's module for the duration, under a lock (one generation at a time: the GIL serialises sympy's
    work anyway), and serves only the generating thread: another thread's calls go to sympy's own."""
    from sympy.core.parameters import global_parameters

    done: dict = {}
    owner = threading.get_ident()

    def gcd_terms(terms, isprimitive=False, clear=True, fraction=True):
        if threading.get_ident() != owner:
            return original(terms, isprimitive, clear, fraction)
        key = (terms, isprimitive, clear, fraction, global_parameters.evaluate, global_parameters.distribute)
        try:
            return done[key]
        except KeyError:
            out = done[key] = original(terms, isprimitive, clear, fraction)
            return out
        except TypeError:  # an unhashable argument (a list or dict of terms)
            return original(terms, isprimitive, clear, fraction)

    with _GCD_LOCK:  # read and swapped under the lock: another thread's generation has put sympy's back
        original = exprtools.gcd_terms
        exprtools.gcd_terms = gcd_terms
        try:
            yield
        finally:
            exprtools.gcd_terms = original


@contextmanager
def _shared_free_symbols():
    """sympy computes an expression's ``free_symbols`` by walking it at every call and keeps no answer; ``diff`` asks
    it of every factor of every product at every level, ``_jac`` and the networks' inputs again: about a quarter of
    the derivatives source's generation for the models of every effect. While one model's source is generated, each
    expression's answer is kept (expressions are immutable; keyed by identity, the expression held with it) and a
    copy handed out (sympy's callers change the set they get): the same source, byte for byte. Swapped in sympy's
    ``Basic`` for the duration under ``_GCD_LOCK``, and serving only the generating thread, as ``_shared_gcd_terms``."""
    done: dict = {}
    owner = threading.get_ident()

    def free_symbols(self):
        if threading.get_ident() != owner:
            return original.fget(self)
        hit = done.get(id(self))
        if hit is None or hit[0] is not self:
            hit = done[id(self)] = (self, original.fget(self))
        return set(hit[1])

    with _GCD_LOCK:
        original = Basic.__dict__.get("free_symbols")
        if not isinstance(original, property):  # another sympy: its own, uncached
            yield
            return
        Basic.free_symbols = property(free_symbols, doc=original.__doc__)
        try:
            yield
        finally:
            Basic.free_symbols = original


def _network_adjoint(name: str, exprs: list, printer, eq: Equations) -> str:
    """``name(s, in, th, w, lam, gth, gin, buf)``: the networks' part of the adjoint of ``exprs``
    (the right-hand side or the outputs) weighted by ``w``, with the networks' layers in ``buf`` (written by
    ``rhs_jac`` / ``out_jac`` at the same point): adds to ``lam`` (the state's adjoint), ``gth`` (the
    parameters' and the weights') and ``gin`` (the inputs: u, du, ddu, controls). ``rhs_jac`` / ``out_jac`` hold
    the rest of the Jacobians, with every network's outputs held: together they are the full chain rule."""
    args = ["s", "in", "th", "w", "lam", "gth", "gin", "buf"]
    n_s, n_p, n_i = len(eq.state), len(eq.params), len(eq.inputs)
    head, targets, tail = [], [], []
    for k, net in enumerate(eq.networks):
        dfdn = _jac(exprs, net.outputs, f"dfdn{k}")
        if all(e == 0 for _, e in dfdn):
            continue  # these expressions do not read this network
        n_in, n_out, n_layers = net.widths[0], net.widths[-1], len(net.widths) - 1
        head += [f"    double dfdn{k}[{len(exprs) * n_out}] = {{0}};",
                 f"    double dins{k}[{max(n_in * n_s, 1)}] = {{0}};",
                 f"    double dinth{k}[{max(n_in * n_p, 1)}] = {{0}};",
                 f"    double dinin{k}[{n_in * n_i}] = {{0}};"]
        targets += dfdn
        targets += _jac(net.inputs, eq.state, f"dins{k}")
        targets += _jac(net.inputs, eq.params, f"dinth{k}")
        targets += _jac(net.inputs, eq.inputs, f"dinin{k}")
        tail.append(f"    _network_vjp(w, {len(exprs)}, dfdn{k}, dins{k}, {n_s}, dinth{k}, {n_p}, dinin{k}, {n_i}, th, "
                    f"{net.offset}, W{k}, {n_layers}, {_ACTIVATIONS[net.activation]}, Z{k}, A{k}, {max(net.widths)}, "
                    "lam, gth, gin);")
    targets = [(t, e) for t, e in targets if e != 0]  # the arrays start at zero
    return _kernel(name, args, targets, printer, eq, head=head, tail=tail, evaluate=False)


def _state_columns(eq: Equations) -> tuple[list[bool], bool]:
    """Which parameters reach the state (they enter the right-hand side, the inputs of a network it reads, or a
    state bound), and whether the right-hand side reads any network (then every weight counts as reaching it):
    the state tangent of any other column stays zero, and ``tangent_row`` leaves it out."""
    read = set().union(*(sp.sympify(e).free_symbols for e in eq.rhs))
    nets = [net for net in eq.networks if read & set(net.outputs)]
    for net in nets:
        read |= set().union(*(sp.sympify(e).free_symbols for e in net.inputs))
    for e in (eq.lower or []) + (eq.upper or []):
        if e is not None:
            read |= sp.sympify(e).free_symbols
    return [p in read for p in eq.params], bool(nets)


SOURCES = ("values", "derivatives")


def generate_source(eq: Equations, kind: str = "derivatives") -> str:
    """One of the C sources of one model (``SOURCES``): runtime, sizes, the kernels, loops."""
    if kind not in SOURCES:
        raise ValueError(f"unknown source {kind!r}; choose one of {SOURCES}")
    with _shared_gcd_terms(), _shared_free_symbols():
        return _source(eq, kind)


def _source(eq: Equations, kind: str = "derivatives") -> str:
    n_state, n_param, n_out = len(eq.state), len(eq.params), len(eq.outputs)
    n_th = n_param + sum(net.n_weights for net in eq.networks)  # th's columns: the parameters, the weights
    printer = _Printer(eq.params, first=n_th)
    args = ["s", "in", "th"]
    f_t = [(f"f[{i}]", e) for i, e in enumerate(eq.rhs)]
    g_t = [(f"g[{i}]", e) for i, e in enumerate(eq.outputs)]
    big = sp.Float(1e300)  # an unbounded state: a bound no state reaches
    lower = [(f"lo[{i}]", -big if e is None else e) for i, e in enumerate(eq.lower or [None] * n_state)]
    upper = [(f"hi[{i}]", big if e is None else e) for i, e in enumerate(eq.upper or [None] * n_state)]
    b_full = lower + upper + _jac([e for _, e in lower], eq.params, "dlo") + _jac([e for _, e in upper], eq.params,
                                                                                 "dhi")
    widths = [f"static const int W{k}[] = {{{', '.join(map(str, net.widths))}}};" for k, net in enumerate(eq.networks)]
    live, rhs_nets = _state_columns(eq)
    # the kernels in one order in both sources (the derivatives source's text as when it was the only one)
    kernels = [_kernel("bounds", args + ["lo", "hi", "dlo", "dhi"], b_full, printer, eq),
               _kernel("rhs", args + ["f", "buf"], f_t, printer, eq)]
    if kind == "derivatives":
        f_full = f_t + _jac(eq.rhs, eq.state, "fs") + _jac(eq.rhs, eq.params, "fth") + _jac(eq.rhs, eq.inputs, "fin")
        kernels.append(_kernel("rhs_jac", args + ["f", "fs", "fth", "fin", "buf"], f_full, printer, eq))
    kernels.append(_kernel("out", args + ["g", "buf"], g_t, printer, eq))
    if kind == "derivatives":
        g_full = g_t + _jac(eq.outputs, eq.state, "gs") + _jac(eq.outputs, eq.params, "gth") + _jac(eq.outputs,
                                                                                                  eq.inputs, "gin")
        kernels += [_kernel("out_jac", args + ["g", "gs", "gth", "gin", "buf"], g_full, printer, eq),
                    _network_adjoint("rhs_net_vjp", eq.rhs, printer, eq),
                    _network_adjoint("out_net_vjp", eq.outputs, printer, eq)]
    parts = [
        f"/* Generated by hybridhyst.simulate.fast.codegen — do not edit. The {kind} source. */",
        RUNTIME,
        f"#define S {n_state}\n#define P {n_param}\n#define O {n_out}\n#define NI {len(eq.inputs)}\n"
        f"#define NTH {n_th} /* th's columns; the values hoisted out of the kernels follow */\n"
        f"#define NH {len(printer.hoisted)}\n"
        f"#define HAS_BOUNDS {int(eq.lower is not None)}\n"
        f"#define NETS {int(bool(eq.networks))}\n#define NB {max(_buffer_layout(eq)[1], 1)} "
        "/* the networks' layer values at one point */",
        f"#define RHS_NETS {int(rhs_nets)} /* the right-hand side reads a network */\n"
        f"static const int LIVE[DIM(P)] = {{{', '.join(str(int(x)) for x in live) or '0'}}}; "
        "/* the parameters that reach the state */",
        "\n".join(widths),
        printer.hoisted_kernel(eq),
        *kernels,
        LOOPS,
    ]
    return "\n\n".join(p for p in parts if p) + "\n"


# the generator's own sources: a changed template or kernel generator must not find the libraries it built before
_GENERATOR = hashlib.sha1(Path(__file__).read_bytes() + RUNTIME.encode() + LOOPS.encode()).hexdigest()[:16]


def equations_key(eq: Equations) -> str:
    """A hash of the equations themselves (cheap next to generating their source: CSE and Jacobians) and of
    this generator."""
    text = repr((eq.state, eq.inputs, eq.params, eq.rhs, eq.outputs, eq.lower, eq.upper, eq.networks, _GENERATOR))
    return hashlib.sha1(text.encode()).hexdigest()[:16]
