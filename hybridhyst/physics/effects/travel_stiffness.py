"""Stiffness drifting with cumulative travel (a rubber or particle bed that softens as it is worked)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Kinematics
from .travel_drift import TravelEffect


class TravelStiffness(TravelEffect):
    """A stiffness that changes with the distance travelled so far, in proportion until it levels off.

    State and force::

        ṡ = |v| (1 − λ s)
        F = dk · s · x

    s [x] is the worked travel (0 at the record's start, or what the travel s0 before it left; the cumulative
    travel when λ = 0, levelling off at 1/λ otherwise: ``TravelEffect``), so the spring's stiffness at travel
    s is the nominal's plus dk · s: dk < 0 for a spring that softens as it is worked (Mullins-like softening of
    an elastomer, a particle bed that loosens), dk > 0 for one that stiffens (compaction).

    Units: dk [F/x²] (real, neutral 0: no drift), λ = lam [1/x] (≥ 0,
    neutral 0: linear in the travel). Shapes: ``(batch,)``; state ``(batch, 1)``.
    Source: hybridhyst (a stiffness drifting with cumulative travel; the friction level's is ``travel_drift``).
    """

    name = "travel_stiffness"
    # a drift that levelled off before the record began (λ → ∞ with the drift over λ held, or λ s0 ≫ 1) is
    # a constant stiffness dk/λ
    special_cases = (("linear_stiffness",),)
    example_values = {"dk": -0.3, "lam": 0.3}
    equation = "ds/dt = |v| (1 - lam * s);  F = dk * s * x"
    source = "hybridhyst: drift of the stiffness with cumulative travel, levelling off"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "dk": ParameterSpec(0.0, "F/x^2", (-1e9, 1e9), "real", neutral=0.0,
                            doc="change of the stiffness per unit travel"),
        "lam": TravelEffect.levelling(),
    }

    def force(self, p, kin: Kinematics, state):
        return p["dk"] * state[:, 0] * kin.x
