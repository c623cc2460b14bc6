"""Dahl friction: a first-order, rate-independent presliding state."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, rates


class Dahl(Effect):
    """Dahl friction model.

    State and force::

        ż = v − σ0 |v| z / Fc
        F = σ0 z

    z [x] is the mean bristle deflection. From rest the force rises with slope dF/dx = σ0 and saturates
    at ±Fc while sliding: under a monotone motion from z = 0, F = Fc (1 − exp(−σ0 |x| / Fc)) sign(v).
    The model is rate-independent (ż/v depends only on z and sign v), so its loops do not change with
    frequency.

    Units: sigma0 [F/x] (> 0, presliding stiffness), Fc [F] (> 0, sliding level; it divides, so it is
    positive rather than nonnegative). The state relaxes with rate σ0 |v| / Fc [1/t]: the fixed-step
    solver needs h · σ0 |v| / Fc ≲ 2 (use ``substeps``). Shapes: ``(batch,)``; state ``(batch, 1)``,
    z(0) = 0 or ``z0`` (optional: the deflection the motion before a record left). Source: P. R. Dahl,
    "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1, 1968.
    """

    name = "dahl"
    example_values = {"Fc": 1.0, "sigma0": 5.0}
    state_dim = 1
    equation = "dz/dt = v - sigma0 |v| z / Fc;  F = sigma0 z"
    source = "Dahl 1968"
    special_cases = (("coulomb",),)  # σ0 → ∞: rigid-plastic, Coulomb
    start: ClassVar[dict[str, ParameterSpec]] = {
        "z0": ParameterSpec(0.0, "x", (-1e9, 1e9), "real", neutral=0.0, signed=True,
                            doc="bristle deflection at the start of each record"),
    }
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "sigma0": ParameterSpec(1e3, "F/x", (1e-9, 1e12), "positive", doc="presliding (bristle) stiffness"),
        "Fc": ParameterSpec(1.0, "F", (1e-12, 1e9), "positive", doc="sliding (Coulomb) friction level"),
    }

    def rate(self, p, kin: Kinematics, state):
        z = state[:, 0]
        return rates(kin.v - p["sigma0"] * absolute(kin.v) * z / p["Fc"])

    def force(self, p, kin: Kinematics, state):
        return p["sigma0"] * state[:, 0]
