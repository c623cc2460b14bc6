"""Coulomb friction with a direction-dependent sliding level."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, smooth_sign


class AsymmetricCoulomb(Effect):
    """Smoothed Coulomb friction whose level depends on the sliding direction.

    Force::

        F = Fc · tanh(v / v_s) + dF · |tanh(v / v_s)|

    so the sliding force is +(Fc + dF) for v ≫ v_s and −(Fc − dF) for v ≪ −v_s: the mean level is Fc and
    dF shifts the loop vertically while sliding (seal and guide friction that differs between extension
    and compression). dF = 0 recovers ``Coulomb``.

    Units: Fc [F] (≥ 0), dF [F] (real, |dF| ≤ Fc keeps both levels resisting), v_s [x/t] (> 0, the
    velocity over which the sign is smoothed; v_s → 0 gives sgn(v)). Shapes: ``(batch,)``.
    Source: asymmetric friction of hydraulic and MR dampers, e.g. Olsson, Åström, Canudas de Wit,
    Gäfvert & Lischinsky, "Friction models and friction compensation", Eur. J. Control 4 (1998).
    """

    name = "asymmetric_coulomb"
    example_values = {"Fc": 0.5, "dF": 0.2, "v_s": 0.2}
    equation = "F = Fc * tanh(v / v_s) + dF * |tanh(v / v_s)|"
    source = "Olsson et al. 1998 (direction-dependent Coulomb level)"
    special_cases = (("coulomb",),)  # dF = 0
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "Fc": ParameterSpec(0.0, "F", (0.0, 1e6), "nonnegative", neutral=0.0, doc="mean sliding friction level"),
        "dF": ParameterSpec(0.0, "F", (-1e6, 1e6), "real", neutral=0.0,
                            doc="half the difference between the positive- and negative-velocity levels"),
        "v_s": ParameterSpec(1e-3, "x/t", (1e-9, 1e6), "positive", doc="sign smoothing velocity", smoothing=True),
    }

    def force(self, p, kin: Kinematics, state):
        s = smooth_sign(kin.v, p["v_s"])
        return p["Fc"] * s + p["dF"] * absolute(s)
