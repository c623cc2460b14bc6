"""A model's equations as sympy expressions, built by running its effects on symbols.

The effects' own ``rate``/``force``/``transform``/``added_mass`` methods are called with sympy symbols
(see ``physics/symbolic.py``), so the compiled path integrates exactly the equations of the reference. A
network (``NeuralEffect``) enters as output symbols, with its inputs built by the effect's own
``features`` and its force and rates by its ``terms``; the generated code evaluates it (``codegen``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ...physics.effects.base import Kinematics
from ...physics.effects.neural import NeuralEffect
from ...physics.models import STRUCTURE, Constitutive, DrivenOscillator
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
    inputs: list  # [u, du, ddu]
    params: list  # parameter symbols (P)
    param_keys: list  # [(effect key or "structure", name)] in the order of ``params``
    rhs: list  # ds/dt (S)
    outputs: list  # model outputs (O)
    lower: list | None = None  # per state: lower bound (an expression of the parameters) or None; None: no bounds
    upper: list | None = None
    networks: list = field(default_factory=list)  # Network per neural effect; weights follow the params in th


def _param_symbols(model):
    groups = [(key, effect.value_names()) for key, effect in model.effects.items()]
    groups.append((STRUCTURE, list(model.structure_params)))
    keys, syms, P = [], [], {}
    for key, names in groups:
        P[key] = {}
        for name in names:
            P[key][name] = sym = sp.Symbol(f"th{len(syms)}", real=True)
            keys.append((key, name))
            syms.append(sym)
    return keys, syms, P


def _network(effect, key, P, kin, st, networks, first_weight) -> tuple:
    """A neural effect's (force, rates) in terms of new output symbols; its call is appended to ``networks``."""
    layers = effect.net.layers()
    widths = (layers[0].in_features, *(lin.out_features for lin in layers))
    k = len(networks)
    outputs = list(sp.symbols(f"net{k}_0:{widths[-1]}", real=True))
    offset = first_weight + sum(n.n_weights for n in networks)
    networks.append(Network(key, effect.features(P[key], kin, st), outputs, widths, effect.net.activation, offset))
    return effect.terms(outputs)


def _effects_pass(model, kin, state, P, networks, first_weight):
    force, mass, rates = sp.S.Zero, None, []
    for key, effect in model.effects.items():
        lo, hi = model._offsets[key]
        st = SymbolicState(state[lo:hi])
        if isinstance(effect, NeuralEffect):
            f, r = _network(effect, key, P, kin, st, networks, first_weight)
            force, rates = force + f, rates + r
            continue
        if effect.state_dim:
            rates += list(effect.rate(P[key], kin, st))
        f = effect.force(P[key], kin, st)
        if f is not None:
            force = force + f
        m = effect.added_mass(P[key])
        if m is not None:
            mass = m if mass is None else mass + m
        kin = effect.transform(P[key], kin, st)
    return force, mass, rates


def build_equations(model) -> Equations:
    """Symbolic right-hand side and outputs of a ``Constitutive`` or ``DrivenOscillator`` model."""
    if not isinstance(model, (Constitutive, DrivenOscillator)):
        raise ValueError(f"the fast path supports Constitutive and DrivenOscillator models, not {type(model).__name__}")
    u, du, ddu = sp.symbols("u du ddu", real=True)
    state = list(sp.symbols(f"s0:{model.state_dim}", real=True)) if model.state_dim else []
    keys, params, P = _param_symbols(model)
    bounds = model.state_bounds(P)
    lower = None if bounds is None else [b[0] for b in bounds]
    upper = None if bounds is None else [b[1] for b in bounds]
    nets: list[Network] = []
    if isinstance(model, Constitutive):
        kin = Kinematics(x=u, v=du, u=u, du=du, a=ddu)
        force, mass, rates = _effects_pass(model, kin, state, P, nets, len(params))
        out = force + (mass * ddu if mass is not None else 0)
        return Equations(state, [u, du, ddu], params, keys, rates, [out], lower, upper, nets)
    x, v = state[0], state[1]
    if model.excitation == "base":
        kin = Kinematics(x=x - u, v=v - du, u=u, du=du, a=sp.S.Zero)
    else:
        kin = Kinematics(x=x, v=v, u=u, du=du, a=sp.S.Zero)
    force, mass, rates = _effects_pass(model, kin, state, P, nets, len(params))
    m = P[STRUCTURE]["mass"] + (mass if mass is not None else 0)
    drive = P[STRUCTURE]["drive_gain"] * u if model.excitation == "force" else 0
    acc = (drive - force) / m
    channels = {"x": x, "v": v, "a": acc, "force": force}
    return Equations(state, [u, du, ddu], params, keys, [v, acc, *rates], [channels[o] for o in model.outputs],
                     lower, upper, nets)
