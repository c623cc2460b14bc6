"""The effect interface: one physical term of a nominal model.

An effect owns named parameters (each a parameter function of the operating condition, constrained by
its ``ParameterSpec``), an optional internal state with its rate equation, and contributes in one of
three ways:

* a resisting force ``force(p, kin, state)`` summed by the structure (most effects);
* an input transformation: ``transform`` maps the kinematics seen by the effects after it
  (backlash/play operator) or ``input_delay`` shifts the time at which the input is read (time delay);
* an added mass ``added_mass`` (inertia).

Effects never loop over time: they return rates and forces for one instant, batched as
``(batch,)`` tensors; ``hybridhyst.simulate`` integrates.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import torch
from torch import nn

from ..parameters import Fixed, ParameterFunction, ParameterSpec, build_function, render_unit

__all__ = [
    "ControlEffect", "Effect", "Kinematics", "abs_pow", "absolute", "clamp", "exp", "rates", "sigmoid", "sign",
    "smooth_sign", "step", "tanh",
]


@dataclass(frozen=True)
class Kinematics:
    """What an effect sees at one instant; every field has shape ``(batch,)``.

    x, v : displacement and velocity the effect acts on (the excitation for a ``Constitutive`` model,
        the relative or absolute coordinate for a ``DrivenOscillator``), after input operators.
    u, du : the raw input (excitation or drive) and its rate.
    a : acceleration of the excitation (used by inertia in a ``Constitutive`` model).
    controls : the control channels at this instant, ``{name: (batch,)}`` (a coil's voltage, an underpressure
        schedule: ``Record.controls``), as the effects before this one left them (a lag, a saturation).
    """

    x: torch.Tensor
    v: torch.Tensor
    u: torch.Tensor
    du: torch.Tensor
    a: torch.Tensor
    controls: Mapping = field(default_factory=dict)

    def moved(self, x: torch.Tensor, v: torch.Tensor) -> Kinematics:
        return replace(self, x=x, v=v)

    def with_control(self, name: str, value) -> Kinematics:
        """These kinematics with control ``name`` replaced by ``value`` for the effects after this one."""
        return replace(self, controls={**self.controls, name: value})


def signals(conditions) -> set[str]:
    """The names of the conditions that vary in time: ``(batch, time)`` tensors among ``conditions``."""
    return {k for k, v in (conditions or {}).items() if isinstance(v, torch.Tensor) and v.ndim == 2}


# Elementary functions used by every effect. With torch tensors they compute the reference path; with
# sympy expressions they build the symbolic equations of the compiled fast path (physics/symbolic.py),
# so each effect's equations are written exactly once.


def _symbolic():
    from .. import symbolic

    return symbolic


def tanh(x):
    return torch.tanh(x) if isinstance(x, torch.Tensor) else _symbolic().tanh(x)


def exp(x):
    return torch.exp(x) if isinstance(x, torch.Tensor) else _symbolic().exp(x)


def sigmoid(x):
    return torch.sigmoid(x) if isinstance(x, torch.Tensor) else _symbolic().sigmoid(x)


def absolute(x):
    return x.abs() if isinstance(x, torch.Tensor) else _symbolic().absolute(x)


def sign(x):
    return x.sign() if isinstance(x, torch.Tensor) else _symbolic().sign(x)


def step(x):
    """The unit step: 1 where x ≥ 0, else 0 (derivative 0)."""
    return (x >= 0).to(x.dtype) if isinstance(x, torch.Tensor) else _symbolic().step(x)


def clamp(x, lo, hi):
    """x limited to [lo, hi] (lo ≤ hi), written with steps so that both paths share it: derivative 1 inside,
    and with respect to the bound that is active outside."""
    return x - (x - hi) * step(x - hi) + (lo - x) * step(lo - x)


def rates(*columns):
    """Assemble an effect's state rates: ``(batch, state_dim)`` for tensors, a list for symbols."""
    if isinstance(columns[0], torch.Tensor):
        return torch.stack(columns, dim=1)
    return list(columns)


