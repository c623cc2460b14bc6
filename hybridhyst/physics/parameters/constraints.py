"""Constraints of physical parameters: stored unconstrained and mapped to their admissible range by a
``torch.nn.utils.parametrize`` parametrization (``Positive``: softplus, ``Bounded``: scaled sigmoid), never
by clamping, so gradients survive at the bounds; ``ParameterSpec`` declares a parameter's unit, constraint and
bounds, ``render_unit`` fills its unit template with a model's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn.utils import parametrize

__all__ = ["Bounded", "ParameterSpec", "Positive", "render_unit"]


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
        ``u`` (input), ``t`` (time), e.g. ``"F*t/x"`` for a viscous coefficient; see ``render_unit``.
    bounds : search bounds used by identification; also the hard range when ``constraint="bounded"``.
    constraint : ``"positive"``, ``"nonnegative"``, ``"bounded"`` or ``"real"``.
    neutral : the value at which the effect contributes nothing (used when discovery adds it).
    doc : one line on what the parameter is.
    smoothing : the parameter is a smoothing width (of a sign, a corner): the element is meant to be sharp
        against the data, so discovery searches it only well below the data's scale of its unit (a sign
        smoothed over the data's own speeds is a linear term, not the effect the element names).
    signed : its sign is not known in advance (a start state): identification searches it in a box symmetric
        about 0 (``± factor · |value|``) instead of one that keeps its sign.
    """

    default: float
    unit: str = "-"
    bounds: tuple[float, float] = (-math.inf, math.inf)
    constraint: str = "real"
    neutral: float | None = None
    doc: str = ""
    smoothing: bool = False
    signed: bool = False

    def admits(self, values: torch.Tensor) -> torch.Tensor:
        """Whether each value lies in the parameter's domain: > 0 (positive), ≥ 0 (nonnegative), within
        ``bounds`` (bounded); a real parameter admits every value. NaN is never admitted."""
        if self.constraint == "positive":
            return values > 0
        if self.constraint == "nonnegative":
            return values >= 0
        if self.constraint == "bounded":
            return (values >= self.bounds[0]) & (values <= self.bounds[1])
        return values == values


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


def _interior(module: nn.Module, attr: str, value: torch.Tensor) -> torch.Tensor:
    """``value`` moved strictly inside the range of the attribute's constraint (right_inverse needs that)."""
    for p in module.parametrizations[attr]:
        if isinstance(p, Bounded):
            eps = 1e-9 * (p.high - p.low)
            value = value.clamp(p.low + eps, p.high - eps)
        elif isinstance(p, Positive):
            value = value.clamp_min(p.floor + 1e-300)
    return value
