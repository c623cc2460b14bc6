"""Cubic (hardening or softening) stiffness."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics


class CubicStiffness(Effect):
    """Cubic spring, F = k3 · x³.

    k3 > 0 hardens, k3 < 0 softens (keep k + 3 k3 x² > 0 over the stroke for a stable oscillator).
    Units: k3 [F/x^3] (real, neutral 0). Shapes: ``(batch,)``.
    Source: seed 000 (eq. 1, k₂ φ³), seed 001 (eq. 1, k₁ φ³ inside the elastic part of Bouc–Wen).
    """

    name = "cubic_stiffness"
    example_values = {"k3": 0.7}
    equation = "F = k3 * x^3"
    source = "seeds 000 (k2 phi^3), 001 (k1 phi^3)"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "k3": ParameterSpec(0.0, "F/x^3", (-1e9, 1e9), "real", neutral=0.0, doc="cubic stiffness coefficient"),
    }

    def force(self, p, kin: Kinematics, state):
        return p["k3"] * kin.x**3
