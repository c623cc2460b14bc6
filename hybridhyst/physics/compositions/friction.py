"""Friction-damper laws for force–displacement data (e.g. the bundled BRFD tests, in/kip)."""

from __future__ import annotations

from ..effects import EFFECTS, Coulomb, Viscous
from ..models import Constitutive

BRFD_UNITS = {"x": "in", "F": "kip", "t": "s"}


def dahl_friction(Fc: float = 2.0, sigma0: float = 10.0, c: float = 0.01, Fc_coulomb: float = 0.5,
                  v_s: float = 0.05, units: dict | None = None) -> Constitutive:
    """Viscous + smoothed Coulomb + Dahl friction: F = c v + Fc_coulomb tanh(v/v_s) + σ0 z, ż = v − σ0 |v| z / Fc.

    Defaults are BRFD-sized starting values [in, kip, s]: a Dahl state much stiffer than σ0/Fc ≈ 5 /in
    needs a finer time grid than the ~32 samples per loading cycle the main job fits on.
    """
    effects = {
        "viscous": Viscous(c=c),
        "coulomb": Coulomb(Fc=Fc_coulomb, v_s=v_s, fixed=["v_s"]),
        "dahl": EFFECTS["dahl"](Fc=Fc, sigma0=sigma0),
    }
    return Constitutive(effects, units=units or BRFD_UNITS, name="dahl_friction")


def lugre_friction(Fc: float = 2.0, Fs: float = 2.5, vs: float = 1.0, sigma0: float = 10.0, sigma1: float = 0.0,
                   sigma2: float = 0.01, units: dict | None = None) -> Constitutive:
    """LuGre friction: F = σ0 z + σ1 ż + σ2 v, ż = v − σ0 |v| z / g(v), g(v) = Fc + (Fs − Fc) e^(−(v/vs)²)."""
    effects = {"lugre": EFFECTS["lugre"](Fc=Fc, Fs=Fs, vs=vs, sigma0=sigma0, sigma1=sigma1, sigma2=sigma2)}
    return Constitutive(effects, units=units or BRFD_UNITS, name="lugre_friction")
