"""Smoothed Coulomb (dry) friction."""

from __future__ import annotations

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, smooth_sign


class Coulomb(Effect):
    """Coulomb friction with a smoothed sign, F = Fc · tanh(v / v_s).

    Units: Fc [F] is the sliding friction level (seed 000's and 001's M_s, seed 003's f_f); v_s [x/t]
    the velocity over which the sign is smoothed (seed 003 writes tanh(σ v) with σ = 1/v_s). v_s → 0
    recovers sgn(v). Shapes: (batch,). Source: seeds 000 (eq. 1), 001 (eq. 1), 003 (eq. 3).
    """

    name = "coulomb"
    example_values = {"Fc": 0.5, "v_s": 0.2}
    equation = "F = Fc * tanh(v / v_s)"
    source = "seeds 000, 001, 003"
    specs = {
        "Fc": ParameterSpec(0.0, "F", (0.0, 1e6), "nonnegative", neutral=0.0, doc="sliding friction level"),
        "v_s": ParameterSpec(1e-3, "x/t", (1e-9, 1e6), "positive", doc="sign smoothing velocity", smoothing=True),
    }

    def force(self, p, kin: Kinematics, state):
        return p["Fc"] * smooth_sign(kin.v, p["v_s"])