def zeros_like(x):
    """Zero of x's kind: a tensor of zeros shaped like x, or the symbolic 0."""
    return torch.zeros_like(x) if isinstance(x, torch.Tensor) else _symbolic().ZERO


def columns(blocks: list, like):
    """Blocks of columns side by side: ``(batch,)`` or ``(batch, k)`` tensors into one ``(batch, n)`` tensor
    (``like``'s shape ``(batch, 0)`` when there are none), or symbols and lists of symbols into one list."""
    if not isinstance(like, torch.Tensor):
        return [x for b in blocks for x in (b if isinstance(b, (list, tuple)) else [b])]
    if not blocks:
        return like.new_zeros(like.shape[0], 0)
    return torch.cat([b[:, None] if b.dim() == 1 else b for b in blocks], dim=1)


def smooth_sign(v, width):
    """tanh(v / width): the smoothed sign used by every friction term (width > 0, in velocity units)."""
    return tanh(v / width)


def abs_pow(z, n):
    """|z|^n with a finite value and gradient (w.r.t. z and n) at z = 0 for n > 0."""
    if not isinstance(z, torch.Tensor):
        return _symbolic().abs_pow(z, n)
    a = z.abs()
    safe = torch.where(a > 0, a, torch.ones_like(a))
    return torch.where(a > 0, safe**n, torch.zeros_like(a))


