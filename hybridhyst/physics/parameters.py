"""Constrained physical parameters and parameter functions of an operating condition.

A physical parameter is stored unconstrained and mapped to its admissible range by a
``torch.nn.utils.parametrize`` parametrization (``Positive``: softplus, ``Bounded``: scaled sigmoid),
never by clamping, so gradients survive at the bounds.

A *parameter function* maps an operating condition (e.g. underpressure p [MPa]) to a parameter value.
Every effect parameter is one of these modules; ``Constant`` is the usual case. Functions follow the
seeds: linear and polynomial in p (seed 001 Table 1), exponential rise-to-maximum / decay / growth
(seed 002 eqs. 7-12), one value per condition level, and a small neural network.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn.utils import parametrize

__all__ = [
    "Bounded",
    "Constant",
    "ExpDecay",
    "ExpGrowth",
    "ExpRise",
    "Fixed",
    "Linear",
    "NeuralFunction",
    "ParameterFunction",
    "ParameterSpec",
    "PerCondition",
    "Polynomial",
    "Positive",
    "build_function",
    "project_to_bounds",
    "render_unit",
]


class Positive(nn.Module):
    """Softplus map R -> (floor, inf) with an exact inverse (``right_inverse``)."""

    def __init__(self, floor: float = 0.0):
        super().__init__()
        self.floor = float(floor)

    def forward(self, raw: torch.Tensor) -> torch.Tensor:
        # log(1 + e^raw) without softplus's threshold switch (discontinuous by ~1e-9 at raw = 20)
        return torch.logaddexp(raw, torch.zeros_like(raw)) + self.floor

    def right_inverse(self, value: torch.Tensor) -> torch.Tensor:
        y = torch.as_tensor(value) - self.floor
        if torch.any(y <= 0):
            raise ValueError(f"Positive parameter needs a value > {self.floor}, got {value.tolist()}")
        # log(expm1(y)) computed stably for large y
        return y + torch.log(-torch.expm1(-y))


class Bounded(nn.Module):
    """Scaled sigmoid map R -> (low, high) with an exact inverse."""

    def __init__(self, low: float, high: float):
        super().__init__()
        if not high > low:
            raise ValueError(f"Bounded needs low < high, got ({low}, {high})")
        self.low, self.high = float(low), float(high)

    def forward(self, raw: torch.Tensor) -> torch.Tensor:
        return self.low + (self.high - self.low) * torch.sigmoid(raw)

    def right_inverse(self, value: torch.Tensor) -> torch.Tensor:
        s = (torch.as_tensor(value) - self.low) / (self.high - self.low)
        if torch.any((s <= 0) | (s >= 1)):
            raise ValueError(
                f"Bounded parameter needs a value strictly inside ({self.low}, {self.high}), got {value.tolist()}"
            )
        return torch.logit(s)


@dataclass(frozen=True)
class ParameterSpec:
    """Definition of one effect parameter.

    Parameters
    ----------
    default : value used when the configuration gives none (the effect's neutral value where it has one).
    unit : unit template in the model's symbols ``F`` (response), ``x`` (excitation/displacement),
        ``u`` (input), ``t`` (time), e.g. ``"F*s/x"`` for a viscous coefficient; see ``render_unit``.
    bounds : search bounds used by identification; also the hard range when ``constraint="bounded"``.
    constraint : ``"positive"``, ``"nonnegative"``, ``"bounded"`` or ``"real"``.
    neutral : the value at which the effect contributes nothing (used when discovery adds it).
    doc : one line on what the parameter is.
    """

    default: float
    unit: str = "-"
    bounds: tuple[float, float] = (-math.inf, math.inf)
    constraint: str = "real"
    neutral: float | None = None
    doc: str = ""


def render_unit(template: str, units: dict[str, str] | None) -> str:
    """Render a unit template such as ``"F*s/x"`` with the model's units ({'F': 'Nm', 'x': 'deg'})."""
    if not units:
        return template
    out = []
    token = ""
    for ch in template + " ":
        if ch.isalpha() or ch == "_":
            token += ch
            continue
        if token:
            out.append(units.get(token, token))
            token = ""
        if ch != " ":
            out.append(ch)
    return "".join(out)


def _constrain(module: nn.Module, name: str, spec: ParameterSpec | None) -> None:
    if spec is None or spec.constraint == "real":
        return
    if spec.constraint == "positive":
        parametrize.register_parametrization(module, name, Positive())
    elif spec.constraint == "nonnegative":
        # Amplitudes whose neutral value is exactly 0 (an effect added by discovery starts there) stay
        # unconstrained in storage: softplus cannot reach 0 and would zero the gradient near it.
        # Identification keeps them inside ``spec.bounds``.
        return
    elif spec.constraint == "bounded":
        parametrize.register_parametrization(module, name, Bounded(*spec.bounds))
    else:
        raise ValueError(f"unknown constraint {spec.constraint!r}; use positive, nonnegative, bounded or real")


def _condition_tensor(conditions: dict[str, torch.Tensor] | None, name: str, like: torch.Tensor) -> torch.Tensor:
    if conditions is None or name not in conditions:
        known = sorted(conditions) if conditions else []
        raise ValueError(
            f"parameter function needs condition {name!r} but the records give {known}; "
            f"add a {name!r} condition to every record or use a constant parameter"
        )
    return torch.as_tensor(conditions[name], dtype=like.dtype, device=like.device)


class ParameterFunction(nn.Module):
    """Base class: ``forward(conditions, batch) -> (batch,)`` parameter values."""

    condition: str | None = None

    def forward(self, conditions: dict[str, torch.Tensor] | None, batch: int) -> torch.Tensor:
        raise NotImplementedError

    def describe(self) -> str:
        return type(self).__name__


class Constant(ParameterFunction):
    """Same value for every condition, constrained by the parameter's spec."""

    def __init__(self, value: float, spec: ParameterSpec | None = None):
        super().__init__()
        self.value = nn.Parameter(torch.tensor(float(value), dtype=torch.get_default_dtype()))
        _constrain(self, "value", spec)

    def forward(self, conditions, batch):
        return self.value.expand(batch)

    def describe(self) -> str:
        return f"{float(self.value.detach()):.6g}"


class Fixed(ParameterFunction):
    """A constant that is not trained (a buffer, per STYLE rule 3)."""

    def __init__(self, value: float):
        super().__init__()
        self.register_buffer("value", torch.tensor(float(value), dtype=torch.get_default_dtype()))

    def forward(self, conditions, batch):
        return self.value.expand(batch)

    def describe(self) -> str:
        return f"{float(self.value.detach()):.6g} (fixed)"


class Polynomial(ParameterFunction):
    """y = Σ_i coeffs[i] · c^i (coeffs in increasing power, as in seed 001 Table 1 read right to left)."""

    def __init__(self, coeffs: list[float], condition: str = "pressure_mpa"):
        super().__init__()
        if len(coeffs) == 0:
            raise ValueError("Polynomial needs at least one coefficient")
        self.condition = condition
        self.coeffs = nn.Parameter(torch.tensor([float(c) for c in coeffs], dtype=torch.get_default_dtype()))

    def forward(self, conditions, batch):
        c = _condition_tensor(conditions, self.condition, self.coeffs).expand(batch)
        powers = torch.stack([c**i for i in range(self.coeffs.shape[0])], dim=-1)
        return powers @ self.coeffs

    def describe(self) -> str:
        terms = [f"{float(a):+.6g}·{self.condition}^{i}" for i, a in enumerate(self.coeffs.detach())]
        return " ".join(terms)


class Linear(Polynomial):
    """y = intercept + slope · c."""

    def __init__(self, slope: float, intercept: float, condition: str = "pressure_mpa"):
        super().__init__([intercept, slope], condition)


class _Exponential(ParameterFunction):
    def __init__(self, y0: float, a: float, b: float, condition: str = "pressure_mpa"):
        super().__init__()
        self.condition = condition
        dtype = torch.get_default_dtype()
        self.y0 = nn.Parameter(torch.tensor(float(y0), dtype=dtype))
        self.a = nn.Parameter(torch.tensor(float(a), dtype=dtype))
        self.b = nn.Parameter(torch.tensor(float(b), dtype=dtype))

    def _c(self, conditions, batch):
        return _condition_tensor(conditions, self.condition, self.y0).expand(batch)

    _form = "{y0} + {a}·f({b}·{c})"

    def describe(self) -> str:
        v = {k: f"{float(getattr(self, k).detach()):.6g}" for k in ("y0", "a", "b")}
        return self._form.format(c=self.condition, **v)


class ExpRise(_Exponential):
    """Exponential rise to maximum (seed 002 eq. 9): y = y0 + a (1 − exp(−b c))."""

    _form = "{y0} + {a}·(1 − exp(−{b}·{c}))"

    def forward(self, conditions, batch):
        return self.y0 + self.a * (1 - torch.exp(-self.b * self._c(conditions, batch)))


class ExpDecay(_Exponential):
    """Exponential decay (seed 002 eq. 7): y = y0 + a exp(−b c)."""

    _form = "{y0} + {a}·exp(−{b}·{c})"

    def forward(self, conditions, batch):
        return self.y0 + self.a * torch.exp(-self.b * self._c(conditions, batch))


class ExpGrowth(_Exponential):
    """Exponential growth (seed 002 eq. 8): y = y0 + a exp(b c)."""

    _form = "{y0} + {a}·exp({b}·{c})"

    def forward(self, conditions, batch):
        return self.y0 + self.a * torch.exp(self.b * self._c(conditions, batch))


class PerCondition(ParameterFunction):
    """One free value per level of a condition (levels given up front; unknown levels are an error)."""

    def __init__(self, levels: list[float], values: list[float] | float, condition: str,
                 spec: ParameterSpec | None = None):
        super().__init__()
        self.condition = condition
        if isinstance(values, (int, float)):
            values = [float(values)] * len(levels)
        if len(levels) != len(values):
            raise ValueError(f"PerCondition: {len(levels)} levels but {len(values)} values")
        self.register_buffer("levels", torch.tensor([float(v) for v in levels], dtype=torch.get_default_dtype()))
        self.values = nn.Parameter(torch.tensor([float(v) for v in values], dtype=torch.get_default_dtype()))
        _constrain(self, "values", spec)

    def forward(self, conditions, batch):
        c = _condition_tensor(conditions, self.condition, self.levels).expand(batch)
        match = torch.isclose(c[:, None], self.levels[None, :], rtol=1e-9, atol=1e-12)
        missing = ~match.any(dim=1)
        if bool(missing.any()):
            raise ValueError(
                f"PerCondition on {self.condition!r}: level(s) {sorted(set(c[missing].tolist()))} have no value; "
                f"known levels are {self.levels.tolist()}"
            )
        return self.values[match.to(torch.long).argmax(dim=1)]

    def describe(self) -> str:
        pairs = zip(self.levels.tolist(), self.values.detach().tolist())
        return ", ".join(f"{self.condition}={lv:g}: {v:.6g}" for lv, v in pairs)


class NeuralFunction(ParameterFunction):
    """Small MLP of one condition, added to a base value: y = base + MLP(c). Starts at ``base``."""

    def __init__(self, base: float, condition: str, hidden: int = 16):
        super().__init__()
        self.condition = condition
        dtype = torch.get_default_dtype()
        self.base = nn.Parameter(torch.tensor(float(base), dtype=dtype))
        self.net = nn.Sequential(nn.Linear(1, hidden, dtype=dtype), nn.Tanh(), nn.Linear(hidden, 1, dtype=dtype))
        nn.init.zeros_(self.net[-1].weight)
        nn.init.zeros_(self.net[-1].bias)

    def forward(self, conditions, batch):
        c = _condition_tensor(conditions, self.condition, self.base).expand(batch)
        return self.base + self.net(c[:, None]).squeeze(-1)


_FUNCTIONS = {
    "constant": Constant,
    "fixed": Fixed,
    "linear": Linear,
    "polynomial": Polynomial,
    "exp_rise": ExpRise,
    "exp_decay": ExpDecay,
    "exp_growth": ExpGrowth,
    "per_condition": PerCondition,
    "neural": NeuralFunction,
}


def build_function(value, spec: ParameterSpec | None = None) -> ParameterFunction:
    """Build a parameter function from a config value.

    ``value`` is a number (a ``Constant`` with the spec's constraint), an existing ``ParameterFunction``,
    or a mapping ``{"kind": "linear", "slope": ..., "intercept": ..., "condition": "pressure_mpa"}``
    (kinds: constant, linear, polynomial, exp_rise, exp_decay, exp_growth, per_condition, neural).
    """
    if isinstance(value, ParameterFunction):
        return value
    if value is None:
        if spec is None:
            raise ValueError("a parameter without a value needs a spec with a default")
        value = spec.default
    if isinstance(value, (int, float)):
        return Constant(float(value), spec)
    if hasattr(value, "items"):
        kwargs = dict(value.items())
        kind = kwargs.pop("kind", "constant")
        if kind not in _FUNCTIONS:
            raise ValueError(f"unknown parameter function {kind!r}; choose one of {sorted(_FUNCTIONS)}")
        if kind in ("constant", "per_condition"):
            kwargs["spec"] = spec
        if kind == "polynomial":
            kwargs["coeffs"] = list(kwargs["coeffs"])
        return _FUNCTIONS[kind](**kwargs)
    raise ValueError(f"cannot build a parameter function from {value!r}")


def project_to_bounds(model: nn.Module) -> None:
    """Projected-gradient step: put unconstrained amplitudes (``nonnegative``) back inside their bounds.

    Call after an optimiser step. These parameters are stored unconstrained so that they can sit exactly
    at their neutral value 0 with a live gradient; the projection (not a clamp inside the forward pass)
    keeps them admissible. Parameter functions of a condition (linear, polynomial, …) are not projected:
    their coefficients have no sign constraint, only their values do.
    """
    for module in model.modules():
        specs = getattr(module, "param_specs", None)
        params = getattr(module, "params", None)
        if not specs or params is None:
            continue
        for pname, fn in params.items():
            spec = specs.get(pname)
            if spec is None or spec.constraint != "nonnegative":
                continue
            attr = "value" if isinstance(fn, Constant) else "values" if isinstance(fn, PerCondition) else None
            if attr is None or parametrize.is_parametrized(fn, attr):
                continue
            lo, hi = spec.bounds
            with torch.no_grad():
                getattr(fn, attr).clamp_(min=lo if math.isfinite(lo) else None, max=hi if math.isfinite(hi) else None)
