"""LuGre friction: bristle state with a Stribeck sliding curve."""

from __future__ import annotations

from typing import ClassVar

import torch

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, exp, rates


class LuGre(Effect):
    """LuGre dynamic friction model.

    State and force::

        g(v) = Fc + (Fs − Fc) exp(−(v / vs)²)
        ż    = v − σ0 |v| z / g(v)
        F    = σ0 z + σ1 ż + σ2 v

    z [x] is the mean bristle deflection. At steady sliding ż = 0 and z = g(v) sign(v) / σ0, so
    F = g(v) sign(v) + σ2 v: the Stribeck curve (``Coulomb`` + ``Stribeck`` + ``Viscous`` in static form);
    σ1 only damps the transients (presliding). Fs = Fc, σ1 = σ2 = 0 recovers ``Dahl``.

    Units: sigma0 [F/x] (> 0, bristle stiffness), sigma1 [F*t/x] (≥ 0, micro-damping), sigma2 [F*t/x]
    (≥ 0, viscous, default 0), Fc [F] (> 0, Coulomb level), Fs [F] (> 0, static level, usually Fs ≥ Fc),
    vs [x/t] (> 0, Stribeck velocity). The state relaxes with rate σ0 |v| / g(v) [1/t]: the fixed-step
    solver needs h · σ0 |v| / g ≲ 2 (use ``substeps``). Shapes: ``(batch,)``; state ``(batch, 1)``,
    z(0) = 0 or ``z0`` (optional: the deflection the motion before a record left).
    Source: C. Canudas de Wit, H. Olsson, K. J. Åström, P. Lischinsky, "A new model for control of
    systems with friction", IEEE Trans. Automatic Control 40(3), 419–425, 1995.
    """

    name = "lugre"
    example_values = {"Fc": 1.0, "Fs": 1.4, "vs": 0.5, "sigma0": 5.0, "sigma1": 0.1, "sigma2": 0.05}
    state_dim = 1
    equation = "g = Fc + (Fs-Fc) exp(-(v/vs)^2);  dz/dt = v - sigma0 |v| z / g;  F = sigma0 z + sigma1 dz/dt + sigma2 v"
    source = "Canudas de Wit et al. 1995"
    # Fs = Fc, σ1 = σ2 = 0: Dahl (with σ2: + viscous); Fc, Fs → 0: viscous
    special_cases = (("dahl",), ("dahl", "viscous"), ("viscous",))
    start: ClassVar[dict[str, ParameterSpec]] = {
        "z0": ParameterSpec(0.0, "x", (-1e9, 1e9), "real", neutral=0.0, signed=True,
                            doc="bristle deflection at the start of each record"),
    }
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "sigma0": ParameterSpec(1e3, "F/x", (1e-9, 1e12), "positive", doc="bristle stiffness"),
        "sigma1": ParameterSpec(0.0, "F*t/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="bristle micro-damping"),
        "sigma2": ParameterSpec(0.0, "F*t/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="viscous friction"),
        "Fc": ParameterSpec(1.0, "F", (1e-12, 1e9), "positive", doc="Coulomb (sliding) friction level"),
        "Fs": ParameterSpec(1.0, "F", (1e-12, 1e9), "positive", doc="static (breakaway) friction level"),
        "vs": ParameterSpec(1e-2, "x/t", (1e-9, 1e6), "positive", doc="Stribeck velocity"),
    }

    @staticmethod
    def stribeck_curve(p, v: torch.Tensor) -> torch.Tensor:
        """g(v) = Fc + (Fs − Fc) exp(−(v/vs)²) [F], ``(batch,)``."""
        return p["Fc"] + (p["Fs"] - p["Fc"]) * exp(-((v / p["vs"]) ** 2))

    def _dz(self, p, kin: Kinematics, z: torch.Tensor) -> torch.Tensor:
        return kin.v - p["sigma0"] * absolute(kin.v) * z / self.stribeck_curve(p, kin.v)

    def rate(self, p, kin: Kinematics, state):
        return rates(self._dz(p, kin, state[:, 0]))

    def force(self, p, kin: Kinematics, state):
        z = state[:, 0]
        return p["sigma0"] * z + p["sigma1"] * self._dz(p, kin, z) + p["sigma2"] * kin.v