class Effect(nn.Module):
    """Base class of every effect. Subclasses set ``specs`` and override what they contribute.

    Parameters
    ----------
    fixed : names of parameters held constant (stored as buffers, not trained).
    **values : parameter values: numbers, parameter-function configs (``{"kind": "linear", ...}``)
        or ``ParameterFunction`` modules. Missing parameters take ``spec.default``; a start state (``start``)
        exists only where it is given (a value, or its name in ``fixed``: held at 0).
    """

    specs: ClassVar[dict[str, ParameterSpec]] = {}
    state_dim: ClassVar[int] = 0
    name: ClassVar[str] = "effect"
    equation: ClassVar[str] = ""
    source: ClassVar[str] = ""
    # simpler effect sets this effect contains as an exact special case or limit (e.g. Stribeck with vs → ∞ is
    # Coulomb): the discovery loop tries each in its place and keeps the simpler one when the data allow
    special_cases: ClassVar[tuple[tuple[str, ...], ...]] = ()
    # the state each record starts from, one optional parameter per state component, for elements that the motion
    # before a record may leave away from rest (a gap's position, a presliding deflection): present only where
    # given (``Clearance(q0=...)``); without them the state starts at 0. The discovery loop offers them as a
    # candidate (``discover.candidates.start_candidates``).
    start: ClassVar[dict[str, ParameterSpec]] = {}
    # start_candidate: whether the loop offers one fitted start state shared by every record (False where the
    # start follows the records' history instead: the drifts with travel, ``discover.carried_travel``)
    start_candidate: ClassVar[bool] = True

    # What the discovery loop reads (discover/candidates.py). Declare these on the class; nothing else about an
    # effect is special-cased by name.
    # discovery_candidate: whether the loop offers this effect as a candidate (False for a reparametrisation of
    # another effect, a network, an effect acting on a control, a complete device model).
    discovery_candidate: ClassVar[bool] = True
    # discovery_units: {parameter: unit template} for a parameter whose literal unit is "-" but whose size follows
    # the data (Bouc–Wen's β, γ act on z ~ x: "1/x"); the candidate's start and bounds are scaled by it.
    discovery_units: ClassVar[dict[str, str]] = {}
    # discovery_fixed: {parameter: value} held in the candidate (a form the data can identify).
    discovery_fixed: ClassVar[dict[str, float]] = {}
    # needs_drive: the effect reads a drive u separate from the displacement (a DrivenOscillator); the loop does not
    # offer it to a constitutive law.
    needs_drive: ClassVar[bool] = False
    # example_values: {parameter: value} away from neutral, at which tests compare the compiled simulator with the
    # reference (tests/test_fast.py) and every hook above is exercised; every library effect declares them.
    example_values: ClassVar[dict[str, float]] = {}

    def __init__(self, fixed: tuple[str, ...] | list[str] = (), **values):
        super().__init__()
        unknown = set(values) - set(self.specs) - set(self.start)
        if unknown:
            close = [difflib.get_close_matches(u, [*self.specs, *self.start], n=1) for u in sorted(unknown)]
            hint = "; ".join(f"did you mean {c[0]} for {u}?" for u, c in zip(sorted(unknown), close) if c)
            raise ValueError(
                f"effect {self.name!r} has no parameter(s) {sorted(unknown)}" + (f" ({hint})" if hint else "")
                + f"; its parameters are {sorted(self.specs)}"
                + (f" (and the start state {sorted(self.start)})" if self.start else "")
            )
        bad_fixed = set(fixed) - set(self.specs) - set(self.start)
        if bad_fixed:
            raise ValueError(f"effect {self.name!r}: cannot fix unknown parameter(s) {sorted(bad_fixed)}")
        self.params = nn.ModuleDict()
        self.param_specs: dict[str, ParameterSpec] = dict(self.specs)
        for pname, spec in self.specs.items():
            value = values.get(pname)
            self._check_value(pname, spec, value)
            if pname in fixed:
                value = spec.default if value is None else value
                if not isinstance(value, (int, float)):
                    raise ValueError(f"effect {self.name!r}: a fixed parameter {pname!r} must be a number")
                self.params[pname] = Fixed(value)
            else:
                if spec.constraint == "bounded" and isinstance(value, (int, float)):
                    lo, hi = spec.bounds
                    if not lo < value < hi:  # a sigmoid holds neither bound: only a fixed value may sit there
                        raise ValueError(f"effect {self.name!r}: a trained {pname} must lie strictly inside "
                                         f"({lo:g}, {hi:g}), got {value}; to hold it at or beyond a bound, fix it: "
                                         f"fixed=[{pname!r}]")
                self.params[pname] = build_function(value, spec)
        for pname, spec in self.start.items():
            if pname in values or pname in fixed:
                value = values.get(pname)
                self.add_parameter(pname, spec.default if value is None else value, spec, fixed=pname in fixed)

    # -- parameters -------------------------------------------------------------------------------
    def value_names(self, controls=()) -> list[str]:
        """Names of the per-row values ``evaluate`` returns (the parameters; a network's conditions). A parameter
        that follows one of the ``controls`` passes its function's coordinates instead (``alpha.c0``,
        ``alpha.c1``): its value is taken at every instant (``instant``)."""
        return [name for pname, fn in self.params.items()
                for name in ([pname + s for s in fn.suffixes()] if fn.condition in controls else [pname])]

    def evaluate(self, conditions: dict[str, torch.Tensor] | None, batch: int) -> dict[str, torch.Tensor]:
        """Parameter values for a batch: name -> ``(batch,)`` tensor. A parameter that is a function of a control
        signal (a ``(batch, time)`` condition) gives its coordinates, ``value_names``."""
        follow = signals(conditions)
        out = {}
        for pname, fn in self.params.items():
            if fn.condition in follow:
                coords = fn.coordinate_values()
                out.update({pname + s: v.expand(batch) for s, v in zip(fn.suffixes(), coords)})
            else:
                out[pname] = fn(conditions, batch)
        return out

    def instant(self, p: dict, controls: Mapping) -> dict:
        """``p`` with every parameter that follows a control evaluated at this instant's ``controls``."""
        if not controls:
            return p
        out = None
        for pname, fn in self.params.items():
            if fn.condition in controls and pname not in p:
                out = dict(p) if out is None else out
                out[pname] = fn.at([p[pname + s] for s in fn.suffixes()], controls[fn.condition])
        return p if out is None else out

    def param_unit(self, pname: str, units: dict[str, str] | None = None) -> str:
        """The unit of parameter ``pname`` with the model's ``units`` (``{"F": "Nm", "x": "deg"}``)."""
        return render_unit(self.param_specs[pname].unit, units)

    def options(self) -> dict:
        """The constructor's arguments that are not parameters (e.g. what drives a Bouc–Wen state), as given."""
        return {}

    def config(self) -> dict:
        """``{"effect": name, **options, parameter: value or function config, "fixed": [...]}``: what
        ``physics.build_effect`` builds this effect back from, with its current values."""
        from ..parameters import Fixed

        fixed = [pname for pname, fn in self.params.items() if isinstance(fn, Fixed)]
        return {"effect": self.name, **self.options(), **{pname: fn.config() for pname, fn in self.params.items()},
                **({"fixed": fixed} if fixed else {})}

    def describe(self, units: dict[str, str] | None = None) -> dict[str, dict[str, str]]:
        """Parameter name -> {value (or function), unit} for reports."""
        return {pname: {"value": fn.describe(), "unit": self.param_unit(pname, units)}
                for pname, fn in self.params.items()}

    # -- contributions (defaults: contributes nothing) --------------------------------------------
    def initial_state(self, p: dict[str, torch.Tensor], batch: int, controls: Mapping | None = None) -> torch.Tensor:
        """The state at the start of a record, ``(batch, state_dim)``: the ``start`` parameters where the effect
        has them, else 0. ``controls``: the control channels' first values ``{name: (batch,)}`` (a lag starts
        there)."""
        ref = next(iter(p.values())) if p else torch.zeros(())
        if self.start and all(name in p for name in self.start):
            return torch.stack([p[name].expand(batch) for name in self.start], dim=1)
        return torch.zeros(batch, self.state_dim, dtype=ref.dtype, device=ref.device)

    def rate(self, p: dict[str, torch.Tensor], kin: Kinematics, state: torch.Tensor) -> torch.Tensor:
        """Time derivative of the internal state, ``(batch, state_dim)``."""
        raise NotImplementedError(f"effect {self.name!r} declares state_dim={self.state_dim} but no rate()")

    def force(self, p: dict[str, torch.Tensor], kin: Kinematics, state: torch.Tensor) -> torch.Tensor | None:
        """Resisting force ``(batch,)`` in response units, or None when the effect adds no force."""
        return None

    def state_bounds(self, p: dict[str, torch.Tensor]) -> list[tuple] | None:
        """Bounds ``[(lower, upper)]`` per state component (``(batch,)`` tensors, or None for unbounded), or
        None. The simulator projects the state onto them after every step: a rate-independent operator (the
        play) is then exact at any step size instead of a stiff smoothed ODE."""
        return None

    def transform(self, p: dict[str, torch.Tensor], kin: Kinematics, state: torch.Tensor) -> Kinematics:
        """Kinematics seen by the effects listed after this one (input operators override)."""
        return kin

    @property
    def transforms(self) -> bool:
        """Whether this effect changes what the effects listed after it see (``transform`` overridden: a play on
        the input, a lag or saturation of a control)."""
        return type(self).transform is not Effect.transform

    @property
    def delays_input(self) -> bool:
        """Whether the structure reads its input with a delay this effect sets (``input_delay`` overridden)."""
        return type(self).input_delay is not Effect.input_delay

    def input_delay(self, p: dict[str, torch.Tensor]) -> torch.Tensor | None:
        """Delay ``(batch,)`` [t] with which the structure reads its input, or None."""
        return None

    def added_mass(self, p: dict[str, torch.Tensor]) -> torch.Tensor | None:
        """Mass ``(batch,)`` [F*t^2/x] added to the structure (inertia), or None."""
        return None

    def add_parameter(self, pname: str, value, spec: ParameterSpec, fixed: bool = False) -> None:
        """Register a parameter that exists only in some configurations (e.g. a free Bouc–Wen κ)."""
        self._check_value(pname, spec, value)
        self.param_specs[pname] = spec
        if fixed:
            if not isinstance(value, (int, float)):
                raise ValueError(f"effect {self.name!r}: a fixed parameter {pname!r} must be a number")
            self.params[pname] = Fixed(value)
        else:
            self.params[pname] = build_function(value, spec)

    def _check_value(self, pname: str, spec: ParameterSpec, value) -> None:
        """A value given for ``pname`` is a number or a parameter function, and the numbers that are values of the
        parameter itself (a constant, a fixed value, per-condition levels) lie in its declared domain
        (``ParameterSpec.admits``: > 0 for a positive one, >= 0 for a non-negative one), fixed or trained: a
        negative damping coefficient or friction level feeds energy in, which no damper does. A bounded
        parameter's range is checked where it is built (a fixed one may sit at or beyond a bound). Coefficients
        of a function of a condition are not checked: a negative slope may keep the value positive over the
        data (``identify.space.outside_domain`` checks the values there)."""
        if value is None or isinstance(value, ParameterFunction):
            return
        if not isinstance(value, (int, float)) and not hasattr(value, "items"):
            raise ValueError(f"effect {self.name!r}: parameter {pname} needs a number or a parameter function "
                             f"({{kind: linear, slope: ..., intercept: ..., condition: ...}}), got {value!r}")
        numbers = [value]
        if hasattr(value, "items"):
            kind = value.get("kind", "constant")
            numbers = {"constant": [value.get("value")], "fixed": [value.get("value")],
                       "per_condition": value.get("values")}.get(kind, [])
            numbers = numbers if isinstance(numbers, (list, tuple)) else [numbers]
        for number in numbers:
            if not isinstance(number, (int, float)) or isinstance(number, bool):
                continue  # a malformed function config: build_function names what is wrong with it
            if spec.constraint == "bounded" and math.isfinite(number):
                continue  # checked where it is built: strictly inside when trained, anywhere when fixed
            if not bool(spec.admits(torch.tensor(float(number)))):
                domain = _DOMAIN_WORDS.get(spec.constraint, "a number")
                # 0 turns the term off where it is the neutral value, unless the doc says what 0 means (a drift's
                # levelling rate: 0 keeps the drift linear)
                off = " (0 turns the term off)" if (spec.constraint == "nonnegative" and spec.neutral == 0.0
                                                     and "(0:" not in spec.doc) else ""
                raise ValueError(f"effect {self.name!r}: parameter {pname} ({spec.doc}) needs {domain}, got "
                                 f"{number:g}: give {pname} {domain} in the model config{off}")

    def extra_repr(self) -> str:
        return self.equation


_DOMAIN_WORDS = {"positive": "a value > 0", "nonnegative": "a value >= 0"}


class ControlEffect(Effect):
    """Base of the effects that act on a control channel (``Kinematics.controls``) for the effects listed after
    them: the control's name is an option (``control``), listed by ``physics.conditions_used`` like a parameter
    function's condition, and ``read`` is the control at this instant (a one-line error where the records do not
    carry it)."""

    discovery_candidate = False  # offered by the loop only where a parameter follows the control

    def __init__(self, control: str = "voltage", **values):
        super().__init__(**values)
        if not isinstance(control, str) or not control:
            raise ValueError(f"effect {self.name!r}: control must name a control channel, got {control!r}")
        self.control = control

    @property
    def condition(self) -> str:
        return self.control

    def options(self) -> dict:
        return {"control": self.control}

    def read(self, kin: Kinematics):
        if self.control not in kin.controls:
            raise ValueError(f"effect {self.name!r} acts on the control {self.control!r}, but the records carry "
                             f"{sorted(kin.controls) or 'no control channel'}; name its column in data.controls")
        return kin.controls[self.control]
