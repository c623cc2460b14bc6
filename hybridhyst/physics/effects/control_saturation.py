"""Saturation of a control channel: a field that stops growing with the current."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, tanh


class ControlSaturation(Effect):
    """The control ``c`` seen by the effects listed after this one saturates smoothly: c_s = c_max tanh(c / c_max).

    A magnetorheological fluid's yield stress stops growing once its particles' magnetisation saturates; an
    amplifier clips its output. Linear for |c| ≪ c_max (slope 1), bounded by ± c_max. Listed after a
    ``control_lag`` it saturates the lagged value.

    Units: c_max in the control's unit (> 0). No state. Shapes: ``(batch,)``.
    Source: no seed; the smooth limiter used for saturating actuators (e.g. G. Tao and P. Kokotović,
    "Adaptive Control of Systems with Actuator and Sensor Nonlinearities", Wiley, 1996).
    """

    name = "control_saturation"
    equation = "later effects see c_max tanh(c / c_max) for c"
    source = "smooth actuator saturation (Tao & Kokotović 1996); no seed"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "c_max": ParameterSpec(1.0, "c", (1e-9, 1e9), "positive", doc="saturation level of the control"),
    }

    def __init__(self, control: str = "voltage", **values):
        super().__init__(**values)
        if not isinstance(control, str) or not control:
            raise ValueError(f"effect 'control_saturation': control must name a control channel, got {control!r}")
        self.control = control

    @property
    def condition(self) -> str:
        return self.control

    def options(self) -> dict:
        return {"control": self.control}

    def param_unit(self, pname: str, units: dict[str, str] | None = None) -> str:
        return (units or {}).get(self.control, f"unit of {self.control}")

    def transform(self, p, kin: Kinematics, state):
        if self.control not in kin.controls:
            raise ValueError(f"effect 'control_saturation' acts on the control {self.control!r}, but the records "
                             f"carry {sorted(kin.controls) or 'no control channel'}; name its column in data.controls")
        c_max = p["c_max"]
        return kin.with_control(self.control, c_max * tanh(kin.controls[self.control] / c_max))
