"""Input signals of the first bed: ``Sines`` (sums of sines with an optional smooth fade-in, held at rest before
t = 0; x, ẋ, ẍ in closed form) and its makers ``sine``, ``multisine``, ``random_motion``; control channels as
``Schedule`` signals, exactly linear between breakpoints (``staircase``, ``ramp``); ``fine_grid``, a refined sample
grid for the path operators."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Sines:
    """x(t) = w(t) · Σ_i A_i sin(2π f_i t + φ_i) for t ≥ 0, held at x(0) (at rest) for t < 0.

    ``fade`` > 0 multiplies the sum by the smoothstep window w = 10 s³ − 15 s⁴ + 6 s⁵, s = t / fade, for
    t < fade (w = 1 after; w' = w'' = 0 at both ends), so the signal starts from rest with x = ẋ = ẍ = 0.
    Velocity and acceleration are exact.
    """

    amplitudes: tuple[float, ...]
    frequencies: tuple[float, ...]
    phases: tuple[float, ...] = ()
    fade: float = 0.0

    def _parts(self, t: np.ndarray, order: int) -> np.ndarray:
        t = np.asarray(t, float)
        phases = self.phases or (0.0,) * len(self.amplitudes)
        out = np.zeros_like(t)
        for a, f, p in zip(self.amplitudes, self.frequencies, phases):
            w = 2 * math.pi * f
            arg = w * np.clip(t, 0.0, None) + p
            out += a * w**order * (np.sin, np.cos, lambda z: -np.sin(z))[order](arg)
        return out

    def _window(self, t: np.ndarray):
        t = np.clip(np.asarray(t, float), 0.0, None)
        if self.fade <= 0:
            one = np.ones_like(t)
            return one, 0 * one, 0 * one
        s = np.clip(t / self.fade, 0.0, 1.0)
        w = s**3 * (10 - 15 * s + 6 * s**2)
        dw = 30 * s**2 * (1 - s) ** 2 / self.fade
        ddw = 60 * s * (1 - s) * (1 - 2 * s) / self.fade**2
        return w, dw, ddw

    def x(self, t) -> np.ndarray:
        w, _, _ = self._window(t)  # the signal is held at x(0) before 0 (_parts and _window clip t at 0)
        return w * self._parts(t, 0)

    def v(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        w, dw, _ = self._window(t)
        return np.where(t < 0, 0.0, dw * self._parts(t, 0) + w * self._parts(t, 1))

    def a(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        w, dw, ddw = self._window(t)
        return np.where(t < 0, 0.0, ddw * self._parts(t, 0) + 2 * dw * self._parts(t, 1) + w * self._parts(t, 2))


def sine(amplitude: float, frequency: float, fade: float = 0.0, phase: float = 0.0) -> Sines:
    """A sine test x = A sin(2π f t + φ): from x = 0 at full speed (φ = 0), from rest at an end of the
    stroke (φ = −π/2: x = −A cos 2π f t), or from rest at 0 with ``fade``."""
    return Sines((float(amplitude),), (float(frequency),), (float(phase),), float(fade))


def multisine(rms: float, frequencies: Sequence[float], seed: int, fade: float = 0.0) -> Sines:
    """Equal-amplitude lines at ``frequencies`` with random (Schroeder-free, seeded) phases, scaled to ``rms``
    (the rms of the steady part: A = rms · √(2 / n))."""
    rng = np.random.default_rng(seed)
    n = len(frequencies)
    amp = rms * math.sqrt(2.0 / n)
    return Sines((amp,) * n, tuple(float(f) for f in frequencies), tuple(rng.uniform(0, 2 * math.pi, n)),
                 float(fade))


def random_motion(peak: float, f_lo: float, f_hi: float, lines: int, seed: int, duration: float,
                  fade: float = 0.25) -> Sines:
    """Band-limited random displacement: ``lines`` sines at frequencies drawn uniformly in [f_lo, f_hi], amplitudes
    uniform in [0.5, 1] (relative), phases uniform, faded in from rest over ``fade`` s, scaled so that the largest
    |x| over [0, ``duration``] is ``peak``. Velocity and acceleration are exact (``Sines``)."""
    rng = np.random.default_rng(seed)
    freqs = np.sort(rng.uniform(f_lo, f_hi, lines))
    amps = rng.uniform(0.5, 1.0, lines)
    phases = rng.uniform(0, 2 * math.pi, lines)
    raw = Sines(tuple(amps), tuple(freqs), tuple(phases), float(fade))
    top = float(np.max(np.abs(raw.x(np.linspace(0.0, duration, int(duration * 2000) + 1)))))
    return Sines(tuple(amps * peak / top), tuple(freqs), tuple(phases), float(fade))


@dataclass(frozen=True)
class Schedule:
    """A control signal c(t) (a coil voltage, an underpressure), exactly linear between its breakpoints ``times``
    (increasing) with ``values``, and held at the first and last value outside them. A slewed staircase or a ramp;
    a record samples it, and where no corner falls between two samples the samples' linear interpolation is it."""

    times: tuple[float, ...]
    values: tuple[float, ...]

    def __call__(self, t) -> np.ndarray:
        return np.interp(np.asarray(t, float), self.times, self.values)


def staircase(duration: float, low: float, high: float, seed: int, hold: tuple[float, float] = (0.3, 0.8),
              slew: float = 0.005, min_step: float = 0.3) -> Schedule:
    """A random staircase on [0, ``duration``]: levels drawn uniformly in [low, high] (each at least ``min_step``
    from the one before), each held a time drawn uniformly in ``hold``, changed by a linear ramp of ``slew`` s (an
    amplifier's finite slew rate; the ramps start at arbitrary times, not on any sample grid)."""
    if high - low <= 2 * min_step:
        raise ValueError(f"staircase: the range [{low}, {high}] must be wider than twice min_step {min_step}")
    rng = np.random.default_rng(seed)
    level = float(rng.uniform(low, high))
    times, values, t = [0.0], [level], 0.0
    while True:
        t += float(rng.uniform(*hold))
        if t + slew >= duration:
            break
        new = level
        while abs(new - level) < min_step:
            new = float(rng.uniform(low, high))
        times += [t, t + slew]
        values += [level, new]
        level, t = new, t + slew
    times.append(float(duration))
    values.append(level)
    return Schedule(tuple(times), tuple(values))


def ramp(duration: float, start: float, end: float, lead: float = 0.0) -> Schedule:
    """``start`` held for ``lead`` s, a linear ramp to ``end`` until ``duration − lead``, then held."""
    return Schedule((0.0, float(lead), float(duration - lead), float(duration)),
                    (float(start), float(start), float(end), float(end)))


def fine_grid(t: np.ndarray, refine: int) -> np.ndarray:
    """Every interval of the sample times ``t`` split into ``refine`` equal steps; t[k] = result[k * refine]."""
    t = np.asarray(t, float)
    if refine < 1:
        raise ValueError(f"refine must be >= 1, got {refine}")
    frac = np.arange(refine) / refine
    inner = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    return np.r_[inner, t[-1]]
