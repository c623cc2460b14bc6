"""A parameter drifting with cumulative travel (wear, heating, run-in): the friction level (``travel_drift``), and
the base the stiffness's and the damping's drifts share (``TravelEffect``; ``travel_stiffness.py``,
``travel_damping.py``)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, rates, smooth_sign


class TravelEffect(Effect):
    """Base of the drifts with travel: one state, the worked travel s since the record started, ṡ = |v| (1 − s/s_sat)
    (it starts at 0 with every record): s is the cumulative travel while it is short of the saturation travel
    s_sat and approaches s_sat beyond it, s = s_sat (1 − exp(−travel / s_sat)), so a drift that levels off (a
    run-in, a Mullins-like softening) is one parameter more than a linear one, and a linear drift is s_sat far
    beyond the records' travel. A subclass's force is the drift of one linear term's coefficient times s times
    that term's carrier (the sign of v, x or v): the nominal's coefficient at travel s is its own plus the drift
    times s, exactly for a term linear in its coefficient. A drift across records (one test after another) is a
    parameter function of a condition instead. Not registered: it has no force of its own."""

    state_dim = 1
    # the saturation travel's search starts far beyond the data's displacement scale: a linear drift first
    discovery_units: ClassVar[dict[str, str]] = {"s_sat": "100*x"}

    @staticmethod
    def saturation(default: float = 1e9) -> ParameterSpec:
        """The saturation travel's spec (every subclass declares it; the default is a linear drift)."""
        return ParameterSpec(default, "x", (1e-9, 1e12), "positive",
                             doc="travel over which the drift levels off (far beyond the records': linear)")

    def rate(self, p, kin: Kinematics, state):
        return rates(absolute(kin.v) * (1 - state[:, 0] / p["s_sat"]))


class TravelDrift(TravelEffect):
    """A sliding-friction level that changes with the distance travelled so far, in proportion until it levels off.

    State and force::

        ṡ = |v| (1 − s / s_sat)
        F = dF · s · tanh(v / v_s)

    s [x] is the worked travel since the record started (the state starts at 0 with every record; the
    cumulative travel while short of s_sat, levelling off at s_sat), so the friction level at travel s is the
    nominal's plus dF · s: dF > 0 for a level that grows (run-in,
    contamination), dF < 0 for one that fades (heating, wear of the pads). It is the discovery loop's
    candidate for "slow drift / degradation of the friction level with cumulative travel"; the stiffness's and
    the damping's are ``travel_stiffness`` and ``travel_damping``.

    Units: dF [F/x] (real, neutral 0: no drift), v_s [x/t] (> 0, sign smoothing, as ``Coulomb``), s_sat [x]
    (> 0; default 1e9: linear).
    Shapes: ``(batch,)``; state ``(batch, 1)``. Source: hybridhyst (a linear wear law, cf. Archard).
    """

    name = "travel_drift"
    example_values = {"dF": 0.4, "v_s": 0.2, "s_sat": 3.0}
    equation = "ds/dt = |v| (1 - s / s_sat);  F = dF * s * tanh(v / v_s)"
    source = "hybridhyst: drift of the friction level with cumulative travel, levelling off"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "dF": ParameterSpec(0.0, "F/x", (-1e9, 1e9), "real", neutral=0.0,
                            doc="change of the friction level per unit travel"),
        "v_s": ParameterSpec(1e-3, "x/t", (1e-9, 1e6), "positive", doc="sign-smoothing velocity", smoothing=True),
        "s_sat": TravelEffect.saturation(),
    }

    def force(self, p, kin: Kinematics, state):
        return p["dF"] * state[:, 0] * smooth_sign(kin.v, p["v_s"])
