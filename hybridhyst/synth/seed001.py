"""Seed 001's rig and damper law, simulated: free vibration (Table 2), forced response under an underpressure
schedule (§5.2, Figs. 10–14) and the response-determining combinations of the raw parameters.

The models themselves (``modified_bouc_wen``, ``vpptd_rig``, Table 1) are in
``hybridhyst.physics.compositions.seed001``; this module runs experiments on them.
"""

from __future__ import annotations

import numpy as np
import torch

from ..analysis import free_vibration_frequency
from ..physics.compositions.seed001 import CONDITION, FREE_VIBRATION_IC, _check_mixture, vpptd_rig
from ..simulate import simulate

__all__ = ["forced_response", "free_vibration_frequencies", "identifiable_combinations"]


def identifiable_combinations(model, pressures) -> dict[str, np.ndarray]:
    """Response-determining combinations of the modified Bouc–Wen parameters at each pressure.

    z → s z (A → s A; β, γ → s^(1−n) β, s^(1−n) γ; (1 − α) k → (1 − α) k / s) and D → λ D (A, β, γ → λ A,
    λ β, λ γ; (1 − α) k → (1 − α) k / λ), each with α k and α k1 held, leave the torque unchanged
    (docs/units.md); these combinations are invariant under both:

    ``elastic_k = α k`` [Nm/deg], ``cubic_k1 = α k1`` [Nm/deg³], ``hysteretic_k0 = (1 − α) k A`` [Nm/deg]
    (initial slope of the hysteretic torque), ``hysteretic_torque = (1 − α) D k (A / (β + γ))^(1/n)`` [Nm]
    (its saturation level under loading; NaN where β + γ ≤ 0), ``shape = β / (β + γ)`` [-], ``n`` [-],
    ``c`` [Nm·s/deg] and ``Ms`` [Nm]. Returns arrays of shape ``(len(pressures),)``.
    """
    p = np.asarray(pressures, dtype=np.float64).reshape(-1)
    with torch.no_grad():
        values = model.evaluate({CONDITION: torch.as_tensor(p, dtype=torch.float64)}, len(p))
    h = {k: v.detach().double().numpy() for k, v in values["hysteresis"].items()}
    alpha, k, A, D, n = h["alpha"], h["k"], h["A"], h["D"], h["n"]
    s = h["beta"] + h["gamma"]
    with np.errstate(invalid="ignore", divide="ignore"):
        saturation = np.where(s > 0, (1 - alpha) * D * k * np.abs(A / s) ** (1.0 / n), np.nan)
        shape = h["beta"] / s
    return {"elastic_k": alpha * k, "cubic_k1": alpha * h["k1"], "hysteretic_k0": (1 - alpha) * k * A,
            "hysteretic_torque": saturation, "shape": shape, "n": n,
            "c": values["viscous"]["c"].detach().double().numpy(),
            "Ms": values["friction"]["Fc"].detach().double().numpy()}


def free_vibration_frequencies(mixture: str, pressures=None, duration: float = 10.0, dt: float = 2e-3,
                               initial=None, method: str = "fft", backend: str = "fast", coefficients=None):
    """Free-vibration frequency [Hz] of the rig at each underpressure (seed 001 Table 2).

    Simulates φ₁ ≡ 0 from the figure caption's initial conditions and estimates the frequency of
    φ₂ about its rest position (``hybridhyst.analysis.free_vibration_frequency``; ``method`` "fft" or
    "turning_points"). ``coefficients`` (Table 1's layout) replace the mixture's damper law (the initial
    conditions stay the mixture's). Returns ``(pressures, frequencies)`` as numpy arrays.
    """
    pressures = np.arange(1, 10) * 0.01 if pressures is None else np.asarray(pressures, dtype=float)
    _check_mixture(mixture)
    x0, v0 = FREE_VIBRATION_IC[mixture] if initial is None else initial
    model = vpptd_rig(mixture, outputs=("x",), coefficients=coefficients).double()
    n = int(round(duration / dt)) + 1
    with torch.no_grad():
        y = simulate(model, torch.zeros(len(pressures), n), dt=dt, conditions={CONDITION: pressures},
                     initial_state=torch.tensor([[x0, v0]] * len(pressures)), backend=backend)
    x = y[..., 0].double().numpy()
    freqs = np.array([free_vibration_frequency(xi, dt, method=method) for xi in x])
    return pressures, freqs


def forced_response(mixture: str, t, pressure_mpa, amplitude_deg: float = 10.0, frequency_hz: float = 0.3,
                    coefficients=None, outputs=("x",), backend: str = "fast") -> np.ndarray:
    """The rig driven by φ₁ = φ₀ sin(2π f t) under an underpressure schedule (seed 001 §5.2, Figs. 10–14).

    The schedule is a control channel of the simulation (``simulate(conditions={"pressure_mpa": (B, T)})``):
    Table 1's polynomials of p are evaluated at every integration stage, p interpolated linearly between the
    samples like the excitation. One uninterrupted simulation per schedule.

    Parameters
    ----------
    t : sample times ``(T,)`` [s], from rest (φ₂ = φ̇₂ = z = 0 at t[0]).
    pressure_mpa : underpressure at each sample, ``(T,)`` or ``(B, T)`` [MPa] (B schedules in one batch).
    amplitude_deg, frequency_hz : φ₀ [deg] and f [Hz] of the kinematic excitation (its rates are exact).
    coefficients : Table 1's layout, replacing the mixture's damper law; outputs : rig outputs.

    Returns
    -------
    ``(B, T, len(outputs))`` numpy array (φ₂ [deg] for "x").
    """
    t = np.asarray(t, dtype=np.float64)
    P = np.atleast_2d(np.asarray(pressure_mpa, dtype=np.float64))
    if t.ndim != 1 or P.shape[1] != len(t):
        raise ValueError(f"pressure_mpa has {P.shape[1]} samples per row but t has shape {t.shape}")
    w = 2 * np.pi * float(frequency_hz)
    phi1 = float(amplitude_deg) * np.stack([np.sin(w * t), w * np.cos(w * t), -w * w * np.sin(w * t)], axis=-1)
    U = torch.as_tensor(np.broadcast_to(phi1, (len(P), len(t), 3)).copy())
    model = vpptd_rig(mixture, outputs=outputs, coefficients=coefficients).double()
    with torch.no_grad():
        y = simulate(model, U, t=t, conditions={CONDITION: torch.as_tensor(P)}, backend=backend)
    return y.double().numpy()
