"""Nominal models as compositions of effects.

Two structures cover the seeds:

* ``Constitutive`` — a damper law: the excitation x(t) is prescribed (measured), the response is the
  sum of the effects' forces, and effects with internal state (Bouc–Wen z, Dahl, LuGre) are integrated
  along the excitation history. Seeds 000, 002, 004 and the BRFD friction damper.
* ``DrivenOscillator`` — m ẍ + Σ F_e(x, ẋ, z_e) = g·u for a force drive, or with the effects acting on
  the relative coordinate x − u for a kinematic (base) excitation. The Bouc–Wen benchmark, seed 003's
  piezo actuator, seed 001's two-mass rig.

Both expose the same integration interface to ``hybridhyst.simulate``: ``evaluate`` (parameter values
for a batch of conditions), ``initial_state``, ``derivative`` and ``output``; shapes are batch-first.
``derivative`` and ``output`` are written once for both backends: with tensors they compute the reference,
with sympy symbols (``physics.symbolic.SymbolicState``, symbols for the inputs and parameters) they return
lists of expressions, the equations the compiled path differentiates and generates code from.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import torch
from torch import nn

from .effects.base import Effect, Kinematics, columns, signals, zeros_like
from .parameters import ParameterSpec, build_function, render_unit

__all__ = ["Constitutive", "DrivenOscillator", "InputSample", "NominalModel"]

Params = dict[str, dict[str, torch.Tensor]]
STRUCTURE = "structure"


@dataclass(frozen=True)
class InputSample:
    """The input at one instant: value, rate and second rate, each ``(batch,)``, and the control channels
    ``{name: (batch,)}`` (``Record.controls``), interpolated like the input."""

    u: torch.Tensor
    du: torch.Tensor
    ddu: torch.Tensor
    controls: Mapping = field(default_factory=dict)


def _named_effects(effects) -> nn.ModuleDict:
    if isinstance(effects, nn.ModuleDict):
        return effects
    if hasattr(effects, "items"):
        items = list(effects.items())
    else:
        items = []
        seen: dict[str, int] = {}
        for effect in effects:
            base = effect.name
            seen[base] = seen.get(base, 0) + 1
            items.append((base if seen[base] == 1 else f"{base}_{seen[base]}", effect))
    for key, effect in items:
        if not isinstance(effect, Effect):
            raise ValueError(f"model effect {key!r} is a {type(effect).__name__}, not an Effect")
        if key == STRUCTURE:
            raise ValueError(f"'{STRUCTURE}' is reserved; rename that effect")
    return nn.ModuleDict(dict(items))


def conditions_used(model: nn.Module) -> list[str]:
    """Names of the operating conditions a model's parameter functions read (e.g. ``pressure_mpa``)."""
    found = []
    for module in model.modules():
        name = getattr(module, "condition", None)
        if isinstance(name, str) and name not in found:
            found.append(name)
    return found


