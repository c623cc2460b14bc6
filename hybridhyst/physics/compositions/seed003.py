"""Seed 003: lever-amplified piezo actuator with equivalent actuation attenuation (nominal model).

m ẍ + c ẋ + (K_spr/2 + K_p/i²) x + f_f tanh(σ ẋ) = (K_p/i)((d33 − ξ|x|) u − h)          (eqs. 8–9)
ḣ = α u̇ − β |u̇| |h|^(n−1) h − γ u̇ |h|^n                                              (eq. 7)

Mapped onto a ``DrivenOscillator`` with drive gain g = K_p d33 / i and three resisting terms
(attenuation ξ' = K_p ξ / i on |x| u, and the input-driven Bouc–Wen state with κ = K_p / i).
Units: x and h in µm (docs/units.md: the identified values are plausible only with h in µm:
about 170 µm output at 80 V), u in V, F in N, t in s. Table 1's SI values are converted to N/µm.
m_eq is not printed; 0.01 kg (a 1.2 kHz first mode, well above the 50 Hz sweeps) is assumed.
"""

from __future__ import annotations

from ..effects import EFFECTS, BoucWenHysteresis, Coulomb, LinearStiffness, Viscous
from ..models import DrivenOscillator

TABLE1 = dict(K_spr=1.11e4, K_p=4.113e7, d33=0.308, c_eq=1.148e2, f_f=9.544e-1, i_ratio=8.466,
              alpha=3.216, beta=1.279e2, gamma=-1.022e2, n=1.902, xi=3.41e-4)  # SI; d33, alpha in µm/V
ASSUMED = dict(m_eq=0.01, sigma=1.0)  # kg; tanh slope [s/µm]
UM = 1e-6  # m per µm


def piezo_attenuation(params: dict | None = None) -> DrivenOscillator:
    """Seed 003's nominal model; ``params`` overrides entries of ``TABLE1``/``ASSUMED`` (same units)."""
    q = {**TABLE1, **ASSUMED, **(params or {})}
    gain = q["K_p"] * UM / q["i_ratio"]  # N/µm
    effects = {
        "viscous": Viscous(c=q["c_eq"] * UM),  # N·s/µm
        "stiffness": LinearStiffness(k=(q["K_spr"] / 2 + q["K_p"] / q["i_ratio"] ** 2) * UM),  # N/µm
        "friction": Coulomb(Fc=q["f_f"], v_s=1.0 / q["sigma"]),
        "attenuation": EFFECTS["attenuation"](xi=gain * q["xi"]),  # N/(µm·V)
        "hysteresis": BoucWenHysteresis(driven_by="input", alpha=0.0, k=0.0, kappa=gain, D=1.0, A=q["alpha"],
                                        beta=q["beta"], gamma=q["gamma"], n=q["n"], fixed=["alpha", "k", "k1", "D"]),
    }
    return DrivenOscillator(effects, units={"x": "um", "F": "N", "u": "V", "t": "s"}, name="piezo_attenuation",
                            mass=q["m_eq"] * UM, drive_gain=gain * q["d33"])
