"""Maxwell element: a spring in series with a dashpot (linear viscoelastic relaxation)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, rates


class Maxwell(Effect):
    """A spring k_m in series with a dashpot c_m = k_m τ.

    State and force::

        ż = v − z / τ
        F = k_m z

    z [x] is the spring's deflection (the motion not yet taken up by the dashpot). Under a sine of angular
    frequency ω the element adds a storage stiffness k_m (ωτ)² / (1 + (ωτ)²) and a loss coefficient
    c_m / (1 + (ωτ)²): stiff and lossless well above 1/τ, a dashpot well below it — the frequency-dependent
    stiffness and damping of elastomers, viscoelastic layers and granular media. τ → 0 with k_m τ held is
    ``viscous`` (c = k_m τ).

    Units: k_m [F/x] (≥ 0, neutral 0: no element), tau [t] (> 0, relaxation time). The state relaxes at
    1/τ: the fixed-step solver needs h ≲ 2.8 τ (step doubling resolves it). Shapes: ``(batch,)``; state
    ``(batch, 1)``, z(0) = 0 (relaxed at the start of a record).
    Source: J. C. Maxwell, "On the dynamical theory of gases", Phil. Trans. R. Soc. 157, 1867; N. W.
    Tschoegl, "The Phenomenological Theory of Linear Viscoelastic Behavior", Springer 1989.
    """

    name = "maxwell"
    example_values = {"k_m": 2.0, "tau": 0.1}
    state_dim = 1
    equation = "dz/dt = v - z / tau;  F = k_m z"
    source = "Maxwell 1867; Tschoegl 1989"
    special_cases = (("viscous",),)  # tau -> 0 with k_m tau held: c = k_m tau
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "k_m": ParameterSpec(0.0, "F/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="stiffness of the spring"),
        "tau": ParameterSpec(0.1, "t", (1e-9, 1e9), "positive", doc="relaxation time c_m / k_m"),
    }

    def rate(self, p, kin: Kinematics, state):
        return rates(kin.v - state[:, 0] / p["tau"])

    def force(self, p, kin: Kinematics, state):
        return p["k_m"] * state[:, 0]