class NominalModel(nn.Module):
    """Common machinery: named effects, structure parameters, state layout, kinematics pass."""

    base_state_dim = 0
    structure_specs: dict[str, ParameterSpec] = {}

    def __init__(self, effects, units: dict[str, str] | None = None, name: str = "model", **structure_values):
        super().__init__()
        self.name = name
        self.effects = _named_effects(effects)  # laid out (state offsets) by _init_layout below
        self.units = {"t": "s", "x": "x", "F": "F", "u": "u", **(units or {})}
        unknown = set(structure_values) - set(self.structure_specs)
        if unknown:
            raise ValueError(
                f"{type(self).__name__} has no structure parameter(s) {sorted(unknown)}; "
                f"it has {sorted(self.structure_specs)}"
            )
        self.structure_params = nn.ModuleDict(
            {k: build_function(structure_values.get(k), spec) for k, spec in self.structure_specs.items()}
        )
        self._init_layout(self.effects)

    # -- parameters -------------------------------------------------------------------------------
    def evaluate(self, conditions: dict[str, torch.Tensor] | None, batch: int) -> Params:
        """All parameter values for a batch of operating conditions: {effect: {name: (batch,)}}."""
        out = {key: effect.evaluate(conditions, batch) for key, effect in self.effects.items()}
        follow = signals(conditions)
        for k, fn in self.structure_params.items():
            if fn.condition in follow:
                raise ValueError(f"the structure's {k} cannot follow the control {fn.condition!r}; make an effect's "
                                 "parameter a function of it, or give it as a condition constant within each record")
        out[STRUCTURE] = {k: fn(conditions, batch) for k, fn in self.structure_params.items()}
        return out

    def value_names(self, controls=()) -> dict[str, list[str]]:
        """``{effect: names}`` of the per-row values ``evaluate`` returns when ``controls`` vary in time (the
        structure's under ``"structure"``)."""
        return {**{key: e.value_names(controls) for key, e in self.effects.items()},
                STRUCTURE: list(self.structure_params)}

    def describe(self) -> dict[str, dict[str, dict[str, str]]]:
        """{effect: {parameter: {value, unit}}} with units rendered in the model's unit system. A function of a
        control that effects listed before (a lag, a saturation: ``Effect.transform``) pass on says so: its
        value ends ", voltage after coil then limit"."""
        out = {key: effect.describe(self.units) for key, effect in self.effects.items()}
        passed: dict[str, list[str]] = {}  # control -> the keys of the effects that act on it so far
        for key, effect in self.effects.items():
            for pname, fn in effect.params.items():
                condition = getattr(fn, "condition", None)
                if condition in passed and pname in out[key]:
                    out[key][pname]["value"] += f", {condition} after {' then '.join(passed[condition])}"
            if effect.transforms and getattr(effect, "control", None):
                passed.setdefault(effect.control, []).append(key)
        if self.structure_params:
            out[STRUCTURE] = {
                k: {"value": fn.describe(), "unit": render_unit(self.structure_specs[k].unit, self.units)}
                for k, fn in self.structure_params.items()
            }
        return out

    def data_units(self) -> dict[str, str]:
        """The units a record's input and response columns (``Record.units`` "x", "y") must have for this model,
        where the model declares them: ``{}`` for units left symbolic (the default "x", "F", "u")."""
        want = dict(zip(("x", "y"), self._data_channels()))
        return {k: self.units[name] for k, name in want.items() if name and self.units.get(name, name) != name}

    def _data_channels(self) -> tuple[str | None, str | None]:
        return "x", "F"

    def parameter_table(self) -> dict[str, dict[str, dict]]:
        """{effect: {parameter: {"value": float or text, "unit": str, "fixed": bool}}} for reports: constant
        parameters give a number, condition-dependent ones their description (e.g. a polynomial) and, under
        ``"function"``, their config (kind, condition, coefficients: what a program reads back)."""
        from .parameters import Constant, Fixed

        out: dict[str, dict[str, dict]] = {}
        for key, params in self.describe().items():
            fns = dict(self.effects[key].params.items()) if key in self.effects else dict(self.structure_params.items())
            out[key] = {}
            for pname, info in params.items():
                fn = fns.get(pname)
                value = float(fn(None, 1)[0].detach()) if isinstance(fn, (Constant, Fixed)) else info["value"]
                out[key][pname] = {"value": value, "unit": info["unit"], "fixed": isinstance(fn, Fixed)}
                if fn is not None and not isinstance(fn, (Constant, Fixed)):
                    out[key][pname]["function"] = fn.config()
        return out

    def with_effects(self, effects) -> NominalModel:
        """A copy of this model with another effect list (same structure, units, structure parameters).

        ``effects`` maps keys to ``Effect`` modules (e.g. the current ones plus a new one); the effects
        and the structure parameters are deep-copied, so the original model is left untouched.
        """
        import copy

        # the effects in place are replaced: the copy does not copy them first (memo: they copy to an empty dict)
        new = copy.deepcopy(self, {id(self.effects): nn.ModuleDict()})
        new._init_layout(nn.ModuleDict({k: copy.deepcopy(e) for k, e in effects.items()}))
        return new

    def augmented(self, effects) -> NominalModel:
        """This model with ``effects`` (``{key: Effect}``) added after its own, sharing — not copying — its
        effects and structure parameters: training the augmented model trains this one's parameters (a
        hybrid with a network inside the dynamics keeps the nominal it started from as its physical part)."""
        import copy

        new = copy.copy(self)
        new._parameters, new._buffers, new._modules = dict(self._parameters), dict(self._buffers), dict(self._modules)
        clash = set(effects) & set(self.effects)
        if clash:
            raise ValueError(f"the model already has effect(s) {sorted(clash)}; add them under other keys")
        new._init_layout(nn.ModuleDict({**self.effects, **effects}))
        return new

    def _init_layout(self, effects: nn.ModuleDict) -> None:
        self.effects = _named_effects(effects)
        offsets, start = {}, self.base_state_dim
        for key, effect in self.effects.items():
            offsets[key] = (start, start + effect.state_dim)
            start += effect.state_dim
        self._offsets = offsets
        self.state_dim = start

    def input_delay(self, P: Params) -> torch.Tensor | None:
        delays = [d for key, e in self.effects.items() if (d := e.input_delay(P[key])) is not None]
        return sum(delays) if delays else None

    # -- state --------------------------------------------------------------------------------------
    def initial_state(self, P: Params, batch: int, base: torch.Tensor | None = None,
                      controls: Mapping | None = None) -> torch.Tensor:
        """The state at the start: ``base`` (the structure's [x, v], else rest) and each effect's; ``controls``,
        the control channels' first values ``{name: (batch,)}``, where a record has them."""
        ref = P[STRUCTURE] or next(iter(P.values()))
        ref = next(iter(ref.values())) if ref else torch.zeros(())
        parts = []
        if self.base_state_dim:
            if base is None:
                base = torch.zeros(batch, self.base_state_dim, dtype=ref.dtype, device=ref.device)
            parts.append(base.to(ref.dtype))
        parts += [e.initial_state(P[k], batch, controls) for k, e in self.effects.items() if e.state_dim]
        if not parts:
            return torch.zeros(batch, 0, dtype=ref.dtype, device=ref.device)
        return torch.cat(parts, dim=1)

    def state_bounds(self, P: Params) -> list[tuple] | None:
        """``[(lower, upper)]`` per state component (None where unbounded), or None when no effect bounds its
        state; the simulator projects the state onto these bounds after every step (``Effect.state_bounds``)."""
        out = [(None, None)] * self.state_dim
        found = False
        for key, effect in self.effects.items():
            b = effect.state_bounds(P[key]) if effect.state_dim else None
            if b is not None:
                lo = self._offsets[key][0]
                out[lo:lo + effect.state_dim] = list(b)
                found = True
        return out if found else None

    def _effects_pass(self, kin: Kinematics, state, P: Params, need_rates: bool, forces: dict | None = None,
                      substitute=None):
        """Go through the effects in order: total force, added mass and (optionally) state rates (a list of
        blocks, ``columns`` joins them); each effect's own force goes into ``forces`` when given.
        ``substitute(key, effect, params, kin, state)`` may stand in for an effect: it returns that effect's
        (force, rates), or None to run the effect (the compiled path puts a network's outputs in as symbols)."""
        force = zeros_like(kin.x)
        mass = None
        rates = []
        for key, effect in self.effects.items():
            lo, hi = self._offsets[key]
            s = state[:, lo:hi]
            p = effect.instant(P[key], kin.controls)
            stand_in = substitute(key, effect, p, kin, s) if substitute is not None else None
            if stand_in is not None:
                f, r = stand_in
                force = force + f
                rates += [r] if need_rates and effect.state_dim else []
                continue
            if effect.state_dim and need_rates:
                rates.append(effect.rate(p, kin, s))
            f = effect.force(p, kin, s)
            if f is not None:
                force = force + f
                if forces is not None:
                    forces[key] = f
            m = effect.added_mass(p)
            if m is not None:
                mass = m if mass is None else mass + m
            kin = effect.transform(p, kin, s)
        return force, mass, rates

    def effect_forces(self, state: torch.Tensor, inp: InputSample, P: Params) -> dict[str, torch.Tensor]:
        """Each effect's force ``(batch,)`` at the given states and inputs, ``{effect key: force}`` (effects
        that add no force are absent): what every term contributes along a simulated trajectory."""
        forces: dict[str, torch.Tensor] = {}
        self._effects_pass(self.kinematics(state, inp), state, P, need_rates=False, forces=forces)
        return forces

    # -- to be provided by the structure ----------------------------------------------------------
    def kinematics(self, state: torch.Tensor, inp: InputSample) -> Kinematics:
        """What the first effect sees at these states and inputs."""
        raise NotImplementedError

    @property
    def output_dim(self) -> int:
        raise NotImplementedError

    def derivative(self, state: torch.Tensor, inp: InputSample, P: Params, substitute=None) -> torch.Tensor:
        """ds/dt ``(batch, state_dim)`` (with symbols: a list of expressions); ``substitute``: ``_effects_pass``."""
        raise NotImplementedError

    def output(self, state: torch.Tensor, inp: InputSample, P: Params, substitute=None) -> torch.Tensor:
        """The outputs ``(batch, output_dim)`` (with symbols: a list of expressions)."""
        raise NotImplementedError


