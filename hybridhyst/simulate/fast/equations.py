"""A model's equations as sympy expressions, built by running its effects on symbols.

The model's own ``derivative`` and ``output`` — and through them its effects' ``rate``/``force``/
``transform``/``added_mass`` — are called with sympy symbols (see ``physics/symbolic.py``), so the compiled
path integrates exactly the equations of the reference, written once. A network (``NeuralEffect``) enters as
output symbols (``_Networks``, the effects pass's ``substitute``), with its inputs built by the effect's own
``features`` and its force and rates by its ``terms``; the generated code evaluates it (``codegen``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ...physics.effects.neural import NeuralEffect
from ...physics.models import Constitutive, DrivenOscillator, InputSample
from ...physics.symbolic import SymbolicState


@dataclass
class Network:
    """A network inside the equations: its output symbols stand in the right-hand side and outputs; the
    generated code evaluates it (and its adjoint) from the input expressions and its weights in ``th``."""

    key: str  # the effect's key in the model
    inputs: list  # normalised input expressions (of state, inputs and parameters)
    outputs: list  # output symbols
    widths: tuple  # layer sizes (n_in, hidden..., n_out)
    activation: str
    offset: int  # first weight in th (after the P parameters and the networks before it)

    @property
    def n_weights(self) -> int:
        return sum((a + 1) * b for a, b in zip(self.widths[:-1], self.widths[1:]))


@dataclass
class Equations:
    state: list  # state symbols (S)
    inputs: list  # [u, du, ddu, *controls]
    params: list  # parameter symbols (P)
    param_keys: list  # [(effect key or "structure", name)] in the order of ``params``
    rhs: list  # ds/dt (S)
    outputs: list  # model outputs (O)
    lower: list | None = None  # per state: lower bound (an expression of the parameters) or None; None: no bounds
    upper: list | None = None
    networks: list = field(default_factory=list)  # Network per neural effect; weights follow the params in th


def _param_symbols(model, controls=()):
    groups = list(model.value_names(controls).items())
    keys, syms, P = [], [], {}
    for key, names in groups:
        P[key] = {}
        for name in names:
            P[key][name] = sym = sp.Symbol(f"th{len(syms)}", real=True)
            keys.append((key, name))
            syms.append(sym)
    return keys, syms, P


class _Networks:
    """``substitute`` for the models' effects pass: a neural effect's (force, rates) in terms of output
    symbols of one ``Network`` per effect (made on its first call, the same symbols on later ones)."""

    def __init__(self, first_weight: int):
        self.first_weight = first_weight
        self.networks: list[Network] = []
        self._by_key: dict[str, Network] = {}

    def __call__(self, key, effect, p, kin, state):
        if not isinstance(effect, NeuralEffect):
            return None
        net = self._by_key.get(key)
        if net is None:
            layers = effect.net.layers()
            widths = (layers[0].in_features, *(lin.out_features for lin in layers))
            outputs = list(sp.symbols(f"net{len(self.networks)}_0:{widths[-1]}", real=True))
            offset = self.first_weight + sum(n.n_weights for n in self.networks)
            net = Network(key, effect.features(p, kin, state), outputs, widths, effect.net.activation, offset)
            self.networks.append(net)
            self._by_key[key] = net
        return effect.terms(net.outputs, kin)


def build_equations(model, controls: tuple[str, ...] = ()) -> Equations:
    """Symbolic right-hand side and outputs of a ``Constitutive`` or ``DrivenOscillator`` model: its own
    ``derivative`` and ``output`` called on symbols. ``controls``: the control channels, inputs after u, u̇, ü
    (a parameter that follows one is its function of the control's symbol)."""
    if not isinstance(model, (Constitutive, DrivenOscillator)):
        raise ValueError(f"the fast path supports Constitutive and DrivenOscillator models, not {type(model).__name__}")
    inputs = list(sp.symbols("u du ddu", real=True))
    signals = [sp.Symbol(f"ctl{i}", real=True) for i in range(len(controls))]
    state = list(sp.symbols(f"s0:{model.state_dim}", real=True)) if model.state_dim else []
    keys, params, P = _param_symbols(model, controls)
    bounds = model.state_bounds(P)
    lower = None if bounds is None else [b[0] for b in bounds]
    upper = None if bounds is None else [b[1] for b in bounds]
    nets = _Networks(len(params))
    inp = InputSample(*inputs, dict(zip(controls, signals)))
    rhs = model.derivative(SymbolicState(state), inp, P, substitute=nets)
    out = model.output(SymbolicState(state), inp, P, substitute=nets)
    return Equations(state, inputs + signals, params, keys, list(rhs), list(out), lower, upper, nets.networks)
