"""Equivalent actuation attenuation (seed 003)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute


class Attenuation(Effect):
    """Displacement-dependent loss of actuation gain, written as a resisting force.

    Force::

        F = ξ · |x| · u

    Seed 003 (eqs. 4–8) lowers the piezo coefficient with the stroke, d33_eff = d33 − ξ_paper |x|, so
    the drive is (K_p / i)(d33 − ξ_paper |x|) u. In a ``DrivenOscillator`` the linear part is the
    structure's drive ``drive_gain · u`` with drive_gain = K_p d33 / i, and the attenuation moves to the
    left-hand side as this effect with ξ = (K_p / i) · ξ_paper. In a ``Constitutive`` model u is the
    excitation itself, so F = ξ |x| x.

    Units: xi [F/(x*u)] (≥ 0, neutral 0). x is the coordinate the effect sees (the relative coordinate
    for a base-excited oscillator), u the raw input (voltage). Shapes: ``(batch,)``.
    Source: seed 003, eqs. (4)–(9) (Kou et al., Hybrid-PINN piezoelectric actuator).
    """

    name = "attenuation"
    example_values = {"xi": 0.3}
    needs_drive = True  # F = ξ|x|u: on a damper law without a separate drive it is a cubic-like stiffness
    equation = "F = xi * |x| * u"
    source = "seed 003 eqs. (4)-(9)"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "xi": ParameterSpec(0.0, "F/(x*u)", (0.0, 1e9), "nonnegative", neutral=0.0,
                            doc="attenuation coefficient, (K_p / i) * xi_paper"),
    }

    def force(self, p, kin: Kinematics, state):
        return p["xi"] * absolute(kin.x) * kin.u
