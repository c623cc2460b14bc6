"""Linear stiffness."""

from __future__ import annotations

from ..parameters import ParameterSpec
from .base import Effect, Kinematics


class LinearStiffness(Effect):
    """Linear spring, F = k · x. Units: k [F/x]. Source: seeds 000 (k φ), 003 (K_spr/2 + K_p/i²)."""

    name = "linear_stiffness"
    example_values = {"k": 2.0}
    equation = "F = k * x"
    source = "seeds 000, 003"
    specs = {
        "k": ParameterSpec(0.0, "F/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="linear stiffness"),
    }

    def force(self, p, kin: Kinematics, state):
        return p["k"] * kin.x
