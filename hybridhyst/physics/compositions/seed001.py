"""Seed 001: modified Bouc–Wen model of the VPPTD with Table 1's parameter functions of underpressure.

Model (eqs. 1–2, with eq. 2's misplaced |z| corrected)::

    M  = c φ̇ + α (k φ + k₁ φ³) + (1 − α) D k z + M_s sgn(φ̇)
    ż  = (A φ̇ − β |φ̇| |z|^(n−1) z − γ φ̇ |z|^n) / D

Literal-degree convention (docs/units.md): φ in deg, φ̇ in deg/s, M in Nm, and the rig's inertia
I = 0.51 used directly in those units. With it, free vibration reproduces Table 2. Eq. (5) of the
paper prints displacement (φ₂ − φ₁) where velocity belongs in the rate equation; we use velocity.

Every builder takes ``coefficients``: parameter functions in Table 1's layout (``{"D": [c0, c1], ...}``,
increasing powers of p [MPa]) that replace the mixture's, e.g. identified ones (``parameter_functions``
reads them back from a fitted model). The experiments run on these models (free vibration, forced response,
identifiable combinations) are in ``hybridhyst.synth.seed001``.
"""

from __future__ import annotations

from ..effects import BoucWenHysteresis, Coulomb, Viscous
from ..models import Constitutive, DrivenOscillator

MIXTURES = ("ABS", "3:1", "1:1", "1:3", "NBR")
CONDITION = "pressure_mpa"
INERTIA = 0.51  # kg·m² quoted, used in the deg/Nm convention (Nm·s²/deg)
COULOMB_SMOOTHING = 0.1  # deg/s: width of the smoothed sgn(φ̇); the paper uses an exact sign

# Table 1: polynomial coefficients in increasing powers of p [MPa].
TABLE1: dict[str, dict[str, list[float]]] = {
    "ABS": dict(D=[2.5581, 12.726], A=[4.5122, 10.227], beta=[6.9041, 252.3], gamma=[-3.0, -14.776],
                n=[1.0685, 16.356], c=[-0.0033, -1.549, -8.6701], alpha=[0.5325, -7.7916, 106.76, -479.08],
                k=[0.7932, 56.164], k1=[0.0135, 0.7068], Ms=[2.1562, 109.45]),
    "3:1": dict(D=[3.1847, 12.602], A=[5.0437, -7.0758], beta=[4.3327, 16.705], gamma=[0.6223, -27.079],
                n=[2.7561, 15.76], c=[0.005, 1.0048], alpha=[0.2421, 1.4578], k=[4.1, -5.5556],
                k1=[0.0247, 0.6425], Ms=[13.0, 55.556]),
    "1:1": dict(D=[4.4261, -16.879], A=[4.6602, -1.4573], beta=[15.223, -66.521], gamma=[-2.6961, -11.9],
                n=[1.7688, 4.2585], c=[0.0546, -0.2528], alpha=[0.289, 0.187], k=[4.023, 29.745],
                k1=[0.0092, 0.20717], Ms=[1.792, 54.896]),
    "1:3": dict(D=[2.72, -2.174], A=[4.23, -3.42], beta=[22.33, -102.96], gamma=[-0.244, -19.12],
                n=[1.8123, 1.433], c=[0.028, 1.49, -9.86], alpha=[0.1442, 1.916], k=[4.15, 0.33],
                k1=[0.0391, 0.15], Ms=[0.9, 35.0]),
    "NBR": dict(D=[1.9212, -4.385], A=[3.1217, -4.3383], beta=[26.669, -177.48], gamma=[-0.755, -26.345],
                n=[1.6474, 1.2294], c=[0.036, 2.59, -12.86], alpha=[0.24, 2.9748], k=[3.7685, -7.2219],
                k1=[0.0203, -0.0317], Ms=[0.1743, 15.9]),
}
# Table 2: published free-vibration frequency range [Hz] over p = 0.01 ... 0.09 MPa.
TABLE2_HZ = {"ABS": (0.35, 0.52), "3:1": (0.55, 0.75), "1:1": (0.37, 0.50), "1:3": (0.28, 0.38), "NBR": (0.25, 0.30)}
# Figure captions 5–9: initial angle [deg] and angular velocity [deg/s] of the main mass.
FREE_VIBRATION_IC = {"ABS": (10.0, 55.0), "3:1": (10.0, 160.0), "1:1": (10.0, 100.0), "1:3": (10.0, 40.0),
                     "NBR": (10.0, 5.0)}


