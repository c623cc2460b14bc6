"""Seed 004: classic Bouc–Wen damper with a mass.

m ẍ + c ẋ + a kᵢ x + (1 − a) kᵢ z = f(t)   (eqs. 1–3), ż = ẋ [A − (β sgn(ẋ z) + γ)|z|^n]   (eq. 4)

Eq. (4) prints β sign(z) ẋ inside the bracket; the classic form (and the only one that is
dimensionally and physically consistent with the paper's loops) is β sgn(ẋ z), i.e.
ż = A ẋ − β |ẋ| |z|^(n−1) z − γ ẋ |z|^n, which ``BoucWenHysteresis`` implements with D = 1, κ = kᵢ.
The displacement is prescribed (the paper drives the model with measured x(t), ẋ(t)), so the force
f(t) is the response of a ``Constitutive`` law. The captions give a, A, β, γ, n; kᵢ, c and m are not
printed and default to 1 N/mm, 0 and 0 (set them for a given device).
"""

from __future__ import annotations

from ..effects import EFFECTS, BoucWenHysteresis, Viscous
from ..models import Constitutive

CAPTION_PARAMETERS = dict(a=0.35, A=6.0, beta=3.5, gamma=-2.5, n=4.0)  # Figs. 7–8


def bouc_wen_classic(a: float = 0.35, k: float = 1.0, A: float = 6.0, beta: float = 3.5, gamma: float = -2.5,
                     n: float = 4.0, c: float = 0.0, m: float = 0.0) -> Constitutive:
    """Force [N] from displacement [mm]: m ẍ + c ẋ + a k x + (1 − a) k z."""
    effects = {
        "inertia": EFFECTS["inertia"](m=m),
        "viscous": Viscous(c=c),
        "hysteresis": BoucWenHysteresis(alpha=a, k=k, D=1.0, A=A, beta=beta, gamma=gamma, n=n, fixed=["D"]),
    }
    return Constitutive(effects, units={"x": "mm", "F": "N", "t": "s"}, name="bouc_wen_classic")
