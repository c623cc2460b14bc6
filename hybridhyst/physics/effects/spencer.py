"""Spencer's phenomenological magnetorheological damper: Bouc–Wen with a series dashpot and springs."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, abs_pow, absolute, rates


class SpencerMR(Effect):
    """Spencer, Dyke, Sain & Carlson (1997)'s MR damper model (their Fig. 4), the standard MR damper law:

        F = α z + c0 (ẋ − ẏ) + k0 (x − y) + k1 (x − x0)
        ż = −γ |ẋ − ẏ| z |z|^(n−1) − β (ẋ − ẏ) |z|^n + A (ẋ − ẏ)
        ẏ = [α z + c0 ẋ + k0 (x − y)] / (c0 + c1)

    A Bouc–Wen element and a dashpot c0 in parallel, in series with a dashpot c1 (internal displacement y), and an
    accumulator spring k1 with offset x0. In the paper α, c0 and c1 are linear in the coil's filtered voltage u
    (α = αa + αb u, ...): give them as ``{kind: linear, condition: voltage}`` and list a ``control_lag`` on
    ``voltage`` before this effect (``conf/model/mr_damper_spencer.yaml``).

    Units: alpha, k0, k1 [F/x]; c0, c1 [F*t/x]; x0 [x]; gamma, beta [1/x^n]; A, n [-]. States: z [x], y [x],
    both starting at 0. Shapes: ``(batch,)``.
    Source: B. F. Spencer Jr., S. J. Dyke, M. K. Sain, J. D. Carlson, "Phenomenological model for
    magnetorheological dampers", J. Eng. Mech. 123(3), 230–238, 1997 (eqs. 4–9).
    """

    name = "spencer_mr"
    discovery_candidate = False  # a whole device law, not one effect to add
    example_values = {"alpha": 0.8, "c0": 0.4, "c1": 6.0, "k0": 0.5, "k1": 0.1, "x0": 0.05, "gamma": 1.2, "beta": 1.1,
                      "A": 1.3, "n": 2.0}
    state_dim = 2
    equation = ("F = alpha z + c0 (v - dy) + k0 (x - y) + k1 (x - x0); dz = -gamma|v-dy| z|z|^(n-1) - beta (v-dy)|z|^n"
                " + A (v-dy); dy = (alpha z + c0 v + k0 (x - y)) / (c0 + c1)")
    source = "Spencer, Dyke, Sain & Carlson 1997"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "alpha": ParameterSpec(1.0, "F/x", (0.0, 1e9), "nonnegative", doc="Bouc-Wen force per unit z"),
        "c0": ParameterSpec(1.0, "F*t/x", (1e-9, 1e9), "positive", doc="viscous damping at large velocities"),
        "c1": ParameterSpec(10.0, "F*t/x", (1e-9, 1e9), "positive", doc="dashpot for the roll-off at low velocities"),
        "k0": ParameterSpec(1.0, "F/x", (0.0, 1e9), "nonnegative", doc="stiffness at large velocities"),
        "k1": ParameterSpec(0.0, "F/x", (0.0, 1e9), "nonnegative", neutral=0.0, doc="accumulator stiffness"),
        "x0": ParameterSpec(0.0, "x", (-1e9, 1e9), "real", doc="initial displacement of the spring k1"),
        "gamma": ParameterSpec(1.0, "1/x^n", (-1e9, 1e9), "real", doc="shape parameter (|v| term)"),
        "beta": ParameterSpec(1.0, "1/x^n", (-1e9, 1e9), "real", doc="shape parameter (v term)"),
        "A": ParameterSpec(1.0, "-", (0.0, 1e9), "nonnegative", doc="hysteretic gain"),
        "n": ParameterSpec(2.0, "-", (0.5, 10.0), "bounded", doc="sharpness exponent"),
    }

    def _rates(self, p, kin: Kinematics, state):
        z, y = state[:, 0], state[:, 1]
        dy = (p["alpha"] * z + p["c0"] * kin.v + p["k0"] * (kin.x - y)) / (p["c0"] + p["c1"])
        dr = kin.v - dy
        dz = -p["gamma"] * absolute(dr) * z * abs_pow(z, p["n"] - 1) - p["beta"] * dr * abs_pow(z, p["n"]) + p["A"] * dr
        return dz, dy

    def rate(self, p, kin: Kinematics, state):
        return rates(*self._rates(p, kin, state))

    def force(self, p, kin: Kinematics, state):
        dy = self._rates(p, kin, state)[1]
        return p["c1"] * dy + p["k1"] * (kin.x - p["x0"])
