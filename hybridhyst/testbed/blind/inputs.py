"""Input signals of the blind cases: sines from rest at -A, cos-sums, and tapered (raised-cosine faded)
multisines with their analytic velocities; ``_ms_design`` draws a multisine's tones and phases from a seed."""

import math

import numpy as np

from .operators import TWO_PI


def sine_input(A, f, cycles, spc, refine=1):
    """x = -A cos(2 pi f t), whole cycles, endpoint included; returns t, x, v
    on a grid with spc*refine points per cycle."""
    n = int(cycles * spc * refine)
    t = np.arange(n + 1) / (f * spc * refine)
    w = TWO_PI * f
    v = A * w * np.sin(w * t)
    npc = int(spc * refine)
    v[(2 * np.arange(n + 1)) % npc == 0] = 0.0  # turning points: velocity exactly 0
    return t, -A * np.cos(w * t), v


def cos_sum(t, amps, freqs):
    """x = -sum a_i cos(2 pi f_i t) (starts from rest at -sum a_i); returns x, v."""
    t = np.asarray(t, float)
    x = np.zeros_like(t)
    v = np.zeros_like(t)
    for a, f in zip(amps, freqs):
        w = TWO_PI * f
        x -= a * np.cos(w * t)
        v += a * w * np.sin(w * t)
    return x, v


def _taper(t, T, ramp):
    w = np.ones_like(t)
    dw = np.zeros_like(t)
    m1 = t < ramp
    w[m1] = 0.5 * (1.0 - np.cos(math.pi * t[m1] / ramp))
    dw[m1] = 0.5 * math.pi / ramp * np.sin(math.pi * t[m1] / ramp)
    m2 = t > T - ramp
    tr = T - t[m2]
    w[m2] = 0.5 * (1.0 - np.cos(math.pi * tr / ramp))
    dw[m2] = -0.5 * math.pi / ramp * np.sin(math.pi * tr / ramp)
    return w, dw


def tapered_multisine(t, amps, freqs, phases, T, ramp):
    """x = w(t) sum a_i sin(2 pi f_i t + phi_i), raised-cosine fade in/out of
    length ramp at both ends of [0, T]; returns x, v (analytic)."""
    t = np.asarray(t, float)
    s = np.zeros_like(t)
    ds = np.zeros_like(t)
    for a, f, ph in zip(amps, freqs, phases):
        w = TWO_PI * f
        s += a * np.sin(w * t + ph)
        ds += a * w * np.cos(w * t + ph)
    wt, dwt = _taper(t, T, ramp)
    return wt * s, dwt * s + wt * ds


def _ms_design(seed, fmin, fmax, ntones, corner=None):
    rng = np.random.default_rng(seed)
    freqs = np.linspace(fmin, fmax, ntones)
    amps = np.ones(ntones)
    if corner is not None:
        amps = 1.0 / np.sqrt(1.0 + (freqs / corner) ** 4)
    phases = rng.uniform(0.0, TWO_PI, ntones)
    return amps, freqs, phases
