"""Inertia (added mass)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect


class Inertia(Effect):
    """Added mass m: the force m · ẍ.

    In a ``Constitutive`` model the structure adds m · ẍ of the excitation to the response (the inertia
    of the moving parts between the exciter and the load cell); in a ``DrivenOscillator`` m adds to the
    structure's mass. The acceleration is that of the excitation (or oscillator), never that seen
    behind a ``Backlash``. Because m is stored unconstrained (it starts at exactly 0 when discovery adds
    it), keep mass + m > 0 in an oscillator (identification uses the bounds).

    Units: m [F*t^2/x] (≥ 0, neutral 0). Shapes: ``(batch,)``.
    Source: seed 003 eq. (1) (m_eq ẍ), seed 001 eq. (1) (I φ̈).
    """

    name = "inertia"
    example_values = {"m": 0.2}
    equation = "F = m * a"
    source = "seeds 001 (I), 003 (m_eq)"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "m": ParameterSpec(0.0, "F*t^2/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="added mass or inertia"),
    }

    def added_mass(self, p):
        return p["m"]
