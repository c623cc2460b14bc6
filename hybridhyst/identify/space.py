"""The search space of a nominal model: its free scalar coordinates, their bounds, and batched values.

A model's trainable parameters are parameter functions (``Constant``, ``Linear``/``Polynomial``, the
exponential forms, ``PerCondition``); each contributes scalar *coordinates*:

| function | coordinates | name |
|---|---|---|
| ``Constant`` | its value | ``effect.param`` |
| ``Polynomial`` / ``Linear`` | coefficient of c^i | ``effect.param.c<i>`` |
| ``ExpRise`` / ``ExpDecay`` / ``ExpGrowth`` | y0, a, b | ``effect.param.y0`` ... |
| ``PerCondition`` | one value per level | ``effect.param[condition=level]`` |
| ``Fixed`` | none (a buffer) | |

Bounds rule (finite bounds are required by global search): a box around the coordinate's current value
v, ``(v / 10, 10 v)`` for v > 0, ``(10 v, v / 10)`` for v < 0 and ``(-1, 1)`` for v = 0 (``factor``
replaces 10), intersected with ``ParameterSpec.bounds`` for values of the parameter itself (constants and
per-condition levels; function coefficients have other units, so only the box applies). User overrides
``bounds={"dahl.Fc": (0.5, 5)}`` replace the rule for the coordinates named. Coordinates whose box is
strictly positive and spans more than a factor 3 are searched on a log scale. A polynomial's higher
coefficient that starts at 0 (a trend in a condition not yet known) gets ``± factor · |c0| / s^i`` instead of
(-1, 1), with s the largest |condition| in the data (``condition_scales``, which ``identify`` passes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn.utils import parametrize

from ..physics.parameters import (
    Bounded,
    Constant,
    ExpDecay,
    ExpGrowth,
    ExpRise,
    Fixed,
    ParameterSpec,
    PerCondition,
    Polynomial,
    Positive,
    render_unit,
)

__all__ = ["Box", "Coordinate", "SearchSpace"]

_EXP = {ExpRise: lambda y0, a, b, c: y0 + a * (1 - torch.exp(-b * c)),
        ExpDecay: lambda y0, a, b, c: y0 + a * torch.exp(-b * c),
        ExpGrowth: lambda y0, a, b, c: y0 + a * torch.exp(b * c)}


@dataclass(frozen=True)
class Coordinate:
    """One free scalar of the model: where it lives and its search interval.

    Attributes
    ----------
    name : ``effect.param`` (constants), ``effect.param.c1`` (coefficients), ``effect.param[p=0.05]``.
    effect, param : keys in ``model.evaluate`` (``effect`` is ``"structure"`` for mass / drive gain).
    attr, index : attribute of the parameter function holding it and the index in it (None: a scalar).
    value : the value when the space was built; lower, upper : search bounds.
    unit : unit of the coordinate (the parameter's unit for constants and levels, else ``""``).
    """

    name: str
    effect: str
    param: str
    attr: str
    index: int | None
    value: float
    lower: float
    upper: float
    unit: str = ""

    @property
    def positive(self) -> bool:
        return self.lower > 0


class Box:
    """Finite box ``lower <= x <= upper`` and its map to the unit cube (log scale where ``log``).

    Parameters
    ----------
    lower, upper : ``(D,)`` bounds; log : ``(D,)`` booleans, coordinates searched on a log scale.
    """

    def __init__(self, lower, upper, log=None):
        self.lower = torch.as_tensor(lower, dtype=torch.float64)
        self.upper = torch.as_tensor(upper, dtype=torch.float64)
        if self.lower.shape != self.upper.shape or self.lower.ndim != 1:
            raise ValueError(f"bounds must be two (D,) vectors, got shapes {tuple(self.lower.shape)} "
                             f"and {tuple(self.upper.shape)}")
        bad = ~(torch.isfinite(self.lower) & torch.isfinite(self.upper) & (self.upper > self.lower))
        if bool(bad.any()):
            raise ValueError(f"bounds of coordinate(s) {bad.nonzero().flatten().tolist()} are not finite with "
                             "lower < upper; give finite bounds")
        self.log = torch.zeros_like(self.lower, dtype=torch.bool) if log is None else torch.as_tensor(log)
        if bool((self.log & (self.lower <= 0)).any()):
            raise ValueError("a log-scale coordinate needs a positive lower bound")

    @property
    def dim(self) -> int:
        return int(self.lower.shape[0])

    def _ends(self, like: torch.Tensor):
        lo = torch.where(self.log, self.lower.log(), self.lower).to(like)
        hi = torch.where(self.log, self.upper.log(), self.upper).to(like)
        return lo, hi

    def from_unit(self, U: torch.Tensor) -> torch.Tensor:
        """Unit-cube points ``(N, D)`` → coordinates (differentiable)."""
        lo, hi = self._ends(U)
        s = lo + (hi - lo) * U
        return torch.where(self.log.to(U.device), s.exp(), s)

    def to_unit(self, X: torch.Tensor) -> torch.Tensor:
        """Coordinates ``(N, D)`` → unit-cube points."""
        X = torch.as_tensor(X, dtype=torch.float64)
        lo, hi = self._ends(X)
        s = torch.where(self.log, X.clamp_min(1e-300).log(), X)
        return (s - lo) / (hi - lo)


def _box(v: float, factor: float) -> tuple[float, float]:
    if v > 0:
        return v / factor, v * factor
    if v < 0:
        return v * factor, v / factor
    return -1.0, 1.0


def _trend_box(fn, index, v: float, factor: float, condition_scales) -> tuple[float, float] | None:
    """The box of a polynomial's higher coefficient that starts at 0 (a trend not yet known): a term that
    changes the parameter by up to ``factor`` × its constant term over the condition's magnitude,
    ``± factor · |c0| / s^i`` with s = max |condition| in the data; None (the general rule) otherwise."""
    if not (isinstance(fn, Polynomial) and index and v == 0.0 and condition_scales):
        return None
    scale, c0 = condition_scales.get(fn.condition), float(fn.coeffs.detach()[0])
    if not scale or c0 == 0.0:
        return None
    half = factor * abs(c0) / float(scale) ** index
    return -half, half


def _entries(fn, key: str, pname: str):
    """(name suffix, attr, index, current value, is a value of the parameter itself) of one function."""
    if isinstance(fn, Fixed):
        return []
    if isinstance(fn, Constant):
        return [("", "value", None, float(fn.value.detach()), True)]
    if isinstance(fn, Polynomial):
        return [(f".c{i}", "coeffs", i, float(a), False) for i, a in enumerate(fn.coeffs.detach())]
    if type(fn) in _EXP:
        return [(f".{a}", a, None, float(getattr(fn, a).detach()), False) for a in ("y0", "a", "b")]
    if isinstance(fn, PerCondition):
        return [(f"[{fn.condition}={lv:g}]", "values", i, float(v), True)
                for i, (lv, v) in enumerate(zip(fn.levels.tolist(), fn.values.detach().tolist()))]
    raise ValueError(f"parameter {key}.{pname} is a {type(fn).__name__}: global search supports constant, fixed, "
                     "polynomial/linear, exponential and per-condition functions; fix it or replace it")


class SearchSpace(Box):
    """The free coordinates of ``model`` with finite bounds (see the module docstring for the rule).

    Parameters
    ----------
    model : a ``NominalModel``; its current values centre the default boxes.
    bounds : ``{coordinate name: (lower, upper)}`` overrides.
    factor : width of the default box, ``(v / factor, v · factor)``.
    free : names of the coordinates to search (default: all); the others are held at their current
        values (e.g. the discovery loop fitting only a newly added effect).
    """

    def __init__(self, model: nn.Module, bounds: Mapping[str, tuple[float, float]] | None = None,
                 factor: float = 10.0, free=None, condition_scales: Mapping[str, float] | None = None):
        self.model = model
        self.functions = {(k, n): fn for k, e in model.effects.items() for n, fn in e.params.items()}
        specs = {(k, n): e.param_specs[n] for k, e in model.effects.items() for n in e.params}
        self.functions.update({("structure", n): fn for n, fn in model.structure_params.items()})
        specs.update({("structure", n): model.structure_specs[n] for n in model.structure_params})
        bounds = dict(bounds or {})
        coords = []
        for (key, pname), fn in self.functions.items():
            for suffix, attr, index, v, own in _entries(fn, key, pname):
                name = f"{key}.{pname}{suffix}"
                override = bounds.pop(name, None)
                if override is None:
                    override = _trend_box(fn, index, v, factor, condition_scales)
                lo, hi = self._bounds(v, specs[(key, pname)] if own else None, factor, override)
                unit = render_unit(specs[(key, pname)].unit, model.units) if own else ""
                coords.append(Coordinate(name, key, pname, attr, index, v, lo, hi, unit))
        if bounds:
            raise ValueError(f"bounds given for unknown coordinate(s) {sorted(bounds)}; "
                             f"the coordinates are {[c.name for c in coords]}")
        self.held: list[Coordinate] = []
        if free is not None:
            free = set(free)
            unknown = free - {c.name for c in coords}
            if unknown:
                raise ValueError(f"free coordinate(s) {sorted(unknown)} are not in the model; "
                                 f"its coordinates are {[c.name for c in coords]}")
            self.held = [c for c in coords if c.name not in free]
            coords = [c for c in coords if c.name in free]
        if not coords:
            raise ValueError("the model has no free parameters to identify; un-fix at least one")
        self.coordinates = coords
        log = [c.lower > 0 and c.upper / c.lower > 3 for c in coords]
        super().__init__([c.lower for c in coords], [c.upper for c in coords], log)

    @staticmethod
    def _bounds(v: float, spec: ParameterSpec | None, factor: float, override) -> tuple[float, float]:
        if override is not None:
            lo, hi = (float(b) for b in override)
        else:
            lo, hi = _box(v, factor)
            if spec is not None:
                lo, hi = max(lo, spec.bounds[0]), min(hi, spec.bounds[1])
                if spec.constraint == "positive" and lo <= 0:
                    lo = min(hi, abs(v) if v > 0 else 1.0) / factor**2
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ValueError(f"empty or infinite search interval ({lo}, {hi}) for value {v}; give bounds")
        return lo, hi

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.coordinates]

    def initial(self) -> torch.Tensor:
        """The model's current coordinates ``(D,)`` (float64)."""
        out = []
        for c in self.coordinates:
            t = getattr(self.functions[(c.effect, c.param)], c.attr).detach()
            out.append(float(t if c.index is None else t[c.index]))
        return torch.tensor(out, dtype=torch.float64)

    # -- population -> per-row parameter values ----------------------------------------------------
    def values(self, X: torch.Tensor, conditions: Mapping[str, torch.Tensor] | None, repeats: int) -> dict:
        """Per-row values for ``simulate(values=...)``: ``X (N, D)`` at ``repeats`` = R record conditions.

        Row ``n * R + r`` holds member n at record r. ``conditions`` maps a condition name to ``(R,)``.
        Differentiable w.r.t. ``X``.
        """
        N, R = X.shape[0], int(repeats)
        cols = {}
        for j, c in enumerate(self.coordinates):
            cols.setdefault((c.effect, c.param), {})[(c.attr, c.index)] = X[:, j]
        for c in self.held:
            cols.setdefault((c.effect, c.param), {})[(c.attr, c.index)] = X.new_full((N,), c.value)
        out: dict[str, dict[str, torch.Tensor]] = {}
        for (key, pname), fn in self.functions.items():
            v = self._function_values(fn, cols.get((key, pname), {}), conditions, N, R, X)
            out.setdefault(key, {})[pname] = v.reshape(N * R)
        return out

    @staticmethod
    def _condition(fn, conditions, R, like) -> torch.Tensor:
        if not conditions or fn.condition not in conditions:
            raise ValueError(f"a parameter is a function of {fn.condition!r} but the records give "
                             f"{sorted(conditions or {})}; add that condition to every record")
        return torch.as_tensor(conditions[fn.condition], dtype=like.dtype).reshape(1, R)

    def _function_values(self, fn, col, conditions, N, R, X) -> torch.Tensor:
        if isinstance(fn, Fixed):
            return fn.value.detach().to(X).expand(N, R)
        if isinstance(fn, Constant):
            return col[("value", None)][:, None].expand(N, R)
        c = self._condition(fn, conditions, R, X)
        if isinstance(fn, Polynomial):
            K = fn.coeffs.shape[0]
            coeffs = torch.stack([col[("coeffs", i)] for i in range(K)], dim=1)
            return sum(coeffs[:, i:i + 1] * c**i for i in range(K))
        if type(fn) in _EXP:
            y0, a, b = (col[(n, None)][:, None] for n in ("y0", "a", "b"))
            return _EXP[type(fn)](y0, a, b, c)
        levels = fn.levels.to(X)
        match = torch.isclose(c.reshape(R, 1), levels[None, :], rtol=1e-9, atol=1e-12)
        if not bool(match.any(dim=1).all()):
            raise ValueError(f"PerCondition on {fn.condition!r}: a record's level is not one of {levels.tolist()}")
        vals = torch.stack([col[("values", i)] for i in range(levels.shape[0])], dim=1)
        return vals[:, match.to(torch.long).argmax(dim=1)]

    # -- writing back --------------------------------------------------------------------------------
    def to_model(self, x) -> nn.Module:
        """Write the coordinates ``x (D,)`` into the model (through the parametrizations' right_inverse)."""
        x = torch.as_tensor(x, dtype=torch.float64).detach().reshape(-1)
        if x.shape[0] != self.dim:
            raise ValueError(f"expected {self.dim} coordinates, got {x.shape[0]}")
        grouped: dict[tuple, list] = {}
        for c, v in zip(self.coordinates, x.tolist()):
            grouped.setdefault((c.effect, c.param, c.attr), []).append((c.index, v))
        with torch.no_grad():
            for (key, pname, attr), items in grouped.items():
                fn = self.functions[(key, pname)]
                current = getattr(fn, attr).detach().clone()
                for index, v in items:
                    if index is None:
                        current = torch.tensor(v, dtype=current.dtype)
                    else:
                        current[index] = v
                if parametrize.is_parametrized(fn, attr):
                    setattr(fn, attr, _interior(fn, attr, current))
                else:
                    getattr(fn, attr).copy_(current)
        return self.model


def _interior(fn: nn.Module, attr: str, value: torch.Tensor) -> torch.Tensor:
    """``value`` moved strictly inside the range of the attribute's constraint (right_inverse needs that)."""
    for p in fn.parametrizations[attr]:
        if isinstance(p, Bounded):
            eps = 1e-9 * (p.high - p.low)
            value = value.clamp(p.low + eps, p.high - eps)
        elif isinstance(p, Positive):
            value = value.clamp_min(p.floor + 1e-300)
    return value
