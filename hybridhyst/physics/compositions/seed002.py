"""Seed 002: Bouc–Wen-p — Bouc–Wen parameters as exponential functions of underpressure.

M = φ̈ + 2ξ(p)ω(p)φ̇ + α(p)ω(p)²φ + (1 − α(p))ω(p)z with ż from eq. (6) (|z|^n for the printed |x|^n),
n = 1.48 constant (eq. 13). The printed φ̈ term is a unit inertia.

The coefficients of eqs. (7)–(12) are only plotted (Fig. 14); the defaults are exponential fits
(rise, decay, growth as the paper assigns them; scipy ``curve_fit``, R² 0.97–1.00) to Table 2's
per-pressure values on 0–0.05 MPa. docs/units.md: Table 2 does not reproduce Table 1 under any
reading, so use Table 1 (loop metrics) as reference data and this composition for its structure.
"""

from __future__ import annotations

from ..effects import EFFECTS
from ..effects.bouc_wen_p import BoucWenNormalised
from ..models import Constitutive

CONDITION = "pressure_mpa"
# parameter: (function kind, y0, a, b) — y = y0 + a(1 − e^(−b p)) | y0 + a e^(−b p) | y0 + a e^(b p)
TABLE2_FITS = {
    "omega": ("exp_decay", 0.00636, 0.49364, 484.02352),
    "xi": ("exp_growth", -1108.9978, 1118.21614, 16.34096),
    "alpha": ("exp_rise", 10.57149, 10381.62745, 57.80414),
    "gamma": ("exp_decay", 10.0509, 13.93866, 306.44807),
    "A": ("exp_rise", 7.64834, 143.14794, 45.97649),
    "beta": ("exp_rise", -44.0189, 29.66597, 294.97254),
}
N_EXPONENT = 1.48


def bouc_wen_p(fits: dict | None = None, n: float = N_EXPONENT) -> Constitutive:
    """Seed 002's B–W–p model; ``fits`` overrides {parameter: (kind, y0, a, b)} of ``pressure_mpa``."""
    fits = {**TABLE2_FITS, **(fits or {})}
    values = {name: {"kind": kind, "y0": y0, "a": a, "b": b, "condition": CONDITION}
              for name, (kind, y0, a, b) in fits.items()}
    effects = {
        "inertia": EFFECTS["inertia"](m=1.0, fixed=["m"]),
        "hysteresis": BoucWenNormalised(n=n, **values),
    }
    return Constitutive(effects, units={"x": "deg", "F": "Nm", "t": "s"}, name="bouc_wen_p")
