"""A parameter drifting with cumulative travel (wear, heating, run-in): the friction level (``travel_drift``), and
the base the stiffness's and the damping's drifts share (``TravelEffect``; ``travel_stiffness.py``,
``travel_damping.py``)."""

from __future__ import annotations

from typing import ClassVar

import torch

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, rates, smooth_sign


class TravelEffect(Effect):
    """Base of the drifts with travel: one state, the worked travel s, ṡ = |v| (1 − λ s). With λ = 0 (the default)
    s is the cumulative travel and the drift linear in it; with λ > 0 the drift levels off over a travel of 1/λ,
    s = (1 − exp(−λ · travel)) / λ, as a run-in or a Mullins-like softening does: one parameter more than a linear
    drift, which is its special case λ = 0. A subclass's force is the drift of one linear term's coefficient times
    s times that term's carrier (the sign of v, x or v): the nominal's coefficient at travel s is its own plus the
    drift times s, exactly for a term linear in its coefficient. Not registered: it has no force of its own.

    Where the record starts: at s = 0 (a device that forgets between records), or, with the start parameter
    ``s0`` [x], the travel before the record, at the worked travel that travel left, (1 − exp(−λ s0)) / λ (s0 at
    λ = 0). A device that remembers from record to record has s0 = the travel before the first record plus the
    travel of the records before this one: a linear function of the condition ``travel_before``
    (``data.records.with_travel_before``), which is how the discovery loop offers it (``discover.carried_travel``).
    """

    state_dim = 1
    start: ClassVar[dict[str, ParameterSpec]] = {
        "s0": ParameterSpec(0.0, "x", (0.0, 1e12), "nonnegative", neutral=0.0,
                            doc="travel before the record (0: the record starts with nothing worked)"),
    }
    start_candidate = False  # the loop offers the travel before each record instead (discover.carried_travel)

    @staticmethod
    def levelling() -> ParameterSpec:
        """The spec of λ, the inverse of the travel over which the drift levels off (every subclass declares it)."""
        return ParameterSpec(0.0, "1/x", (0.0, 1e9), "nonnegative", neutral=0.0,
                             doc="inverse of the travel over which the drift levels off (0: linear in the travel)")

    def initial_state(self, p, batch, controls=None):
        if "s0" not in p:
            return super().initial_state(p, batch, controls)
        return worked_travel(p["s0"], p["lam"]).expand(batch)[:, None]

    def rate(self, p, kin: Kinematics, state):
        return rates(absolute(kin.v) * (1 - p["lam"] * state[:, 0]))


def worked_travel(travel: torch.Tensor, lam: torch.Tensor) -> torch.Tensor:
    """s after a travel from s = 0 under ṡ = |v| (1 − λ s): (1 − exp(−λ · travel)) / λ, and its series where λ ·
    travel is small (exact at λ = 0, with the derivative w.r.t. λ, −travel² / 2, that the closed form loses there)."""
    a = lam * travel
    small = a.abs() < 1e-3
    series = travel * (1 - a / 2 + a * a / 6 - a * a * a / 24)
    return torch.where(small, series, -torch.expm1(-a) / torch.where(small, torch.ones_like(lam), lam))


class TravelDrift(TravelEffect):
    """A sliding-friction level that changes with the distance travelled so far, in proportion until it levels off.

    State and force::

        ṡ = |v| (1 − λ s)
        F = dF · s · tanh(v / v_s)

    s [x] is the worked travel (0 at the record's start, or what the travel s0 before it left; the cumulative
    travel when λ = 0, levelling off at 1/λ otherwise: ``TravelEffect``), so the friction level at
    travel s is the nominal's plus dF · s: dF > 0 for a level that grows (run-in,
    contamination), dF < 0 for one that fades (heating, wear of the pads). It is the discovery loop's
    candidate for "slow drift / degradation of the friction level with cumulative travel"; the stiffness's and
    the damping's are ``travel_stiffness`` and ``travel_damping``.

    Units: dF [F/x] (real, neutral 0: no drift), v_s [x/t] (> 0, sign smoothing, as ``Coulomb``), λ = lam [1/x]
    (≥ 0, neutral 0: linear in the travel).
    Shapes: ``(batch,)``; state ``(batch, 1)``. Source: hybridhyst (a linear wear law, cf. Archard, that may level off).
    """

    name = "travel_drift"
    # a drift that levelled off before the record began (λ → ∞ with the drift over λ held, or λ s0 ≫ 1) is
    # a constant friction level dF/λ
    special_cases = (("coulomb",),)
    example_values = {"dF": 0.4, "v_s": 0.2, "lam": 0.3}
    equation = "ds/dt = |v| (1 - lam * s);  F = dF * s * tanh(v / v_s)"
    source = "hybridhyst: drift of the friction level with cumulative travel, levelling off"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "dF": ParameterSpec(0.0, "F/x", (-1e9, 1e9), "real", neutral=0.0,
                            doc="change of the friction level per unit travel"),
        "v_s": ParameterSpec(1e-3, "x/t", (1e-9, 1e6), "positive", doc="sign-smoothing velocity", smoothing=True),
        "lam": TravelEffect.levelling(),
    }

    def force(self, p, kin: Kinematics, state):
        return p["dF"] * state[:, 0] * smooth_sign(kin.v, p["v_s"])
