"""Measurement noise of the blind cases: white, stationary AR(1) and low-pass (Butterworth, causal, burn-in,
scaled by the filter's exact noise gain) Gaussian noise with a stated marginal sd, and its one-line description."""

import math

import numpy as np
from scipy import signal


def ar1_noise(rng, n, sd, phi):
    """Stationary AR(1) noise with marginal sd ``sd`` and lag-1 correlation phi."""
    w = rng.standard_normal(n)
    e0 = sd * w[0]
    if n == 1:
        return np.array([e0])
    b = sd * math.sqrt(1.0 - phi * phi)
    rest, _ = signal.lfilter([b], [1.0, -phi], w[1:], zi=[phi * e0])
    return np.concatenate([[e0], rest])


_LP_GAIN_CACHE: dict[tuple[int, float], tuple[np.ndarray, float]] = {}


def _lowpass_design(order, wn):
    key = (int(order), float(wn))
    if key not in _LP_GAIN_CACHE:
        sos = signal.butter(order, wn, output="sos")
        imp = np.zeros(200000)
        imp[0] = 1.0
        hresp = signal.sosfilt(sos, imp)
        _LP_GAIN_CACHE[key] = (sos, float(math.sqrt(np.sum(hresp**2))))
    return _LP_GAIN_CACHE[key]


def lowpass_noise(rng, n, sd, order, wn, burn=4000):
    """White noise through a Butterworth low-pass (cut-off wn x Nyquist),
    causal, after a burn-in; scaled by the exact noise gain -> marginal sd."""
    sos, gain = _lowpass_design(order, wn)
    w = rng.standard_normal(n + burn)
    e = signal.sosfilt(sos, w)[burn:]
    return e * (sd / gain)


def make_noise(rng, n, sd, model):
    kind = model[0]
    if kind == "white":
        return sd * rng.standard_normal(n)
    if kind == "ar1":
        return ar1_noise(rng, n, sd, model[1])
    if kind == "lowpass":
        return lowpass_noise(rng, n, sd, model[1], model[2])
    raise ValueError(model)


def _noise_text(model, sd, unit):
    kind = model[0]
    if kind == "white":
        s = "white Gaussian"
    elif kind == "ar1":
        s = f"AR(1) Gaussian, phi = {model[1]:g} (stationary start)"
    else:
        s = (
            f"low-pass Gaussian (white noise through a causal order-{model[1]:d} Butterworth, "
            f"cut-off {model[2]:g} x Nyquist, burn-in discarded)"
        )
    return f"Noise: {s}, marginal sd {sd:g} {unit}, independent per record, added to y only."
