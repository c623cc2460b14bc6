"""Viscous damping."""

from __future__ import annotations

import math

import torch

from ..parameters import ParameterSpec
from .base import Effect, Kinematics


class Viscous(Effect):
    """Linear viscous damping, F = c · s · v.

    ``s`` (``velocity_scale``, a fixed constant) converts the velocity unit when a source quotes c in
    another one: seed 000's c multiplies φ̇ in rad/s while φ is in deg, so its composition uses
    s = π/180 and ``scaled_unit="rad"`` (the unit of x after scaling, which c's unit then carries).
    Units: c [F*t/x] (with s = 1), c [F*t/scaled_unit] otherwise. Shapes: (batch,).
    Source: seeds 000 (eq. 1), 001 (eq. 1), 003 (eq. 1), 004 (eq. 1).
    """

    name = "viscous"
    example_values = {"c": 0.3}
    equation = "F = c * s * v"
    source = "seeds 000-004"
    specs = {
        "c": ParameterSpec(0.0, "F*t/x", (0.0, 1e6), "nonnegative", neutral=0.0, doc="viscous coefficient"),
    }

    def __init__(self, velocity_scale: float = 1.0, scaled_unit: str | None = None, **values):
        super().__init__(**values)
        if not math.isfinite(velocity_scale) or velocity_scale <= 0:
            raise ValueError(f"viscous: velocity_scale must be a positive number, got {velocity_scale}")
        self.scaled_unit = scaled_unit
        self.register_buffer("velocity_scale", torch.tensor(float(velocity_scale), dtype=torch.get_default_dtype()))

    def options(self) -> dict:
        return {"velocity_scale": float(self.velocity_scale), "scaled_unit": self.scaled_unit}

    def param_unit(self, pname: str, units: dict[str, str] | None = None) -> str:
        if self.scaled_unit and units:
            units = {**units, "x": self.scaled_unit}
        return super().param_unit(pname, units)

    def force(self, p, kin: Kinematics, state):
        return p["c"] * float(self.velocity_scale) * kin.v
