"""Parameter functions: an operating condition (e.g. underpressure p [MPa]) → a parameter value.

Every effect parameter is one of these modules; ``Constant`` is the usual case. Functions follow the seeds:
linear and polynomial in p (seed 001 Table 1), exponential rise-to-maximum / decay / growth (seed 002
eqs. 7-12), one value per condition level, and a small neural network. Each function owns its coordinates
(the free scalars identification searches) and their batched evaluation.
"""

from __future__ import annotations

import torch
from torch import nn

from ...nets import MLP
from .base import FunctionCoordinate, ParameterFunction, _condition_tensor
from .constraints import ParameterSpec, _constrain

__all__ = [
    "Constant",
    "ExpDecay",
    "ExpGrowth",
    "ExpRise",
    "Fixed",
    "Linear",
    "NeuralFunction",
    "PerCondition",
    "Polynomial",
    "build_function",
    "project_to_bounds",
]


def _exp(x):
    """exp of a tensor, or of a sympy expression (a function of a control inside the compiled equations)."""
    if isinstance(x, torch.Tensor):
        return torch.exp(x)
    import sympy

    return sympy.exp(x)


class Constant(ParameterFunction):
    """Same value for every condition, constrained by the parameter's spec."""

    _attrs = ("value",)
    _own = "value"

    def __init__(self, value: float, spec: ParameterSpec | None = None):
        super().__init__()
        self.value = nn.Parameter(torch.tensor(float(value), dtype=torch.get_default_dtype()))
        _constrain(self, "value", spec)

    def _coordinate(self, path, index, value):
        return FunctionCoordinate("", value, own=True)

    def evaluate_batch(self, coords, conditions, batch):
        return coords[:, :1].expand(coords.shape[0], batch)

    def describe(self) -> str:
        return f"{float(self.value.detach()):.6g}"

    def config(self) -> float:
        return float(self.value.detach())


class Fixed(ParameterFunction):
    """A constant that is not trained (a buffer); it has no coordinates."""

    def __init__(self, value: float):
        super().__init__()
        self.register_buffer("value", torch.tensor(float(value), dtype=torch.get_default_dtype()))

    def coordinates(self) -> list[FunctionCoordinate]:
        return []

    def evaluate_batch(self, coords, conditions, batch):
        return self.value.to(coords).expand(coords.shape[0], batch)

    def describe(self) -> str:
        return f"{float(self.value.detach()):.6g} (fixed)"

    def config(self) -> float:
        return float(self.value)


class Polynomial(ParameterFunction):
    """y = Σ_i coeffs[i] · c^i (coeffs in increasing power, as in seed 001 Table 1 read right to left; ``nonnegative``:
    every coefficient ≥ 0).

    Identification's boxes for a nonnegative one start at 0: it models a quantity that starts at a nonnegative
    value and grows with a condition that is never negative (the travel a device has made before a record,
    ``discover.carried_travel``), so that no fit can make it fall, or turn negative, beyond the conditions it was
    fitted on."""

    _attrs = ("coeffs",)
    _kind = "polynomial"

    def __init__(self, coeffs: list[float], condition: str = "pressure_mpa", nonnegative: bool = False):
        super().__init__()
        if len(coeffs) == 0:
            raise ValueError("Polynomial needs at least one coefficient")
        if nonnegative and any(float(c) < 0 for c in coeffs):
            raise ValueError(f"a nonnegative {self._kind} function needs every coefficient >= 0, got "
                             f"{self._named(coeffs)}")
        self.condition = condition
        self.nonnegative = bool(nonnegative)
        self.coeffs = nn.Parameter(torch.tensor([float(c) for c in coeffs], dtype=torch.get_default_dtype()))

    @staticmethod
    def _named(coeffs) -> str:
        return ", ".join(f"c{i} = {float(c):g}" for i, c in enumerate(coeffs))

    def _coordinate(self, path, index, value):
        return FunctionCoordinate(f".c{index}", value, power=index, nonnegative=self.nonnegative)

    def evaluate_batch(self, coords, conditions, batch):
        return self.at([coords[:, i:i + 1] for i in range(coords.shape[1])], self._c(conditions, batch, coords))

    def at(self, coords, c):
        value = coords[0]
        for i in range(1, len(coords)):
            value = value + coords[i] * (c if i == 1 else c**i)  # c**1 is c, bit for bit; a power costs more
        return value

    def describe(self) -> str:
        terms = [f"{float(a):+.6g}·{self.condition}^{i}" for i, a in enumerate(self.coeffs.detach())]
        return " ".join(terms)

    def config(self) -> dict:
        return {"kind": "polynomial", "coeffs": self.coeffs.detach().tolist(), "condition": self.condition,
                **({"nonnegative": True} if self.nonnegative else {})}


