"""The Bouc–Wen system-identification benchmark (Noël & Schoukens 2016).

m ÿ + c ẏ + k y + z = u,  ż = α ẏ − β (γ |ẏ| |z|^(ν−1) z + δ ẏ |z|^ν)
m = 2 kg, c = 10 N s/m, k = 5e4 N/m, α = 5e4 N/m, β = 1e3 m⁻¹, γ = 0.8, δ = −1.1, ν = 1.
In ``BoucWenHysteresis`` terms: α_eff = 0, κ = 1, D = 1, A = α, beta = β γ, gamma = β δ, n = ν.
Input u force [N], output y displacement [m].
"""

from __future__ import annotations

from ..effects import BoucWenHysteresis, LinearStiffness, Viscous
from ..models import DrivenOscillator


def boucwen_benchmark(m: float = 2.0, c: float = 10.0, k: float = 5e4, alpha: float = 5e4, beta: float = 1e3,
                      gamma: float = 0.8, delta: float = -1.1, nu: float = 1.0) -> DrivenOscillator:
    """The benchmark system (defaults: the true values)."""
    effects = {
        "viscous": Viscous(c=c),
        "stiffness": LinearStiffness(k=k),
        "hysteresis": BoucWenHysteresis(alpha=0.0, k=0.0, kappa=1.0, D=1.0, A=alpha, beta=beta * gamma,
                                        gamma=beta * delta, n=nu, fixed=["alpha", "k", "k1", "D", "kappa"]),
    }
    return DrivenOscillator(effects, units={"x": "m", "F": "N", "u": "N", "t": "s"}, name="boucwen_benchmark",
                            mass=m, fixed=("drive_gain",))
