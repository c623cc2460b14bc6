"""Free-vibration frequency of a decaying response (seed 001, Table 2): FFT and turning points."""

from __future__ import annotations

import numpy as np


def turning_points(x, dt: float) -> np.ndarray:
    """Times [s] where the velocity of ``x`` changes sign (extrema of the response)."""
    x = np.asarray(x, dtype=np.float64)
    s = np.sign(np.diff(x))
    idx = np.flatnonzero(s[1:] * s[:-1] < 0) + 1
    return idx * float(dt)


def free_vibration_frequency(x, dt: float, method: str = "fft", pad: int = 16, min_swing: float = 0.05) -> float:
    """Characteristic frequency [Hz] of a free response ``x`` sampled every ``dt`` seconds.

    ``method="fft"``: the peak of the zero-padded spectrum of x about its rest position (the last
    sample; friction can leave the mass off zero). ``method="turning_points"``: half the number of
    half-periods per second between the first and last turning point of the moving part: the turning
    points up to the first swing (the change of x between successive turning points) smaller than
    ``min_swing`` times the largest swing. A dry-friction oscillator creeps to rest with tiny wiggles
    that are not oscillation cycles; ``min_swing=0`` counts every turning point.
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
        if not 0.0 <= min_swing < 1.0:
            raise ValueError(f"min_swing is a fraction of the largest swing in [0, 1), got {min_swing}")
        tp = turning_points(x, dt)
        if len(tp) > 2:
            swings = np.abs(np.diff(x[np.rint(tp / dt).astype(int)]))
            small = np.flatnonzero(swings < min_swing * swings.max())
            tp = tp[: small[0] + 1] if len(small) else tp
        if len(tp) < 2:
            raise ValueError("the response has fewer than two turning points; simulate longer or excite more")
        return float((len(tp) - 1) / 2.0 / (tp[-1] - tp[0]))
    raise ValueError(f"unknown method {method!r}; use 'fft' or 'turning_points'")
