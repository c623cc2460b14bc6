"""Shared pieces of the blind2 generators: the case record, analytic input signals, noise and record assembly."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

EFFECT_WORDS = (
    "play",
    "stribeck",
    "travel_stiffness",
    "travel_friction",
    "drift",
    "asymmetry",
    "relaxation",
    "hysteretic",
    "outside",
)

TWO_PI = 2.0 * math.pi


@dataclass
class BlindCase:
    """One blind test case: an experiment on a simulated device, with its declared nominal law."""

    name: str
    effects: tuple[str, ...]
    description: str
    base_law: str
    kind: str
    units: dict
    mass_kg: float | None
    noise_sd: float
    records: list[dict]
    held_out: list[str]
    validation: list[str]
    noise_model: tuple


# ----------------------------------------------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------------------------------------------


def round_sig1(value: float) -> float:
    """Round to one significant digit (what a user who weighed the part would declare)."""
    if value == 0:
        return 0.0
    exponent = math.floor(math.log10(abs(value)))
    return float(round(value, -exponent))


def grid(fs: float, duration: float) -> np.ndarray:
    """Uniform sample times 0, 1/fs, ... covering `duration` seconds (round(fs*duration) samples)."""
    return np.arange(int(round(fs * duration))) / fs


def fine(t: np.ndarray, q: int) -> np.ndarray:
    """A grid q times finer than the uniform grid t, sharing its samples (every q-th point is a sample of t)."""
    dt = t[1] - t[0]
    return t[0] + np.arange((t.size - 1) * q + 1) * (dt / q)


def sine_name(amp: float, freq: float, unit: str) -> str:
    return f"sine_A{amp:g}{unit}_f{freq:g}Hz"


def switched_off(nominal, effects: tuple[str, ...]) -> frozenset:
    """Effects to switch off: False -> none, True -> all the case's effects, word(s) -> those (must be the case's)."""
    if nominal is False or nominal is None:
        return frozenset()
    if nominal is True:
        return frozenset(effects)
    words = {nominal} if isinstance(nominal, str) else set(nominal)
    unknown = words - set(effects)
    if unknown:
        raise ValueError(f"effect(s) {sorted(unknown)} not in this case's effects {effects}")
    return frozenset(words)


def record(name: str, t, x, y, **conditions) -> dict:
    return {
        "name": name,
        "t": np.asarray(t, dtype=float),
        "x": np.asarray(x, dtype=float),
        "y": np.asarray(y, dtype=float),
        "conditions": {k: float(v) for k, v in conditions.items()},
    }


# ----------------------------------------------------------------------------------------------------------------------
# Analytic input signals: x(t) and its exact derivative v(t)
# ----------------------------------------------------------------------------------------------------------------------


class Sine:
    def __init__(self, amp: float, freq: float, phase: float = 0.0):
        self.amp, self.freq, self.phase = float(amp), float(freq), float(phase)

    def x(self, t):
        return self.amp * np.sin(TWO_PI * self.freq * t + self.phase)

    def v(self, t):
        return self.amp * TWO_PI * self.freq * np.cos(TWO_PI * self.freq * t + self.phase)


class Decaying:
    """A * exp(-t/tau) * sin(2 pi f t): an amplitude-decaying sine (first-order-reversal style)."""

    def __init__(self, amp: float, freq: float, tau: float):
        self.amp, self.freq, self.tau = float(amp), float(freq), float(tau)

    def x(self, t):
        return self.amp * np.exp(-t / self.tau) * np.sin(TWO_PI * self.freq * t)

    def v(self, t):
        w = TWO_PI * self.freq
        return self.amp * np.exp(-t / self.tau) * (w * np.cos(w * t) - np.sin(w * t) / self.tau)


class Multisine:
    """Sum of sines with equal amplitudes and random (seeded) phases, scaled to a target RMS; raised-cosine fade-in."""

    def __init__(self, f_lo: float, f_hi: float, n_tones: int, rms: float, seed: int, fade: float = 0.0):
        rng = np.random.default_rng(seed)
        self.freqs = np.linspace(f_lo, f_hi, n_tones)
        self.amps = np.full(n_tones, rms * math.sqrt(2.0 / n_tones))
        self.phases = rng.uniform(0.0, TWO_PI, n_tones)
        self.fade = float(fade)
        self.rms = float(rms)

    def _raw(self, t):
        arg = TWO_PI * np.outer(self.freqs, t) + self.phases[:, None]
        x = self.amps @ np.sin(arg)
        v = (self.amps * TWO_PI * self.freqs) @ np.cos(arg)
        return x, v

    def _env(self, t):
        if self.fade <= 0:
            return np.ones_like(t), np.zeros_like(t)
        inside = t < self.fade
        e = np.where(inside, 0.5 * (1.0 - np.cos(math.pi * t / self.fade)), 1.0)
        de = np.where(inside, 0.5 * math.pi / self.fade * np.sin(math.pi * t / self.fade), 0.0)
        return e, de

    def x(self, t):
        t = np.asarray(t, dtype=float)
        return self._raw(t)[0] * self._env(t)[0]

    def v(self, t):
        t = np.asarray(t, dtype=float)
        x, v = self._raw(t)
        e, de = self._env(t)
        return v * e + x * de


class Chirp:
    """Linear swept sine A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))."""

    def __init__(self, amp: float, f0: float, f1: float, duration: float):
        self.amp, self.f0, self.f1, self.duration = float(amp), float(f0), float(f1), float(duration)

    def _phase(self, t):
        return TWO_PI * (self.f0 * t + (self.f1 - self.f0) * t**2 / (2.0 * self.duration))

    def x(self, t):
        return self.amp * np.sin(self._phase(t))

    def v(self, t):
        return self.amp * np.cos(self._phase(t)) * TWO_PI * (self.f0 + (self.f1 - self.f0) * t / self.duration)


class RampHold:
    """Half-cosine ramp from 0 to `level` in `t_ramp` seconds, then held."""

    def __init__(self, level: float, t_ramp: float):
        self.level, self.t_ramp = float(level), float(t_ramp)

    def x(self, t):
        t = np.asarray(t, dtype=float)
        return np.where(t < self.t_ramp, 0.5 * self.level * (1.0 - np.cos(math.pi * t / self.t_ramp)), self.level)

    def v(self, t):
        t = np.asarray(t, dtype=float)
        rate = 0.5 * self.level * math.pi / self.t_ramp
        return np.where(t < self.t_ramp, rate * np.sin(math.pi * t / self.t_ramp), 0.0)


# ----------------------------------------------------------------------------------------------------------------------
# Noise
# ----------------------------------------------------------------------------------------------------------------------


def unit_noise(rng: np.random.Generator, n: int, model: tuple) -> np.ndarray:
    """Stationary noise of unit marginal variance for a noise-model tag."""
    tag = model[0]
    if tag == "white":
        return rng.standard_normal(n)
    if tag == "ar1":
        phi = float(model[1])
        w = rng.standard_normal(n)
        s = math.sqrt(1.0 - phi * phi)
        # e_0 = w_0 (stationary start), e_k = phi e_{k-1} + s w_k
        return sps.lfilter([s], [1.0, -phi], w, zi=[(1.0 - s) * w[0]])[0]
    if tag == "lowpass":
        order, cutoff = int(model[1]), float(model[2])
        b, a = sps.butter(order, cutoff)
        burn = 4000
        e = sps.lfilter(b, a, rng.standard_normal(n + burn))[burn:]
        impulse = np.zeros(16384)
        impulse[0] = 1.0
        h = sps.lfilter(b, a, impulse)
        return e / math.sqrt(float(np.sum(h * h)))
    raise ValueError(f"unknown noise model {model!r}")


def describe_noise(model: tuple) -> str:
    tag = model[0]
    if tag == "white":
        return "white Gaussian"
    if tag == "ar1":
        return f"Gaussian AR(1), e_k = {model[1]} e_(k-1) + sqrt(1 - {model[1]}^2) w_k, stationary start"
    if tag == "lowpass":
        return (
            f"white Gaussian passed through a causal order-{model[1]} Butterworth low-pass, "
            f"cutoff {model[2]} x Nyquist, 4000-sample burn-in, scaled to unit marginal variance"
        )
    return repr(model)


# ----------------------------------------------------------------------------------------------------------------------
# Assembly
# ----------------------------------------------------------------------------------------------------------------------


def finish(
    *,
    name: str,
    effects: tuple[str, ...],
    off: frozenset,
    law: str,
    params: str,
    integrator: str,
    sampling: str,
    initial: str,
    base_law: str,
    kind: str,
    units: dict,
    mass_kg: float | None,
    noise_sd: float,
    noise_model: tuple,
    records: list[dict],
    held_out: list[str],
    validation: list[str],
    noise: bool,
    seed: int,
) -> BlindCase:
    """Add the case's seeded output noise (drawn identically whether or not it is added) and build the BlindCase."""
    rng = np.random.default_rng(seed)
    lines = []
    for r in records:
        e = unit_noise(rng, r["y"].size, noise_model) * noise_sd
        if noise:
            r["y"] = r["y"] + e
        fs = 1.0 / (r["t"][1] - r["t"][0])
        cond = ", ".join(f"{k}={v:g}" for k, v in r["conditions"].items())
        lines.append(f"  {r['name']}: {r['t'].size} samples at {fs:g} Hz ({cond})")
    desc = "\n".join(
        [
            f"{name} ({kind}; effects: {', '.join(effects) if effects else 'none (clean control)'})",
            f"Law (truth): {law}",
            f"Parameters: {params}",
            f"Declared nominal (base law): {base_law}",
            f"Integrator: {integrator}",
            f"Sampling: {sampling}",
            "Records (in test order):",
            *lines,
            f"Initial state: {initial}",
            f"Noise: additive on y, {describe_noise(noise_model)}, "
            f"marginal sd {noise_sd:g} {units['y']} (seed {seed}).",
            f"Held out: {', '.join(held_out)}.  Validation: {', '.join(validation) if validation else 'none'}.",
        ]
    )
    if off:
        desc += f"\nNOMINAL VARIANT (diagnostics only): effect(s) switched off: {', '.join(sorted(off))}."
    return BlindCase(
        name=name,
        effects=tuple(effects),
        description=desc,
        base_law=base_law,
        kind=kind,
        units=dict(units),
        mass_kg=mass_kg,
        noise_sd=float(noise_sd),
        records=records,
        held_out=list(held_out),
        validation=list(validation),
        noise_model=tuple(noise_model),
    )
