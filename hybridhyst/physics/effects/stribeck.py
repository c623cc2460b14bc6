"""Stribeck excess of static over sliding friction."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, exp, smooth_sign


class Stribeck(Effect):
    """Static friction excess at low speed, added to a ``Coulomb`` term.

    Force::

        F = dFs · exp(−(v / vs)²) · tanh(v / v_s)

    With ``Coulomb`` (level Fc) the sliding force is (Fc + dFs exp(−(v/vs)²)) sign(v): it starts at the
    static level Fs = Fc + dFs and falls to Fc over the Stribeck velocity vs (the static LuGre curve).

    Units: dFs [F] (≥ 0, neutral 0), vs [x/t] (> 0, Stribeck velocity), v_s [x/t] (> 0, sign smoothing
    velocity, keep v_s ≪ vs). Note the two velocities: ``vs`` sets the decay, ``v_s`` the sign smoothing
    (the same name as in ``Coulomb``). Shapes: ``(batch,)``.
    Source: R. Stribeck, "Die wesentlichen Eigenschaften der Gleit- und Rollenlager", Z. VDI 46, 1902;
    exponential form as in Canudas de Wit et al. 1995.
    """

    name = "stribeck"
    example_values = {"dFs": 0.4, "vs": 0.5, "v_s": 0.2}
    equation = "F = dFs * exp(-(v/vs)^2) * tanh(v / v_s)"
    source = "Stribeck 1902; Canudas de Wit et al. 1995"
    special_cases = (("coulomb",),)  # vs → ∞: a constant excess level, i.e. Coulomb
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "dFs": ParameterSpec(0.0, "F", (0.0, 1e6), "nonnegative", neutral=0.0,
                             doc="static minus sliding friction level"),
        "vs": ParameterSpec(1e-2, "x/t", (1e-9, 1e6), "positive", doc="Stribeck velocity"),
        "v_s": ParameterSpec(1e-3, "x/t", (1e-9, 1e6), "positive", doc="sign smoothing velocity", smoothing=True),
    }

    def force(self, p, kin: Kinematics, state):
        return p["dFs"] * exp(-((kin.v / p["vs"]) ** 2)) * smooth_sign(kin.v, p["v_s"])
