"""Seed 002's normalised Bouc–Wen law (ω, ξ parametrisation)."""

from __future__ import annotations

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, abs_pow, absolute, rates, sign


class BoucWenNormalised(Effect):
    """Bouc–Wen in seed 002's normalised form (eqs. 1–2 / 5–6)::

        F  = 2 ξ ω v + α ω² x + (1 − α) ω z
        ż  = A v − γ |v| |z|^(n−1) z − β v |z|^n

    (eq. 2 prints |x|^n in the β term; the Bouc–Wen form has |z|^n.) Seed 002 names the |v| term γ and
    the v term β — the reverse of seed 001 — and this effect keeps the paper's names. Units as printed
    in its Table 2: ω [1/s], ξ [F*t/x], α [F/x], β, γ [1/x^n] (z ~ x; printed x^-2), A [-], n [-]; the table's values
    are not mutually consistent (docs/units.md), so treat them as a structure, not a calibration.
    Shapes: (batch,); state (batch, 1).
    """

    name = "bouc_wen_normalised"
    example_values = {"omega": 1.5, "xi": 0.1, "alpha": 0.3, "A": 1.0, "beta": 0.3, "gamma": 0.5, "n": 1.48}
    discovery_candidate = False  # bouc_wen is offered in this identifiable form (its discovery_fixed)
    state_dim = 1
    equation = "F = 2 xi w v + a w^2 x + (1-a) w z;  dz/dt = A v - gamma|v||z|^(n-1) z - beta v |z|^n"
    source = "seed 002 (eqs. 5-6)"
    specs = {
        "omega": ParameterSpec(1.0, "1/t", (1e-6, 1e3), "positive", doc="pseudo-natural frequency"),
        "xi": ParameterSpec(0.0, "F*t/x", (-1e4, 1e4), "real", doc="viscous damping ratio (as printed)"),
        "alpha": ParameterSpec(0.5, "F/x", (-1e5, 1e5), "real", doc="elastic/hysteretic split (as printed)"),
        "A": ParameterSpec(1.0, "-", (0.0, 1e3), "nonnegative", doc="hysteretic gain"),
        "beta": ParameterSpec(0.5, "1/x^n", (-1e3, 1e3), "real", doc="shape parameter (z ~ x; v term)"),
        "gamma": ParameterSpec(0.5, "1/x^n", (-1e3, 1e3), "real", doc="shape parameter (z ~ x; |v| term)"),
        "n": ParameterSpec(1.48, "-", (0.5, 10.0), "bounded", doc="sharpness exponent"),
    }

    def rate(self, p, kin: Kinematics, state):
        z, v = state[:, 0], kin.v
        zn = abs_pow(z, p["n"])
        return rates(p["A"] * v - p["gamma"] * absolute(v) * zn * sign(z) - p["beta"] * v * zn)

    def force(self, p, kin: Kinematics, state):
        w, a = p["omega"], p["alpha"]
        return 2 * p["xi"] * w * kin.v + a * w**2 * kin.x + (1 - a) * w * state[:, 0]
