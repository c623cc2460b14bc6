"""A parameter drifting with cumulative travel (wear, heating, run-in): the friction level (``travel_drift``), and
the base the stiffness's and the damping's drifts share (``TravelEffect``; ``travel_stiffness.py``,
``travel_damping.py``)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, rates, smooth_sign


class TravelEffect(Effect):
    """Base of the drifts with travel: one state, the worked travel s since the record started, ṡ = |v| (1 − λ s)
    (it starts at 0 with every record). With λ = 0 (the default) s is the cumulative travel and the drift linear in
    it; with λ > 0 the drift levels off over a travel of 1/λ, s = (1 − exp(−λ · travel)) / λ, as a run-in or a
    Mullins-like softening does: one parameter more than a linear drift, which is its special case λ = 0. A
    subclass's force is the drift of one linear term's coefficient times s times that term's carrier (the sign of
    v, x or v): the nominal's coefficient at travel s is its own plus the drift times s, exactly for a term linear
    in its coefficient. A drift across records (one test after another) is a parameter function of a condition
    instead. Not registered: it has no force of its own."""

    state_dim = 1

    @staticmethod
    def levelling() -> ParameterSpec:
        """The spec of λ, the inverse of the travel over which the drift levels off (every subclass declares it)."""
        return ParameterSpec(0.0, "1/x", (0.0, 1e9), "nonnegative", neutral=0.0,
                             doc="inverse of the travel over which the drift levels off (0: linear in the travel)")

    def rate(self, p, kin: Kinematics, state):
        return rates(absolute(kin.v) * (1 - p["lam"] * state[:, 0]))


class TravelDrift(TravelEffect):
    """A sliding-friction level that changes with the distance travelled so far, in proportion until it levels off.

    State and force::

        ṡ = |v| (1 − λ s)
        F = dF · s · tanh(v / v_s)

    s [x] is the worked travel since the record started (the state starts at 0 with every record; the
    cumulative travel when λ = 0, levelling off at 1/λ otherwise: ``TravelEffect``), so the friction level at
    travel s is the nominal's plus dF · s: dF > 0 for a level that grows (run-in,
    contamination), dF < 0 for one that fades (heating, wear of the pads). It is the discovery loop's
    candidate for "slow drift / degradation of the friction level with cumulative travel"; the stiffness's and
    the damping's are ``travel_stiffness`` and ``travel_damping``.

    Units: dF [F/x] (real, neutral 0: no drift), v_s [x/t] (> 0, sign smoothing, as ``Coulomb``), λ = lam [1/x]
    (≥ 0, neutral 0: linear in the travel).
    Shapes: ``(batch,)``; state ``(batch, 1)``. Source: hybridhyst (a linear wear law, cf. Archard, that may level off).
    """

    name = "travel_drift"
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
