"""Pure time delay of the input."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect


class TimeDelay(Effect):
    """The structure reads its input τ late: u(t − τ) instead of u(t).

    Applies to the whole model (every effect and the drive), wherever the effect is listed; several
    delays add. The simulator interpolates the input linearly between samples and holds its first sample
    (value and rates) before t0, so τ is continuous, differentiable inside each sample interval and need not be a
    multiple of the sample interval, whether the record starts at rest or in motion. Typical use:
    actuator/amplifier or sensor latency, misaligned channels.

    Units: tau [t] (≥ 0, neutral 0; stored unconstrained, a negative value would read the future).
    Shapes: ``(batch,)``.
    Source: no seed; the standard transport-delay (dead-time) element of system identification, e.g.
    L. Ljung, "System Identification: Theory for the User", 2nd ed., 1999 (input delay n_k).
    """

    name = "time_delay"
    example_values = {"tau": 0.013}
    equation = "u_seen(t) = u(t - tau)"
    source = "dead-time element (Ljung 1999); no seed"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "tau": ParameterSpec(0.0, "t", (0.0, 1e3), "nonnegative", neutral=0.0, doc="input delay"),
    }

    def input_delay(self, p):
        return p["tau"]
