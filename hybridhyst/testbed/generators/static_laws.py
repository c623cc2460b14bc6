"""Sign functions and static laws of the first bed: the exact sign and its arctan, erf and algebraic smoothings
(never tanh), the Stribeck sliding level and a position-periodic cogging force."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erf


def sgn(v, kind: str = "exact", width: float = 0.0) -> np.ndarray:
    """The sign of v: "exact" (np.sign, with |v| below 1e-9 of its largest value counted as 0, so that a
    sample on a reversal is 0 and not a rounding accident), "arctan" (2/π) arctan(v/δ), "erf" erf(v/δ), or
    "algebraic" v / √(v² + δ²) with δ = ``width``."""
    v = np.asarray(v, float)
    if kind == "exact":
        tiny = 1e-9 * (np.max(np.abs(v)) if v.size else 0.0)
        return np.where(np.abs(v) <= tiny, 0.0, np.sign(v))
    if width <= 0:
        raise ValueError(f"a smoothed sign ({kind!r}) needs a positive width, got {width}")
    if kind == "arctan":
        return (2.0 / math.pi) * np.arctan(v / width)
    if kind == "erf":
        return erf(v / width)
    if kind == "algebraic":
        return v / np.sqrt(v * v + width * width)
    raise ValueError(f"unknown sign kind {kind!r}; choose exact, arctan, erf or algebraic")


def stribeck_curve(v, Fc: float, Fs: float, vs: float, shape: float = 2.0) -> np.ndarray:
    """Sliding level g(v) = Fc + (Fs − Fc) exp(−|v / vs|^shape) (≥ 0, even in v)."""
    return Fc + (Fs - Fc) * np.exp(-np.abs(np.asarray(v, float) / vs) ** shape)


def cogging(x, amplitude: float, period: float, phase: float = 0.0) -> np.ndarray:
    """A position-periodic force A sin(2π x / p + φ) (detent / cogging of a geared or magnetic drive)."""
    return amplitude * np.sin(2 * math.pi * np.asarray(x, float) / period + phase)
