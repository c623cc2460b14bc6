"""Free-vibration frequency of a decaying response (seed 001, Table 2): FFT and turning points."""

from __future__ import annotations

import numpy as np


def turning_points(x, dt: float) -> np.ndarray:
    """Times [s] where the velocity of ``x`` changes sign (extrema of the response)."""
    x = np.asarray(x, dtype=np.float64)
    s = np.sign(np.diff(x))
    idx = np.flatnonzero(s[1:] * s[:-1] < 0) + 1
    return idx * float(dt)


def free_vibration_frequency(x, dt: float, method: str = "fft", pad: int = 16) -> float:
    """Characteristic frequency [Hz] of a free response ``x`` sampled every ``dt`` seconds.

    ``method="fft"``: the peak of the zero-padded spectrum of x about its rest position (the last
    sample; friction can leave the mass off zero). ``method="turning_points"``: half the number of
    half-periods per second between the first and last turning point of the moving part.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or len(x) < 8:
        raise ValueError(f"free_vibration_frequency needs a 1-D response of at least 8 samples, got shape {x.shape}")
    if method == "fft":
        n = int(2 ** np.ceil(np.log2(len(x) * pad)))
        spectrum = np.abs(np.fft.rfft(x - x[-1], n=n))
        freqs = np.fft.rfftfreq(n, dt)
        return float(freqs[1 + np.argmax(spectrum[1:])])
    if method == "turning_points":
        tp = turning_points(x, dt)
        if len(tp) < 2:
            raise ValueError("the response has fewer than two turning points; simulate longer or excite more")
        return float((len(tp) - 1) / 2.0 / (tp[-1] - tp[0]))
    raise ValueError(f"unknown method {method!r}; use 'fft' or 'turning_points'")
