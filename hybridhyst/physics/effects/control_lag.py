"""First-order lag of a control channel: what a coil's current does to the commanded voltage."""

from __future__ import annotations

from typing import ClassVar

import torch

from ..parameters import ParameterSpec
from .base import ControlEffect, Kinematics, rates


class ControlLag(ControlEffect):
    """The control ``c`` seen by the effects listed after this one lags the measured one: u̇ = −η (u − c).

    A magnetorheological damper's field follows the commanded voltage through the coil's inductance (Spencer
    et al. 1997, eq. 8: u̇ = −η (u − v)); a pressure regulator follows its set point. The lagged value replaces
    the control for every later effect, so a parameter given as a function of ``c`` (``alpha: {kind: linear,
    condition: voltage}``) reads the lagged value once this effect is listed before it, and a model config does
    not change when the lag is added. The state starts at the control's first value (a record that begins in
    steady state).

    Units: eta [1/t] (> 0; 1/eta is the time constant). State: u, in the control's unit. Shapes: ``(batch,)``.
    Source: Spencer, Dyke, Sain & Carlson, "Phenomenological model for magnetorheological dampers",
    J. Eng. Mech. 123(3), 230–238, 1997 (eq. 8).
    """

    name = "control_lag"
    example_values = {"eta": 190.0}
    state_dim = 1
    equation = "du/dt = -eta (u - c);  later effects see u for c"
    source = "Spencer et al. 1997, eq. 8"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "eta": ParameterSpec(100.0, "1/t", (1e-6, 1e9), "positive", doc="lag rate (1 / time constant)"),
    }

    def initial_state(self, p, batch, controls=None):
        if controls and self.control in controls:
            return torch.as_tensor(controls[self.control]).expand(batch)[:, None].clone()
        return super().initial_state(p, batch)

    def rate(self, p, kin: Kinematics, state):
        return rates(-p["eta"] * (state[:, 0] - self.read(kin)))

    def transform(self, p, kin: Kinematics, state):
        return kin.with_control(self.control, state[:, 0])
