"""A model's equations as sympy expressions, built by running its effects on symbols.

The effects' own ``rate``/``force``/``transform``/``added_mass`` methods are called with sympy symbols
(see ``physics/symbolic.py``), so the compiled path integrates exactly the equations of the reference.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ...physics.effects.base import Kinematics
from ...physics.models import STRUCTURE, Constitutive, DrivenOscillator
from ...physics.symbolic import SymbolicState


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


def _param_symbols(model):
    groups = [(key, list(effect.params)) for key, effect in model.effects.items()]
    groups.append((STRUCTURE, list(model.structure_params)))
    keys, syms, P = [], [], {}
    for key, names in groups:
        P[key] = {}
        for name in names:
            P[key][name] = sym = sp.Symbol(f"th{len(syms)}", real=True)
            keys.append((key, name))
            syms.append(sym)
    return keys, syms, P


def _effects_pass(model, kin, state, P):
    force, mass, rates = sp.S.Zero, None, []
    for key, effect in model.effects.items():
        lo, hi = model._offsets[key]
        st = SymbolicState(state[lo:hi])
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
    if isinstance(model, Constitutive):
        kin = Kinematics(x=u, v=du, u=u, du=du, a=ddu)
        force, mass, rates = _effects_pass(model, kin, state, P)
        out = force + (mass * ddu if mass is not None else 0)
        return Equations(state, [u, du, ddu], params, keys, rates, [out], lower, upper)
    x, v = state[0], state[1]
    if model.excitation == "base":
        kin = Kinematics(x=x - u, v=v - du, u=u, du=du, a=sp.S.Zero)
    else:
        kin = Kinematics(x=x, v=v, u=u, du=du, a=sp.S.Zero)
    force, mass, rates = _effects_pass(model, kin, state, P)
    m = P[STRUCTURE]["mass"] + (mass if mass is not None else 0)
    drive = P[STRUCTURE]["drive_gain"] * u if model.excitation == "force" else 0
    acc = (drive - force) / m
    channels = {"x": x, "v": v, "a": acc, "force": force}
    return Equations(state, [u, du, ddu], params, keys, [v, acc, *rates], [channels[o] for o in model.outputs],
                     lower, upper)
