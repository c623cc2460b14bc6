"""Bouc–Wen hysteretic state (general D, A, β, γ, n form of seed 001)."""

from __future__ import annotations

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, abs_pow, absolute, rates, sign


class BoucWenHysteresis(Effect):
    """Bouc–Wen hysteresis with an elastic/hysteretic split and seed 001's cubic term.

    Force and state (seed 001 eqs. 1–2 with eq. 2's misplaced |z| corrected)::

        F  = α (k x + k1 x³) + (1 − α) κ z          κ = D k unless given
        ż  = (A v − β |v| |z|^(n−1) z − γ v |z|^n) / D

    ``v`` is the velocity of the effect's coordinate (``driven_by="motion"``) or the input rate
    (``driven_by="input"``: seed 003's piezo hysteresis h, driven by the voltage rate).

    Special cases: classic Bouc–Wen (seed 004: D = 1, k1 = 0, κ = k), the benchmark of Noël & Schoukens
    (α = 0, κ = 1, D = 1, A = α_BW, β = β_BW γ_BW, γ = β_BW δ_BW), seed 003 (α = 0, κ = K_p / i_ratio).

    Units (for seed 001 x in deg, F in Nm): k [F/x], k1 [F/x^3], κ [F/x], D, A, n [-]; z carries the unit of
    x (of u when driven by the input), so β, γ [1/x^n] (1/u^n), which the seeds print as [-]. Raw Bouc–Wen
    parameters trade off (D, A, α, k); compare responses or identifiable combinations, not raw values.
    Valid range: α ∈ [0, 1] (α [-] is the elastic share of the stiffness); a trained α is kept in (0, 1) by
    a sigmoid, the end points (a purely hysteretic or purely elastic element) are for a fixed α.
    Shapes: (batch,); state (batch, 1).
    """

    name = "bouc_wen"
    example_values = {"alpha": 0.3, "k": 2.0, "k1": 0.1, "D": 1.2, "A": 1.0, "beta": 0.5, "gamma": 0.3, "n": 1.7}
    state_dim = 1
    equation = "F = a(k x + k1 x^3) + (1-a) kappa z;  D dz/dt = A v - beta|v||z|^(n-1) z - gamma v |z|^n"
    source = "Bouc 1967; Wen 1976; seeds 001 (eqs. 1-2), 002, 004; Noel & Schoukens 2016"
    special_cases = (("dahl",),)  # in the discovery form F = k z: n = 1, γ = 0 is Dahl (σ0 = k, Fc = k/β)
    specs = {
        # bounded (a sigmoid): outside [0, 1] one of the two springs has a negative stiffness, and the
        # search bounds alone do not hold α there under gradient training
        "alpha": ParameterSpec(0.5, "-", (0.0, 1.0), "bounded", doc="ratio of elastic to total stiffness"),
        # k, A non-negative (their search bounds' lower end): a softening is the cubic k1's, which may be negative
        "k": ParameterSpec(1.0, "F/x", (0.0, 1e9), "nonnegative", neutral=0.0,
                           doc="stiffness (at k = 0, with k1 = 0, the effect adds nothing)"),
        "k1": ParameterSpec(0.0, "F/x^3", (-1e9, 1e9), "real", neutral=0.0, doc="cubic stiffness (seed 001)"),
        "D": ParameterSpec(1.0, "-", (1e-3, 1e3), "positive", doc="rate divisor (yield scale)"),
        "A": ParameterSpec(1.0, "-", (0.0, 1e6), "nonnegative", doc="hysteretic gain"),
        "beta": ParameterSpec(0.5, "1/x^n", (-1e6, 1e6), "real", doc="shape parameter (z ~ x; |v| term)"),
        "gamma": ParameterSpec(0.5, "1/x^n", (-1e6, 1e6), "real", doc="shape parameter (z ~ x; v term)"),
        "n": ParameterSpec(1.0, "-", (0.5, 10.0), "bounded", doc="sharpness exponent"),
    }

    # for the discovery loop: β and γ multiply |z|^n with z ~ x, so their size scales like 1/x (at n = 1)
    discovery_units = {"beta": "1/x", "gamma": "1/x"}
    # ... and is added in its identifiable normalised form F = k z, ż = v − β|v||z|^(n−1)z − γ v|z|^n:
    # the elastic share α k x and the cubic k1 x³ are other candidates (linear_stiffness, cubic_stiffness),
    # and D, A only rescale z against k (docs/units.md), so they are held at 1.
    discovery_fixed = {"alpha": 0.0, "k1": 0.0, "D": 1.0, "A": 1.0}

    def __init__(self, driven_by: str = "motion", kappa=None, fixed=(), **values):
        if driven_by not in ("motion", "input"):
            raise ValueError(f"bouc_wen: driven_by must be 'motion' or 'input', got {driven_by!r}")
        fix_kappa = "kappa" in fixed
        if fix_kappa and kappa is None:
            raise ValueError("bouc_wen: fixing 'kappa' needs a kappa value")
        super().__init__(fixed=[f for f in fixed if f != "kappa"], **values)
        self.driven_by = driven_by
        self.free_kappa = kappa is not None
        if self.free_kappa:
            spec = ParameterSpec(1.0, "F/x", (-1e9, 1e9), "real", doc="hysteretic force per unit z")
            self.add_parameter("kappa", kappa, spec, fixed=fix_kappa)

    def options(self) -> dict:
        return {"driven_by": self.driven_by}

    def param_unit(self, pname: str, units: dict[str, str] | None = None) -> str:
        if self.driven_by == "input" and pname in ("beta", "gamma"):  # z follows the input u, not x
            return super().param_unit(pname, {**(units or {}), "x": (units or {}).get("u", "u")})
        return super().param_unit(pname, units)

    def _kappa(self, p):
        return p["kappa"] if self.free_kappa else p["D"] * p["k"]

    def rate(self, p, kin: Kinematics, state):
        z = state[:, 0]
        v = kin.v if self.driven_by == "motion" else kin.du
        zn = abs_pow(z, p["n"])
        dz = (p["A"] * v - p["beta"] * absolute(v) * zn * sign(z) - p["gamma"] * v * zn) / p["D"]
        return rates(dz)

    def force(self, p, kin: Kinematics, state):
        x = kin.x
        return p["alpha"] * (p["k"] * x + p["k1"] * x**3) + (1 - p["alpha"]) * self._kappa(p) * state[:, 0]