# Where each Table 1 parameter lives in the composition: (effect key, parameter name).
PARAMETER_PATHS = {"c": ("viscous", "c"), **{n: ("hysteresis", n) for n in ("alpha", "k", "k1", "D", "A", "beta",
                                                                             "gamma", "n")},
                   "Ms": ("friction", "Fc")}


def _check_mixture(mixture: str) -> dict[str, list[float]]:
    if mixture not in TABLE1:
        raise ValueError(f"unknown seed 001 mixture {mixture!r}; choose one of {list(MIXTURES)}")
    return TABLE1[mixture]


def _table(mixture: str, coefficients) -> dict[str, list[float]]:
    if coefficients is None:
        return _check_mixture(mixture)
    if set(coefficients) != set(PARAMETER_PATHS) or any(len(v) == 0 for v in coefficients.values()):
        raise ValueError(f"coefficients must give a non-empty coefficient list for each of {list(PARAMETER_PATHS)}; "
                         f"got {sorted(coefficients)}")
    return {k: [float(c) for c in v] for k, v in coefficients.items()}


def _effects(mixture: str, coefficients=None) -> dict:
    table = _table(mixture, coefficients)
    poly = lambda name: {"kind": "polynomial", "coeffs": table[name], "condition": CONDITION}  # noqa: E731
    return {
        "viscous": Viscous(c=poly("c")),
        "hysteresis": BoucWenHysteresis(**{k: poly(k) for k in ("alpha", "k", "k1", "D", "A", "beta", "gamma", "n")}),
        "friction": Coulomb(Fc=poly("Ms"), v_s=COULOMB_SMOOTHING, fixed=["v_s"]),
    }


def modified_bouc_wen(mixture: str = "1:3", coefficients=None) -> Constitutive:
    """The damper law of one mixture (torque [Nm] from the angle history [deg]); condition ``pressure_mpa``.

    ``coefficients`` (Table 1's layout) replace the mixture's parameter functions.
    """
    label = mixture if coefficients is None else "custom"
    return Constitutive(_effects(mixture, coefficients), units={"x": "deg", "F": "Nm", "t": "s"},
                        name=f"modified_bouc_wen[{label}]")


def vpptd_rig(mixture: str = "1:3", outputs=("x", "force"), coefficients=None) -> DrivenOscillator:
    """Seed 001 Fig. 4: inertia I on the damper, driven kinematically by φ₁(t) (eqs. 3–5).

    I φ̈₂ + M(φ₂ − φ₁, φ̇₂ − φ̇₁, z) = 0. Input: φ₁ [deg]; outputs φ₂ [deg] and the damper torque [Nm].
    Free vibration: φ₁ ≡ 0 and an initial state [φ₂(0), φ̇₂(0)]. ``coefficients`` (Table 1's layout)
    replace the mixture's parameter functions (e.g. a damper law identified from loops).
    """
    label = mixture if coefficients is None else "custom"
    return DrivenOscillator(_effects(mixture, coefficients), units={"x": "deg", "F": "Nm", "u": "deg", "t": "s"},
                            name=f"vpptd_rig[{label}]", excitation="base", outputs=outputs,
                            mass=INERTIA, fixed=("mass",))


def parameter_functions(model) -> dict[str, list[float]]:
    """The parameter functions of a seed 001 composition in Table 1's layout (increasing powers of p).

    Works on ``modified_bouc_wen`` / ``vpptd_rig`` models, fitted or not; a constant parameter gives a
    one-element list. The result can be passed back as ``coefficients=``.
    """
    out = {}
    for name, (effect, param) in PARAMETER_PATHS.items():
        fn = model.effects[effect].params[param]
        values = fn.coeffs if hasattr(fn, "coeffs") else fn.value
        out[name] = [float(v) for v in values.detach().reshape(-1)]
    return out
