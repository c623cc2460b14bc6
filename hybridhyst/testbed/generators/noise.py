"""Measurement noise of the first bed: white Gaussian and stationary AR(1) noise with a stated marginal standard
deviation."""

from __future__ import annotations

import math

import numpy as np


def white_noise(n: int, sd: float, rng: np.random.Generator) -> np.ndarray:
    """Independent Gaussian samples of standard deviation ``sd``."""
    return sd * rng.standard_normal(n)


def ar1_noise(n: int, sd: float, phi: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary AR(1) noise e_k = φ e_{k−1} + √(1 − φ²) sd w_k (marginal sd ``sd``, lag-1 correlation φ)."""
    if not -1 < phi < 1:
        raise ValueError(f"AR(1) coefficient must lie in (-1, 1), got {phi}")
    w = rng.standard_normal(n)
    e = np.empty(n)
    e[0] = sd * w[0]
    c = math.sqrt(1 - phi * phi) * sd
    for k in range(1, n):
        e[k] = phi * e[k - 1] + c * w[k]
    return e
