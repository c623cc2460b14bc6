"""Ordinary differential equations of the first bed: ``integrate`` (``solve_ivp`` with a step limit of a fraction
of the sample interval), ``heun`` (fixed-step second order on a refined grid), and the laws solved with them: LuGre,
Bouc-Wen in yield form, a Spencer-type MR damper and a driven oscillator."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

from .signals import Sines
from .static_laws import stribeck_curve


def integrate(rhs: Callable[[float, np.ndarray], np.ndarray], t_out, y0, method: str = "LSODA", rtol: float = 1e-9,
              atol: float = 1e-11, refine: int = 10) -> np.ndarray:
    """solve_ivp from t_out[0] over ``t_out`` with the step limited to (sample interval) / ``refine``; returns
    the states at t_out, shape ``(len(t_out), len(y0))``. Raises RuntimeError when the solver fails."""
    t_out = np.asarray(t_out, float)
    max_step = float(np.min(np.diff(t_out))) / refine
    sol = solve_ivp(rhs, (t_out[0], t_out[-1]), np.asarray(y0, float), method=method, t_eval=t_out, rtol=rtol,
                    atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(f"solve_ivp ({method}) failed: {sol.message}")
    return sol.y.T


def heun(rhs: Callable[[float, np.ndarray], np.ndarray], t_out, y0, refine: int = 20) -> np.ndarray:
    """Heun's method (explicit trapezoid, second order) with ``refine`` steps per sample interval; states at
    t_out, shape ``(len(t_out), len(y0))``."""
    t_out = np.asarray(t_out, float)
    y = np.asarray(y0, float).copy()
    out = np.empty((len(t_out), len(y)))
    out[0] = y
    for k in range(1, len(t_out)):
        t0, h = t_out[k - 1], (t_out[k] - t_out[k - 1]) / refine
        for j in range(refine):
            t = t0 + j * h
            k1 = rhs(t, y)
            k2 = rhs(t + h, y + h * k1)
            y = y + 0.5 * h * (k1 + k2)
        out[k] = y
    return out


def lugre(t, signal: Sines, sigma0: float, sigma1: float, sigma2: float, Fc: float, Fs: float, vs: float,
          method: str = "LSODA") -> np.ndarray:
    """LuGre friction force along the motion ``signal`` (Canudas de Wit et al. 1995):
    ż = v − σ0 |v| z / g(v), F = σ0 z + σ1 ż + σ2 v, g the Stribeck curve, z(0) = 0; solved by ``method``."""

    def dz(tt, z):
        v = float(signal.v(np.array([tt]))[0])
        return np.array([v - sigma0 * abs(v) * z[0] / float(stribeck_curve(v, Fc, Fs, vs))])

    z = integrate(dz, t, [0.0], method=method)[:, 0]
    v = signal.v(t)
    zdot = v - sigma0 * np.abs(v) * z / stribeck_curve(v, Fc, Fs, vs)
    return sigma0 * z + sigma1 * zdot + sigma2 * v


def bouc_wen_yield(t, signal: Sines, Fy: float, xy: float, n: float, b: float, method: str = "LSODA") -> np.ndarray:
    """Bouc–Wen hysteresis in yield form: F = Fy ζ, ζ̇ = (v / xy) [1 − |ζ|^n (b sgn(v ζ) + 1 − b)], ζ(0) = 0.

    Fy is the yield (saturation) force, xy the yield displacement, b ∈ [0, 1] the loop shape (b = 1/2 the
    classic shape). In the (k, β, γ, n) form F = k z, ż = v − β|v||z|^(n−1) z − γ v |z|^n this is
    k = Fy / xy, β = b / xy^n, γ = (1 − b) / xy^n. Monotone loading from rest gives ζ = 1 − e^(−x/xy) at
    n = 1 and ζ = tanh(x / xy) at n = 2."""

    def dzeta(tt, s):
        v = float(signal.v(np.array([tt]))[0])
        z = s[0]
        return np.array([(v / xy) * (1 - abs(z) ** n * (b * np.sign(v * z) + 1 - b))])

    return Fy * integrate(dzeta, t, [0.0], method=method)[:, 0]


def mr_damper(t, amplitude: float, frequency: float, c: float, k: float, kappa: float, beta: float, gamma: float,
              n: float) -> np.ndarray:
    """Force of the Spencer-type MR-damper law under x = A sin(2π f t): F = c ẋ + k x + κ z with
    ż = ẋ − β |ẋ| |z|^(n−1) z − γ ẋ |z|^n, z(0) = 0; the state by ``solve_ivp`` (RK45, rtol 1e-10, 20
    internal steps per sample at most), ẋ in closed form."""
    w = 2 * math.pi * frequency

    def rate(s, z):
        v = amplitude * w * math.cos(w * s)
        return [v - beta * abs(v) * abs(z[0]) ** (n - 1) * z[0] - gamma * v * abs(z[0]) ** n]

    t = np.asarray(t, float)
    z = solve_ivp(rate, (0, t[-1]), [0.0], t_eval=t, rtol=1e-10, atol=1e-12,
                  max_step=float(np.min(np.diff(t))) / 20).y[0]
    return c * amplitude * w * np.cos(w * t) + k * amplitude * np.sin(w * t) + kappa * z


def oscillator(t, drive: Sines, mass: float, damping: float, stiffness: float,
               extra: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
               method: str = "DOP853") -> np.ndarray:
    """Displacement of m ẍ + c ẋ + k x + F_extra(x, ẋ, u) = u(t) from rest, u = ``drive``; solved by
    ``method`` (DOP853 for smooth laws, LSODA or Radau where a smoothed sign makes it stiff)."""

    def rhs(tt, s):
        x, v = s
        u = float(drive.x(np.array([tt]))[0])
        f = damping * v + stiffness * x
        if extra is not None:
            f += float(extra(np.array([x]), np.array([v]), np.array([u]))[0])
        return np.array([v, (u - f) / mass])

    return integrate(rhs, t, [0.0, 0.0], method=method, rtol=1e-10, atol=1e-12)[:, 0]
