"""Saturation of a control channel: a field that stops growing with the current."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import ControlEffect, Kinematics, tanh


class ControlSaturation(ControlEffect):
    """The control ``c`` seen by the effects listed after this one saturates smoothly: c_s = c_max tanh(c / c_max).

    A magnetorheological fluid's yield stress stops growing once its particles' magnetisation saturates; an
    amplifier clips its output. Linear for |c| ≪ c_max (slope 1), bounded by ± c_max. Listed after a
    ``control_lag`` it saturates the lagged value.

    Units: c_max in the control's unit (> 0). No state. Shapes: ``(batch,)``.
    Source: no seed; the smooth limiter used for saturating actuators (e.g. G. Tao and P. Kokotović,
    "Adaptive Control of Systems with Actuator and Sensor Nonlinearities", Wiley, 1996).
    """

    name = "control_saturation"
    example_values = {"c_max": 3.0}
    equation = "later effects see c_max tanh(c / c_max) for c"
    source = "smooth actuator saturation (Tao & Kokotović 1996); no seed"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "c_max": ParameterSpec(1.0, "c", (1e-9, 1e9), "positive", doc="saturation level of the control"),
    }

    def param_unit(self, pname: str, units: dict[str, str] | None = None) -> str:
        return (units or {}).get(self.control, f"unit of {self.control}")

    def transform(self, p, kin: Kinematics, state):
        c_max = p["c_max"]
        return kin.with_control(self.control, c_max * tanh(self.read(kin) / c_max))
