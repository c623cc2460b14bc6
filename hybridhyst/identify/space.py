"""The search space of a nominal model: its free scalar coordinates, their bounds, and batched values.

A model's trainable parameters are parameter functions; each declares its scalar *coordinates* and
evaluates a population of them (``ParameterFunction.coordinates`` / ``evaluate_batch`` in
``physics/parameters.py``), so this module only lays them side by side:

| function | coordinates | name |
|---|---|---|
| ``Constant`` | its value | ``effect.param`` |
| ``Polynomial`` / ``Linear`` | coefficient of c^i | ``effect.param.c<i>`` |
| ``ExpRise`` / ``ExpDecay`` / ``ExpGrowth`` | y0, a, b | ``effect.param.y0`` ... |
| ``PerCondition`` | one value per level | ``effect.param[condition=level]`` |
| ``NeuralFunction`` | base, then every network weight | ``effect.param.base``, ``effect.param.net.head.weight[0]`` |
| ``Fixed`` | none (a buffer) | |

Bounds rule (finite bounds are required by global search): a box around the coordinate's current value
v, ``(v / 10, 10 v)`` for v > 0, ``(10 v, v / 10)`` for v < 0 and ``(-1, 1)`` for v = 0 (``factor``
replaces 10), intersected with ``ParameterSpec.bounds`` for values of the parameter itself (constants and
per-condition levels; function coefficients have other units, so only the box applies). Coordinates of
unknown sign (network weights, a start state: ``ParameterSpec.signed``) get ``(-10 |v|, 10 |v|)`` instead; the
coefficients of a nonnegative polynomial (``Polynomial(nonnegative=True)``: the travel a device made before a record)
never reach below 0, a user's box for them included (one entirely below 0 is an error). User overrides
``bounds={"dahl.Fc": (0.5, 5)}`` replace the rule for the coordinates named.
Coordinates whose box is strictly positive and spans more than a factor 3 are searched on a log scale.

Polynomial trends (``trend_scale``, the one rule of identification and the discovery loop; only when the data's
range of the condition is known): a coefficient of c^i (i ≥ 1) that starts at 0 gets ``± factor · |c0| / Δ_i``,
where Δ_i is how much c^i changes over the data's range of the condition (``condition_ranges``, from the
records): a coefficient at the edge changes the parameter by ``factor`` × its value across the data. When every
higher coefficient starts at 0, the constant term gets ``c0 ± (factor · |c0| + Σ_i half_i · max|c|^i)`` (half_i:
the half-width of c^i's box, the user's where given), so that the value at the data's conditions can stay put
while the trend moves (the intercept of a steep line lies far from the value, and its sign is not the
parameter's).

Fitted trends (``refit_trends``, the discovery loop's local refits, over data at more than one level): a known
coefficient of c^i gets ``± factor · |c_i|`` and the constant term the same reach whatever the higher ones are.
With the general rule a fitted slope could only shrink 10× per refit, and the intercept could not cross zero:
a trend given to an effect the loop had added could not be refitted to the data, and the loop's next candidate
got the credit for the rest of a slope the data did not hold (``tests/test_discover.py``,
``experiments/discovery_testbed``). Identification's global search keeps the general rule for them: boxes that
wide let it wander into laws that diverge between the data's levels.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from ..data.batch import numeric_conditions
from ..physics.effects.base import signals
from ..physics.parameters import FunctionCoordinate, ParameterFunction, ParameterSpec, render_unit

__all__ = ["Box", "Coordinate", "SearchSpace", "condition_ranges", "outside_domain", "trend_scale"]


@dataclass(frozen=True)
class Coordinate:
    """One free scalar of the model: where it lives and its search interval.

    Attributes
    ----------
    name : ``effect.param`` (constants), ``effect.param.c1`` (coefficients), ``effect.param[p=0.05]``.
    effect, param : keys in ``model.evaluate`` (``effect`` is ``"structure"`` for mass / drive gain).
    position : its index in the parameter function's coordinates (``ParameterFunction.coordinates``).
    value : the value when the space was built; lower, upper : search bounds.
    unit : unit of the coordinate (the parameter's unit for constants and levels, else ``""``).
    """

    name: str
    effect: str
    param: str
    position: int
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

    def _map(self, U: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Coordinates of the unit-cube points ``U``, with the span of each scale and which are logarithmic."""
        lo, hi = self._ends(U)
        span = hi - lo
        s = lo + span * U
        log = self.log.to(U.device)
        # exp only where the scale is logarithmic: a linear coordinate's exp overflows for |s| > 709, and the
        # unused branch's inf · 0 would make its gradient NaN
        return torch.where(log, torch.where(log, s, 0.0).exp(), s), span, log

    def from_unit(self, U: torch.Tensor) -> torch.Tensor:
        """Unit-cube points ``(N, D)`` → coordinates (differentiable)."""
        return self._map(U)[0]

    def from_logits(self, W: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Coordinates ``from_unit(sigmoid(W))`` ``(N, D)`` and their derivatives w.r.t. the logits ``W``
        (elementwise), without a backward pass: the same operations, in the same order, as autograd's backward of
        that map (``exp``'s result, the span, then the sigmoid's ``(1 − σ) σ``), so the same numbers."""
        U = torch.sigmoid(W)
        X, span, log = self._map(U)
        ds = torch.where(log, X, torch.ones_like(X))  # dX/ds: exp's result on a log scale, 1 on a linear one
        return X, ds * span * (1 - U) * U

    def to_unit(self, X: torch.Tensor) -> torch.Tensor:
        """Coordinates ``(N, D)`` → unit-cube points."""
        X = torch.as_tensor(X, dtype=torch.float64)
        lo, hi = self._ends(X)
        s = torch.where(self.log, X.clamp_min(1e-300).log(), X)
        return (s - lo) / (hi - lo)


def _box(v: float, factor: float, signed: bool = False) -> tuple[float, float]:
    if signed and v != 0:
        return -abs(v) * factor, abs(v) * factor
    if v > 0:
        return v / factor, v * factor
    if v < 0:
        return v * factor, v / factor
    return -1.0, 1.0


def condition_ranges(records) -> dict[str, tuple[float, float]]:
    """``{condition: (lowest, highest)}`` over ``records`` for every numeric condition and every control channel
    (the trend boxes)."""
    out = {k: (float(v.min()), float(v.max())) for k, v in numeric_conditions(records).items()}
    for k in sorted({c for r in records for c in r.controls}):
        values = [r.controls[k] for r in records if k in r.controls]
        out[k] = (min(float(v.min()) for v in values), max(float(v.max()) for v in values))
    return out


def trend_scale(value: float, power: int, lo: float, hi: float) -> float | None:
    """The natural size of the coefficient of c^``power`` in a parameter of size |``value``| whose condition
    spans ``[lo, hi]`` in the data: ``|value| / Δ``, with Δ the change of c^power over the range (over its
    magnitude where the data hold one level only); a coefficient this size changes the parameter by its own
    value across the data. None where that is not defined (a value or a range of 0)."""
    ends = [lo**power, hi**power] + ([0.0] if lo < 0.0 < hi else [])
    span = (max(ends) - min(ends)) or max(abs(lo), abs(hi)) ** power
    if value == 0.0 or span == 0.0:
        return None
    return abs(value) / span


def _trend_boxes(declared: list[FunctionCoordinate], condition: str | None, factor: float, ranges,
                 given: Mapping[int, tuple[float, float]], refit: bool = False) -> dict[int, tuple[float, float]]:
    """``{position: box}`` for the coefficients of a polynomial (module docstring): the higher ones that start at
    0 symmetric about 0, sized by the trend scale, and the constant term's reach following the higher
    coefficients' boxes (``given``: the user's, where set) while every trend is unknown; with ``refit`` (a local
    refit of fitted trends, over data at more than one level of the condition) the known higher coefficients
    too, by their own size, and the constant term whatever they are. {} for other functions."""
    rng = (ranges or {}).get(condition)
    c0 = next((i for i, co in enumerate(declared) if not co.power), None)
    if rng is None or c0 is None or not any(co.power for co in declared):
        return {}
    known = refit and rng[0] != rng[1]  # one level cannot move a known trend: its coefficients trade off exactly
    boxes = {}
    for i, co in enumerate(declared):
        if not co.power or (co.value != 0.0 and not known):
            continue
        scale = trend_scale(declared[c0].value, co.power, *rng) if co.value == 0.0 else abs(co.value)
        if scale is not None:
            boxes[i] = (-factor * scale, factor * scale)
    if not known and any(co.value != 0.0 for co in declared if co.power):
        return boxes
    top = max(abs(rng[0]), abs(rng[1]))
    halves = {i: max(abs(b) for b in given.get(i, boxes.get(i, _box(co.value, factor))))
              for i, co in enumerate(declared) if co.power}
    reach = factor * abs(declared[c0].value) + sum(h * top ** declared[i].power for i, h in halves.items())
    boxes[c0] = (declared[c0].value - reach, declared[c0].value + reach)
    return boxes


def _coordinates(fn: ParameterFunction, key: str, pname: str) -> list[FunctionCoordinate]:
    try:
        return fn.coordinates()
    except NotImplementedError as err:
        raise ValueError(f"parameter {key}.{pname}: {err}") from None


def outside_domain(model: nn.Module, records) -> list[str]:
    """``"effect.param = value at condition=level"`` for each parameter function of ``model`` (a trend: not a
    constant, which its box keeps inside) whose value at a record's conditions its parameter's domain does not
    admit (``ParameterSpec.admits``). A search starting there simulates nothing (``SearchSpace.values``) and no
    local refit can leave it: the caller says so instead of fitting."""
    with torch.no_grad():
        space = SearchSpace(model)
        conditions = numeric_conditions(records)
        controls = [c for c in condition_ranges(records) if c not in conditions]
        rows = len(records)
        if controls:  # a function of a control: checked at each record's lowest and highest value (two rows each)
            conditions = {k: v.repeat(2) for k, v in conditions.items()}
            conditions.update({c: torch.tensor([float(f(r.controls.get(c, [math.nan]))) for f in (np.min, np.max)
                                                for r in records], dtype=torch.float64) for c in controls})
            rows *= 2
        values = model.evaluate(conditions, rows)
    out = []
    for (key, pname), spec in space.domains.items():
        v = values[key][pname]
        bad = (~spec.admits(v)).nonzero().flatten().tolist()
        if bad:
            at = ", ".join(f"{c}={float(conditions[c][bad[0]]):g}" for c in conditions) or "every record"
            out.append(f"{key}.{pname} = {float(v[bad[0]]):.4g} at {at}")
    return out


class SearchSpace(Box):
    """The free coordinates of ``model`` with finite bounds (see the module docstring for the rule).

    Parameters
    ----------
    model : a ``NominalModel``; its current values centre the default boxes.
    bounds : ``{coordinate name: (lower, upper)}`` overrides.
    factor : width of the default box, ``(v / factor, v · factor)``.
    free : names of the coordinates to search (default: all); the others are held at their current
        values (e.g. the discovery loop fitting only a newly added effect).
    condition_ranges : ``{condition: (lowest, highest)}`` in the data (``condition_ranges(records)``): sizes
        the boxes of trends not yet known (module docstring); without it they get the general rule.
    refit_trends : boxes for fitted trends that let them vanish, turn, and move their intercept across zero
        (module docstring): the discovery loop's local refits. A global search keeps the general rule for
        them: boxes that wide let it wander into laws that diverge between the data's levels.
    """

    def __init__(self, model: nn.Module, bounds: Mapping[str, tuple[float, float]] | None = None,
                 factor: float = 10.0, free=None,
                 condition_ranges: Mapping[str, tuple[float, float]] | None = None, refit_trends: bool = False):
        self.model = model
        self.functions = {(k, n): fn for k, e in model.effects.items() for n, fn in e.params.items()}
        specs = {(k, n): e.param_specs[n] for k, e in model.effects.items() for n in e.params}
        self.functions.update({("structure", n): fn for n, fn in model.structure_params.items()})
        specs.update({("structure", n): model.structure_specs[n] for n in model.structure_params})
        bounds = dict(bounds or {})
        coords = []
        self.sizes: dict[tuple[str, str], int] = {}
        self.domains: dict[tuple[str, str], ParameterSpec] = {}  # functions whose values the boxes do not bound
        for (key, pname), fn in self.functions.items():
            declared = _coordinates(fn, key, pname)
            self.sizes[(key, pname)] = len(declared)
            if declared and not any(co.own for co in declared) and specs[(key, pname)].constraint != "real":
                self.domains[(key, pname)] = specs[(key, pname)]
            names = [f"{key}.{pname}{co.suffix}" for co in declared]
            given = {i: bounds[name] for i, name in enumerate(names) if name in bounds}
            trends = _trend_boxes(declared, fn.condition, factor, condition_ranges, given, refit_trends)
            for position, (co, name) in enumerate(zip(declared, names)):
                override = bounds.pop(name, None)
                if override is None:
                    override = trends.get(position)
                spec = specs[(key, pname)] if co.own else None
                lo, hi = self._bounds(co.value, spec, factor, override, co.signed or (spec is not None and spec.signed))
                if co.nonnegative and lo < 0:  # a coefficient that is never negative (``Polynomial(nonnegative=)``)
                    if hi <= 0:  # only a user's box can be (the rule's reach above a value ≥ 0): said, not replaced
                        raise ValueError(f"bounds ({lo:g}, {hi:g}) for {name}: a coefficient of a nonnegative "
                                         "function is never negative; give an upper bound > 0")
                    lo = 0.0
                unit = "" if spec is None else (model.effects[key].param_unit(pname, model.units)
                                                if key in model.effects else render_unit(spec.unit, model.units))
                coords.append(Coordinate(name, key, pname, position, co.value, lo, hi, unit))
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
        where = {(c.effect, c.param, c.position): j for j, c in enumerate(coords)}
        # each (effect, parameter) function's columns of a population, in its coordinates' order; None for a held one
        self.columns = {f: [where.get((*f, i)) for i in range(k)] for f, k in self.sizes.items()}
        log = [c.lower > 0 and c.upper / c.lower > 3 for c in coords]
        super().__init__([c.lower for c in coords], [c.upper for c in coords], log)

    @staticmethod
    def _bounds(v: float, spec: ParameterSpec | None, factor: float, override,
                signed: bool = False) -> tuple[float, float]:
        if override is not None:
            lo, hi = (float(b) for b in override)
        else:
            lo, hi = _box(v, factor, signed)
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
        current = {key: fn.coordinate_values().detach() for key, fn in self.functions.items()}
        return torch.tensor([float(current[(c.effect, c.param)][c.position]) for c in self.coordinates],
                            dtype=torch.float64)

    # -- population -> per-row parameter values ----------------------------------------------------
    def values(self, X: torch.Tensor, conditions: Mapping[str, torch.Tensor] | None, repeats: int,
               only: Collection[tuple[str, str]] | None = None) -> dict:
        """Per-row values for ``simulate(values=...)``: ``X (N, D)`` at ``repeats`` = R record conditions
        (``only``: of these ``(effect, parameter)`` functions alone).

        Row ``n * R + r`` holds member n at record r. ``conditions`` maps a condition name to ``(R,)``.
        Differentiable w.r.t. ``X``. A function of a condition whose coefficients put the parameter outside its
        domain at a record's condition (a positive stiffness or friction level whose trend crosses zero between
        the data's levels: the boxes bound coefficients, not values) gives NaN there, so that the member
        simulates nothing and every search and refit treats it as infinitely costly.
        """
        N, R = X.shape[0], int(repeats)
        out: dict[str, dict[str, torch.Tensor]] = {}
        follow = signals(conditions)
        for (key, pname), fn in self.functions.items():
            if only is not None and (key, pname) not in only:
                continue
            coords = self._function_coords(X, key, pname)
            if fn.condition in follow:  # a function of a control: its coordinates, evaluated at every step
                out.setdefault(key, {}).update({pname + s: coords[:, i].repeat_interleave(R)
                                                for i, s in enumerate(fn.suffixes())})
                continue
            value = fn.evaluate_batch(coords, conditions, R).reshape(N * R)
            spec = self.domains.get((key, pname))
            if spec is not None:
                value = torch.where(spec.admits(value), value, torch.full_like(value, math.nan))
            out.setdefault(key, {})[pname] = value
        return out

    def _function_coords(self, X: torch.Tensor, key: str, pname: str) -> torch.Tensor:
        """``(N, k)``: the coordinates of one parameter function, in order: a slice of ``X`` where they are
        adjacent free columns (most functions; this runs at every simulation of a fit), else gathered with the
        held ones."""
        cols = self.columns[(key, pname)]
        if not cols:
            return X.new_zeros((X.shape[0], 0))
        if None not in cols and cols == list(range(cols[0], cols[0] + len(cols))):
            return X[:, cols[0]:cols[0] + len(cols)]
        held = {c.position: c.value for c in self.held if (c.effect, c.param) == (key, pname)}
        return torch.stack([X[:, j] if j is not None else X.new_full((X.shape[0],), held[i])
                            for i, j in enumerate(cols)], dim=1)

    # -- writing back --------------------------------------------------------------------------------
    def to_model(self, x) -> nn.Module:
        """Write the coordinates ``x (D,)`` into the model (through the parametrizations' right_inverse)."""
        x = torch.as_tensor(x, dtype=torch.float64).detach().reshape(-1)
        if x.shape[0] != self.dim:
            raise ValueError(f"expected {self.dim} coordinates, got {x.shape[0]}")
        grouped: dict[tuple[str, str], list] = {}
        for c, v in zip(self.coordinates, x.tolist()):
            grouped.setdefault((c.effect, c.param), []).append((c.position, v))
        for key, items in grouped.items():
            fn = self.functions[key]
            current = fn.coordinate_values().detach().clone()
            for position, v in items:
                current[position] = v
            fn.set_coordinates(current)
        return self.model