class Linear(Polynomial):
    """y = intercept + slope · c (``nonnegative``: both ≥ 0, as ``Polynomial``)."""

    _kind = "linear"

    def __init__(self, slope: float, intercept: float, condition: str = "pressure_mpa", nonnegative: bool = False):
        super().__init__([intercept, slope], condition, nonnegative)

    @staticmethod
    def _named(coeffs) -> str:
        return f"intercept {float(coeffs[0]):g}, slope {float(coeffs[1]):g}"

    def config(self) -> dict:
        intercept, slope = self.coeffs.detach().tolist()
        return {"kind": "linear", "slope": slope, "intercept": intercept, "condition": self.condition,
                **({"nonnegative": True} if self.nonnegative else {})}


class _Exponential(ParameterFunction):
    """y = y0 + a · f(b · c) with ``_shape`` f; coordinates y0, a, b."""

    _attrs = ("y0", "a", "b")

    def __init__(self, y0: float, a: float, b: float, condition: str = "pressure_mpa"):
        super().__init__()
        self.condition = condition
        dtype = torch.get_default_dtype()
        self.y0 = nn.Parameter(torch.tensor(float(y0), dtype=dtype))
        self.a = nn.Parameter(torch.tensor(float(a), dtype=dtype))
        self.b = nn.Parameter(torch.tensor(float(b), dtype=dtype))

    def _coordinate(self, path, index, value):
        return FunctionCoordinate(f".{path}", value)

    @staticmethod
    def _shape(bc: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def evaluate_batch(self, coords, conditions, batch):
        return self.at([coords[:, 0:1], coords[:, 1:2], coords[:, 2:3]], self._c(conditions, batch, coords))

    def at(self, coords, c):
        y0, a, b = coords
        return y0 + a * self._shape(b * c)

    _form = "{y0} + {a}·f({b}·{c})"

    def describe(self) -> str:
        v = {k: f"{float(getattr(self, k).detach()):.6g}" for k in ("y0", "a", "b")}
        return self._form.format(c=self.condition, **v)

    def config(self) -> dict:
        kind = next(k for k, cls in _FUNCTIONS.items() if cls is type(self))
        return {"kind": kind, **{k: float(getattr(self, k).detach()) for k in self._attrs},
                "condition": self.condition}


class ExpRise(_Exponential):
    """Exponential rise to maximum (seed 002 eq. 9): y = y0 + a (1 − exp(−b c))."""

    _form = "{y0} + {a}·(1 − exp(−{b}·{c}))"

    @staticmethod
    def _shape(bc):
        return 1 - _exp(-bc)


class ExpDecay(_Exponential):
    """Exponential decay (seed 002 eq. 7): y = y0 + a exp(−b c)."""

    _form = "{y0} + {a}·exp(−{b}·{c})"

    @staticmethod
    def _shape(bc):
        return _exp(-bc)


class ExpGrowth(_Exponential):
    """Exponential growth (seed 002 eq. 8): y = y0 + a exp(b c)."""

    _form = "{y0} + {a}·exp({b}·{c})"

    @staticmethod
    def _shape(bc):
        return _exp(bc)


class PerCondition(ParameterFunction):
    """One free value per level of a condition (levels given up front; unknown levels are an error).

    The values are stored as ``level_values`` (``values`` reads them): a constraint's parametrization cannot
    be registered under the name ``values``, which ``ModuleDict`` already has as a method.
    """

    _attrs = ("level_values",)
    _own = "level_values"

    def __init__(self, levels: list[float], values: list[float] | float, condition: str,
                 spec: ParameterSpec | None = None):
        super().__init__()
        self.condition = condition
        if isinstance(values, (int, float)):
            values = [float(values)] * len(levels)
        if len(levels) != len(values):
            raise ValueError(f"PerCondition: {len(levels)} levels but {len(values)} values")
        self.register_buffer("levels", torch.tensor([float(v) for v in levels], dtype=torch.get_default_dtype()))
        self.level_values = nn.Parameter(torch.tensor([float(v) for v in values], dtype=torch.get_default_dtype()))
        _constrain(self, "level_values", spec)
        self.register_load_state_dict_pre_hook(_renamed_level_values)

    @property
    def values(self) -> torch.Tensor:
        """The value at each level ``(L,)`` (constrained)."""
        return self.level_values

    def _coordinate(self, path, index, value):
        return FunctionCoordinate(f"[{self.condition}={float(self.levels[index]):g}]", value, own=True)

    def evaluate_batch(self, coords, conditions, batch):
        c = self._c(conditions, batch, coords)[0]
        levels = self.levels.to(coords)
        match = torch.isclose(c[:, None], levels[None, :], rtol=1e-9, atol=1e-12)
        missing = ~match.any(dim=1)
        if bool(missing.any()):
            raise ValueError(
                f"PerCondition on {self.condition!r}: level(s) {sorted(set(c[missing].tolist()))} have no value; "
                f"known levels are {levels.tolist()}"
            )
        return coords[:, match.to(torch.long).argmax(dim=1)]

    def describe(self) -> str:
        pairs = zip(self.levels.tolist(), self.level_values.detach().tolist())
        return ", ".join(f"{self.condition}={lv:g}: {v:.6g}" for lv, v in pairs)

    def config(self) -> dict:
        return {"kind": "per_condition", "levels": self.levels.tolist(), "values": self.values.detach().tolist(),
                "condition": self.condition}


def _renamed_level_values(module, state_dict, prefix, *args) -> None:
    """Load a state dict saved when ``PerCondition`` stored its values as ``values``."""
    if prefix + "values" in state_dict and prefix + "level_values" not in state_dict:
        state_dict[prefix + "level_values"] = state_dict.pop(prefix + "values")


class NeuralFunction(ParameterFunction):
    """Small MLP of one condition, added to a base value: y = base + MLP(c). Starts at ``base``.

    The network is ``nets.MLP(1, 1, [hidden], "tanh")`` with a zero-initialised output layer. Its
    coordinates are ``base`` then every network weight (``.net.body.0.weight[i]`` ...), searched in boxes
    symmetric about 0.
    """

    def __init__(self, base: float, condition: str, hidden: int = 16):
        super().__init__()
        self.condition = condition
        dtype = torch.get_default_dtype()
        self.base = nn.Parameter(torch.tensor(float(base), dtype=dtype))
        self.net = MLP(1, 1, [int(hidden)], "tanh", zero_last=True)

    def _coordinate_tensors(self) -> list[tuple[str, torch.Tensor]]:
        return [("base", self.base), *((f"net.{n}", p) for n, p in self.net.named_parameters())]

    def _coordinate(self, path, index, value):
        if path == "base":
            return FunctionCoordinate(".base", value)
        return FunctionCoordinate(f".{path}[{index}]", value, signed=True)

    def forward(self, conditions, batch):
        c = _condition_tensor(conditions, self.condition, self.base).expand(batch)
        return self.base + self.net(c[:, None]).squeeze(-1)

    def evaluate_batch(self, coords, conditions, batch):
        c = self._c(conditions, batch, coords)[0]
        shapes = [(n, p.shape) for n, p in self.net.named_parameters()]

        def net_at(flat: torch.Tensor) -> torch.Tensor:  # one member's network on all conditions
            params, offset = {}, 0
            for name, shape in shapes:
                params[name] = flat[offset:offset + shape.numel()].reshape(shape)
                offset += shape.numel()
            return torch.func.functional_call(self.net, params, (c[:, None],)).squeeze(-1)

        return coords[:, :1] + torch.func.vmap(net_at)(coords[:, 1:])

    def config(self) -> dict:
        """The network's form only: its weights are in the model's state dict (``model.pt``)."""
        return {"kind": "neural", "base": float(self.base.detach()), "condition": self.condition,
                "hidden": self.net.hidden[0]}


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
    (kinds: constant, fixed, linear, polynomial, exp_rise, exp_decay, exp_growth, per_condition, neural).
    """
    if isinstance(value, ParameterFunction):
        return value
    if value is None:
        if spec is None:
            raise ValueError("a parameter without a value needs a spec with a default")
        value = spec.default
    if isinstance(value, (int, float)):
        if spec is not None and spec.constraint in ("positive", "nonnegative") and not bool(
                spec.admits(torch.tensor(float(value)))):  # (an effect names itself first: Effect._check_value)
            need = "> 0" if spec.constraint == "positive" else ">= 0"
            raise ValueError(f"parameter '{spec.doc or 'unnamed'}' needs a value {need}, got {value:g}: give one "
                             f"{need} in the model config")
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
    their coefficients have no sign constraint, only their values do — except a nonnegative polynomial's,
    whose coefficients are put back at ≥ 0.
    """
    for module in model.modules():
        if isinstance(module, Polynomial) and module.nonnegative:
            with torch.no_grad():
                module.coeffs.clamp_(min=0.0)
            continue
        specs = getattr(module, "param_specs", None)
        params = getattr(module, "params", None)
        if not specs or params is None:
            continue
        for pname, fn in params.items():
            spec = specs.get(pname)
            if spec is not None and spec.constraint == "nonnegative":
                fn.project(*spec.bounds)
