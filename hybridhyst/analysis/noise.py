"""The measurement noise of records, estimated from the data alone (no model).

``noise_sd`` takes the k-th differences of each record's response (k = 2, 3, 4): for white noise of standard
deviation σ their variance is C(2k, k) σ² (6, 20, 70 σ²), while a response sampled finely enough contributes
little, the less the higher k, and its jumps (a friction reversal) are few. A robust scale (1.4826 × the median
absolute deviation) of the pooled differences, over √C(2k, k), estimates σ for each k; the smallest of the three
is returned. It is biased low for noise correlated from sample to sample (AR(1) noise with lag-1 correlation φ,
second differences: by √(1 − 4φ/3 + φ²/3), 0.26 at φ = 0.9) and high for a response sampled so coarsely that its
own shape shows even in fourth differences (a sine at fewer than about 15 samples per cycle): a rule that uses it
must be harmless when it is too low, and should cap it by what a fitted model leaves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["autocorrelation", "noise_sd"]

MAD_TO_SD = 1.4826  # the standard deviation of a Gaussian per unit of median absolute deviation


def noise_sd(responses: Sequence[np.ndarray]) -> float | None:
    """Estimated noise standard deviation of the responses (module docstring); None with fewer than 8 fourth
    differences in all."""
    estimates = []
    for k in (2, 3, 4):
        d = [np.diff(np.asarray(y, dtype=float), k) for y in responses if len(y) > k]
        d = np.concatenate(d) if d else np.zeros(0)
        d = d[np.isfinite(d)]
        if d.size < 8:
            return None
        estimates.append(MAD_TO_SD * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(math.comb(2 * k, k)))
    return min(estimates)


def autocorrelation(residual, lags=(1, 5, 20)) -> dict[str, float]:
    """Autocorrelation of a residual (its mean removed) at each lag: ``{"lag_1": ..., "lag_5": ..., "lag_20": ...}``
    (NaN where the residual is shorter than the lag). Near 0 for white noise; an uncertainty computed as if the
    samples were independent is too small where it is not (fewer independent samples than samples)."""
    r = np.asarray(residual, float)
    r = r - r.mean()
    d = float(np.dot(r, r)) or 1.0
    return {f"lag_{k}": float(np.dot(r[:-k], r[k:]) / d) if len(r) > k else math.nan for k in lags}
