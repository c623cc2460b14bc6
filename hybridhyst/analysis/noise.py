"""The measurement noise of records, estimated from the data alone (no model).

``noise_sd`` takes the second differences of each record's response, y[k+1] − 2 y[k] + y[k−1]: for white noise
of standard deviation σ their variance is 6σ², while a response sampled finely enough contributes little, and
its jumps (a friction reversal) are few. A robust scale (1.4826 × the median absolute deviation) of the pooled
differences, over √6, is the estimate. It is biased low for noise correlated from sample to sample (AR(1)
noise with lag-1 correlation φ: by the factor √(1 − 4φ/3 + φ²/3), 0.26 at φ = 0.9) and high for a response
sampled so coarsely that its own curvature shows (fewer than about 30 samples per cycle): a rule that uses it
should be harmless when it is too low.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["noise_sd"]

MAD_TO_SD = 1.4826  # the standard deviation of a Gaussian per unit of median absolute deviation


def noise_sd(responses: Sequence[np.ndarray]) -> float | None:
    """Estimated noise standard deviation of the responses (module docstring); None with fewer than 8 second
    differences in all."""
    d = [np.diff(np.asarray(y, dtype=float), 2) for y in responses if len(y) >= 3]
    d = np.concatenate(d) if d else np.zeros(0)
    d = d[np.isfinite(d)]
    if d.size < 8:
        return None
    return float(MAD_TO_SD * np.median(np.abs(d - np.median(d))) / math.sqrt(6.0))
