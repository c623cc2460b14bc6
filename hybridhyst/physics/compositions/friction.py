"""Friction-damper laws for force–displacement data (e.g. the bundled BRFD tests, in/kip)."""

from __future__ import annotations

from ..effects import EFFECTS, Coulomb, Viscous
from ..models import Constitutive

BRFD_UNITS = {"x": "in", "F": "kip", "t": "s"}


def dahl_friction(Fc: float = 1.0, sigma0: float = 50.0, c: float = 0.01, units: dict | None = None) -> Constitutive:
    """Viscous + Dahl friction: F = c v + σ0 z, ż = v − σ0 |v| z / Fc."""
    effects = {"viscous": Viscous(c=c), "dahl": EFFECTS["dahl"](Fc=Fc, sigma0=sigma0)}
    return Constitutive(effects, units=units or BRFD_UNITS, name="dahl_friction")


def lugre_friction(Fc: float = 1.0, Fs: float = 1.2, vs: float = 0.5, sigma0: float = 50.0, sigma1: float = 0.1,
                   sigma2: float = 0.01, units: dict | None = None) -> Constitutive:
    """LuGre friction: F = σ0 z + σ1 ż + σ2 v with the Stribeck curve g(v)."""
    effects = {"lugre": EFFECTS["lugre"](Fc=Fc, Fs=Fs, vs=vs, sigma0=sigma0, sigma1=sigma1, sigma2=sigma2)}
    return Constitutive(effects, units=units or BRFD_UNITS, name="lugre_friction")


def coulomb_viscous(Fc: float = 1.0, c: float = 0.01, v_s: float = 0.05, units: dict | None = None) -> Constitutive:
    """The simplest friction law: F = c v + Fc tanh(v / v_s)."""
    effects = {"viscous": Viscous(c=c), "coulomb": Coulomb(Fc=Fc, v_s=v_s, fixed=["v_s"])}
    return Constitutive(effects, units=units or BRFD_UNITS, name="coulomb_viscous")