class Constitutive(NominalModel):
    """Damper law: y(t) = Σ_e F_e(x, ẋ, z_e) + m ẍ, with ż_e = r_e(x, ẋ, z_e) along the prescribed x(t).

    Input channel 0 is the excitation x [x]; output channel 0 the response [F]. Shapes: the simulator
    passes ``(batch,)`` tensors per instant and returns ``(batch, time, 1)``.
    """

    @property
    def output_dim(self) -> int:
        return 1

    @staticmethod
    def _kinematics(inp: InputSample) -> Kinematics:
        return Kinematics(x=inp.u, v=inp.du, u=inp.u, du=inp.du, a=inp.ddu, controls=inp.controls)

    def kinematics(self, state, inp):
        return self._kinematics(inp)

    def derivative(self, state, inp, P, substitute=None):
        _, _, rates = self._effects_pass(self._kinematics(inp), state, P, need_rates=True, substitute=substitute)
        return columns(rates, state)

    def output(self, state, inp, P, substitute=None):
        force, mass, _ = self._effects_pass(self._kinematics(inp), state, P, need_rates=False, substitute=substitute)
        if mass is not None:
            force = force + mass * inp.ddu
        return columns([force], state)


class DrivenOscillator(NominalModel):
    """Single-DOF oscillator driven by a force or a base motion.

    Force drive (``excitation="force"``)::       m ẍ + Σ_e F_e(x, ẋ, z_e) = g · u(t)
    Base excitation (``excitation="base"``)::    m ẍ + Σ_e F_e(x − u, ẋ − u̇, z_e) = 0

    m [F*t^2/x] is the mass (or inertia; seed 001 uses I = 0.51 in its literal deg/Nm units), g
    [F/u] the drive gain (1 for a force input; K_p d33 / i_ratio for seed 003's voltage input).
    Inertia effects add to m. State: [x, ẋ, effect states]. ``outputs`` picks the returned channels
    from "x", "v", "a" (absolute motion of the mass) and "force" (Σ F_e, e.g. the damper torque).
    """

    base_state_dim = 2
    structure_specs = {
        "mass": ParameterSpec(1.0, "F*t^2/x", (1e-12, 1e12), "positive", doc="mass or inertia"),
        "drive_gain": ParameterSpec(1.0, "F/u", (-1e12, 1e12), "real", doc="force per unit input"),
    }
    _OUTPUTS = ("x", "v", "a", "force")

    def __init__(self, effects, units=None, name="model", excitation: str = "force",
                 outputs: tuple[str, ...] | list[str] | str = ("x",), fixed: tuple[str, ...] = (), **structure):
        if excitation not in ("force", "base"):
            raise ValueError(f"DrivenOscillator: excitation must be 'force' or 'base', got {excitation!r}")
        outputs = (outputs,) if isinstance(outputs, str) else tuple(outputs)
        bad = [o for o in outputs if o not in self._OUTPUTS]
        if bad or not outputs:
            raise ValueError(f"DrivenOscillator: unknown output(s) {bad}; choose from {self._OUTPUTS}")
        if excitation == "base" and "drive_gain" not in fixed:
            fixed = (*fixed, "drive_gain")  # a base-excited oscillator has no drive: nothing to train
        for key in fixed:
            if key not in self.structure_specs:
                raise ValueError(f"DrivenOscillator: cannot fix unknown structure parameter {key!r}")
            structure[key] = {"kind": "fixed", "value": float(structure.get(key, self.structure_specs[key].default))}
        super().__init__(effects, units, name, **structure)
        self.excitation = excitation
        self.outputs = outputs

    @property
    def output_dim(self) -> int:
        return len(self.outputs)

    def _data_channels(self):  # the input is the drive u (a force or a base motion); velocity/acceleration outputs
        return "u", {"x": "x", "force": "F"}.get(self.outputs[0])  # have derived units and are not checked

    def kinematics(self, state, inp):
        return self._kinematics(state, inp)

    def _kinematics(self, state, inp):
        x, v = state[:, 0], state[:, 1]
        if self.excitation == "base":
            x, v = x - inp.u, v - inp.du
        return Kinematics(x=x, v=v, u=inp.u, du=inp.du, a=zeros_like(x), controls=inp.controls)

    def _acceleration(self, force, mass, inp, P):
        m = P[STRUCTURE]["mass"] if mass is None else P[STRUCTURE]["mass"] + mass
        drive = P[STRUCTURE]["drive_gain"] * inp.u if self.excitation == "force" else zeros_like(force)
        return (drive - force) / m

    def derivative(self, state, inp, P, substitute=None):
        force, mass, rates = self._effects_pass(self._kinematics(state, inp), state, P, need_rates=True,
                                                substitute=substitute)
        acc = self._acceleration(force, mass, inp, P)
        return columns([state[:, 1], acc, *rates], state)

    def output(self, state, inp, P, substitute=None):
        force, mass, _ = self._effects_pass(self._kinematics(state, inp), state, P, need_rates=False,
                                            substitute=substitute)
        channels = {"x": lambda: state[:, 0], "v": lambda: state[:, 1], "force": lambda: force,
                    "a": lambda: self._acceleration(force, mass, inp, P)}
        return columns([channels[o]() for o in self.outputs], state)
