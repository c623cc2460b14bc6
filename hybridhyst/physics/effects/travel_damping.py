"""Viscous damping drifting with cumulative travel (a fluid that thins as it heats)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Kinematics
from .travel_drift import TravelEffect


class TravelDamping(TravelEffect):
    """A viscous coefficient that changes with the distance travelled so far, in proportion until it levels off.

    State and force::

        ṡ = |v| (1 − λ s)
        F = dc · s · v

    s [x] is the worked travel (0 at the record's start, or what the travel s0 before it left; the cumulative
    travel when λ = 0, levelling off at 1/λ otherwise: ``TravelEffect``), so the damping at travel s is the
    nominal's plus dc · s: dc < 0 for a damper whose fluid thins as the work heats it, dc > 0 for one that
    thickens.

    Units: dc [F·t/x²] (real, neutral 0: no drift), λ = lam [1/x] (≥ 0,
    neutral 0: linear in the travel). Shapes: ``(batch,)``; state ``(batch, 1)``.
    Source: hybridhyst (a damping drifting with cumulative travel; the friction level's is ``travel_drift``).
    """

    name = "travel_damping"
    # a drift that levelled off before the record began (λ → ∞ with the drift over λ held, or λ s0 ≫ 1) is
    # a constant damping dc/λ
    special_cases = (("viscous",),)
    example_values = {"dc": -0.05, "lam": 0.3}
    equation = "ds/dt = |v| (1 - lam * s);  F = dc * s * v"
    source = "hybridhyst: drift of the viscous damping with cumulative travel, levelling off"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "dc": ParameterSpec(0.0, "F*t/x^2", (-1e9, 1e9), "real", neutral=0.0,
                            doc="change of the viscous coefficient per unit travel"),
        "lam": TravelEffect.levelling(),
    }

    def force(self, p, kin: Kinematics, state):
        return p["dc"] * state[:, 0] * kin.v
