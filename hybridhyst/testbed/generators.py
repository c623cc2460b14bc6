"""Physics of the discovery test bed, written independently of the library (numpy and scipy only).

Nothing here imports ``hybridhyst``: the laws are re-derived from their textbook statements and computed
with numerics the library does not use, so that the discovery loop is judged on data it did not make:

* input signals are analytic (sums of sines with an optional smooth fade-in; x, ẋ, ẍ in closed form)
  and held at rest before t = 0;
* sign functions are exact (``np.sign``) or smoothed by arctan, erf or v/√(v² + δ²), never tanh;
* the play operator is the exact discrete one, y_k = clamp(y_{k-1}, x_k − r, x_k + r), on an input
  refined many times between samples;
* Dahl friction is integrated exactly in displacement (it is rate-independent: piecewise exponential),
  also behind a clearance (a gap in series: the increment split where the gap opens or closes), and so is
  Bouc–Wen with n = 2 (piecewise tanh / tan, split where the state crosses 0);
* control channels (a coil voltage, an underpressure schedule) are ``Schedule`` signals, exactly linear between
  their breakpoints (slewed staircases, ramps); a first-order lag of one is ``linear_lag`` (exact for them);
* Maxwell elements and other linear lags use an exact exponential integrator (first-order hold);
* other states (LuGre, Bouc–Wen, oscillators) use ``scipy.integrate.solve_ivp`` (LSODA, Radau or
  DOP853 with tight tolerances and a step limit of a tenth of the sample interval), or ``heun``, a
  fixed-step second-order scheme on a grid refined between the samples;
* noise is white or AR(1) (coloured) with a stated marginal standard deviation.

Units are whatever the caller uses consistently; every law returns arrays of the shape of its inputs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import erf

__all__ = [
    "Schedule", "Sines", "ar1_noise", "bouc_wen_n2", "bouc_wen_yield", "clearance_dahl", "cogging", "cumulative_travel",
    "dahl_exact", "fine_grid", "heun", "integrate", "linear_lag", "lugre", "maxwell_force", "mr_damper", "multisine",
    "oscillator", "play", "play_rate", "ramp", "random_motion", "sgn", "sine", "staircase", "stribeck_curve",
    "white_noise",
]


# -- input signals -----------------------------------------------------------------------------------------


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


# -- sign functions and static laws ------------------------------------------------------------------------


def sgn(v, kind: str = "exact", width: float = 0.0) -> np.ndarray:
    """The sign of v: "exact" (np.sign, with |v| below 1e-9 of its largest value counted as 0, so that a
    sample on a reversal is 0 and not a rounding accident), "arctan" (2/π) arctan(v/δ), "erf" erf(v/δ), or
    "algebraic" v / √(v² + δ²) with δ = ``width``."""
    v = np.asarray(v, float)
    if kind == "exact":
        tiny = 1e-9 * (np.max(np.abs(v)) if v.size else 0.0)
        return np.where(np.abs(v) <= tiny, 0.0, np.sign(v))
    if width <= 0:
        raise ValueError(f"a smoothed sign ({kind!r}) needs a positive width, got {width}")
    if kind == "arctan":
        return (2.0 / math.pi) * np.arctan(v / width)
    if kind == "erf":
        return erf(v / width)
    if kind == "algebraic":
        return v / np.sqrt(v * v + width * width)
    raise ValueError(f"unknown sign kind {kind!r}; choose exact, arctan, erf or algebraic")


def stribeck_curve(v, Fc: float, Fs: float, vs: float, shape: float = 2.0) -> np.ndarray:
    """Sliding level g(v) = Fc + (Fs − Fc) exp(−|v / vs|^shape) (≥ 0, even in v)."""
    return Fc + (Fs - Fc) * np.exp(-np.abs(np.asarray(v, float) / vs) ** shape)


def cogging(x, amplitude: float, period: float, phase: float = 0.0) -> np.ndarray:
    """A position-periodic force A sin(2π x / p + φ) (detent / cogging of a geared or magnetic drive)."""
    return amplitude * np.sin(2 * math.pi * np.asarray(x, float) / period + phase)


# -- input operators and path-dependent states ---------------------------------------------------------------


def play(x, r: float, y0: float | None = None) -> np.ndarray:
    """The exact discrete play (backlash) operator of half-width r: y_k = min(max(y_{k−1}, x_k − r), x_k + r),
    starting at y0 (default x_0, the play centred on the initial input). Apply it on a refined input."""
    x = np.asarray(x, float)
    y = np.empty_like(x)
    prev = x[0] if y0 is None else float(y0)
    for k, xk in enumerate(x):
        prev = min(max(prev, xk - r), xk + r)
        y[k] = prev
    return y


def play_rate(x, v, y, r: float) -> np.ndarray:
    """ẏ of the play output: v where the gap is closed in the direction of motion, else 0."""
    x, v, y = (np.asarray(a, float) for a in (x, v, y))
    gap = x - y
    engaged = (np.abs(gap) >= r * (1 - 1e-9) - 1e-15) & (v * gap > 0)
    return np.where(engaged, v, 0.0)


def dahl_exact(x, sigma0: float, Fc: float, z0: float = 0.0) -> np.ndarray:
    """Dahl's bristle deflection z along a displacement path, exactly between consecutive points.

    ż = v − σ0 |v| z / Fc is rate-independent: along a monotone step of length Δx in direction s,
    z ← s Fc/σ0 + (z − s Fc/σ0) exp(−σ0 |Δx| / Fc). The force is σ0 z. Use a refined path (reversals
    inside a step are then negligible)."""
    x = np.asarray(x, float)
    z = np.empty_like(x)
    z[0] = prev = float(z0)
    level = Fc / sigma0
    decay = np.exp(-np.abs(np.diff(x)) / level)
    steps = np.sign(np.diff(x))
    for k in range(1, len(x)):
        target = steps[k - 1] * level
        prev = target + (prev - target) * decay[k - 1]
        z[k] = prev
    return z


def _riccati(w: float, d: float, a: float) -> float:
    """w after a travel d of dw/dd = 1 − a w² (a constant), from w."""
    if a > 0:
        r = math.sqrt(a)
        return math.tanh(r * d + math.atanh(min(max(r * w, -1 + 1e-15), 1 - 1e-15))) / r
    if a < 0:
        r = math.sqrt(-a)
        return math.tan(r * d + math.atan(r * w)) / r
    return w + d


def bouc_wen_n2(x, beta: float, gamma: float, z0: float = 0.0) -> np.ndarray:
    """The Bouc–Wen state z with n = 2 and A = 1 along a displacement path, exactly between consecutive points.

    ż = ẋ − β |ẋ| z|z| − γ ẋ z² is rate-independent. Along a monotone step of length d in direction s, w = s z
    obeys dw/dd = 1 − (γ + β sgn w) w², a Riccati equation with a constant coefficient a on either side of w = 0:
    w = tanh(√a d + artanh(√a w0)) / √a for a > 0, tan(√−a d + arctan(√−a w0)) / √−a for a < 0, w0 + d for
    a = 0. A step that starts with w < 0 (the state against the motion: unloading) is split where w reaches 0
    (a travel −artanh(√a w0)/√a, −arctan(√−a w0)/√−a or −w0 with a = γ − β). Saturation |z| → 1/√(β + γ).
    Use a refined path (reversals inside a step are then negligible)."""
    x = np.asarray(x, float)
    z = np.empty_like(x)
    z[0] = prev = float(z0)
    up, down = gamma + beta, gamma - beta
    for k in range(1, len(x)):
        step = x[k] - x[k - 1]
        if step == 0.0:
            z[k] = prev
            continue
        s = 1.0 if step > 0 else -1.0
        d, w = abs(step), s * prev
        if w < 0:
            if down > 0:
                r = math.sqrt(down)
                to_zero = -math.atanh(max(r * w, -1 + 1e-15)) / r
            elif down < 0:
                r = math.sqrt(-down)
                to_zero = -math.atan(r * w) / r
            else:
                to_zero = -w
            if d < to_zero:
                w, d = _riccati(w, d, down), 0.0
            else:
                w, d = 0.0, d - to_zero
        if d > 0:
            w = _riccati(w, d, up)
        prev = s * w
        z[k] = prev
    return z


def clearance_dahl(x_fine, r: float, sigma0: float, Fc_pos: float, Fc_neg: float,
                   q0: float = 0.0) -> np.ndarray:
    """Force of a Dahl friction element driven through a clearance (a gap of half-width r in series), exactly
    along a displacement path (apply it on a refined one: reversals inside a step are then negligible).

    The state q is the gap opening plus the bristle deflection, q = ``q0`` at the first point (0: the gap
    centred, no load; −(r + Fc_neg / σ0): closed on the negative side and fully deflected, as a motion
    down to the first point leaves it); the force is σ0 (q − clamp(q, −r, r)). Along a monotone step of
    direction s (±1), with the level Fc_s of that direction (``Fc_pos`` for s = +1, ``Fc_neg`` for s = −1)
    and ℓ = Fc_s / σ0:

    * gap closed behind the motion (s q < −r, force against the motion): the deflection z = q + s r relaxes
      towards s ℓ, z ← s ℓ + (z − s ℓ) e^(−σ0 |Δx| / Fc_s), until z = 0 (after a travel ℓ ln(1 + |z| / ℓ)):
      the gap opens;
    * gap open (|q| ≤ r, no force): q moves with x until s q = r (a travel r − s q): the gap closes;
    * gap closed ahead (s q ≥ r): the deflection z = q − s r relaxes as above towards s ℓ (it never
      crosses 0 in this direction).

    A step that reaches a boundary is split there, so every step is exact. The force saturates at
    ``Fc_pos`` going up and at −``Fc_neg`` going down; after a reversal it unloads along Dahl's curve,
    stays exactly 0 while the input crosses the gap (a travel of 2r) and then loads the other way."""
    x = np.asarray(x_fine, float)
    q = float(q0)
    force = np.full_like(x, sigma0 * (q - min(max(q, -r), r)))
    for k in range(1, len(x)):
        step = x[k] - x[k - 1]
        if step == 0.0:
            force[k] = force[k - 1]
            continue
        s = 1.0 if step > 0 else -1.0
        ell = (Fc_pos if s > 0 else Fc_neg) / sigma0
        rest = abs(step)
        while rest > 0.0:
            if s * q < -r:  # still pushing against the motion: unload towards s ℓ
                z = q + s * r
                to_open = ell * math.log1p(abs(z) / ell)
                if rest < to_open:
                    z = s * ell + (z - s * ell) * math.exp(-rest / ell)
                    q, rest = z - s * r, 0.0
                else:
                    q, rest = -s * r, rest - to_open
            elif s * q < r:  # in the gap: no force, q follows x
                to_close = r - s * q
                if rest < to_close:
                    q, rest = q + s * rest, 0.0
                else:
                    q, rest = s * r, rest - to_close
            else:  # gap closed ahead: Dahl
                z = q - s * r
                z = s * ell + (z - s * ell) * math.exp(-rest / ell)
                q, rest = z + s * r, 0.0
        force[k] = sigma0 * (q - min(max(q, -r), r))
    return force


def cumulative_travel(x) -> np.ndarray:
    """s_k = Σ_{j ≤ k} |x_j − x_{j−1}|, the distance travelled since the start (exact for a monotone path
    between the points)."""
    x = np.asarray(x, float)
    return np.r_[0.0, np.cumsum(np.abs(np.diff(x)))]


def linear_lag(t, u, rate: float, y0: float = 0.0) -> np.ndarray:
    """y' = −λ y + u(t) integrated exactly for u linear between the points of ``t`` (first-order hold)."""
    t, u = np.asarray(t, float), np.asarray(u, float)
    lam = float(rate)
    y = np.empty_like(u)
    y[0] = prev = float(y0)
    for k in range(1, len(t)):
        h = t[k] - t[k - 1]
        e = math.exp(-lam * h)
        slope = (u[k] - u[k - 1]) / h
        # exact: y(h) = e y0 + ∫_0^h e^{−λ(h−s)} (u0 + slope s) ds
        i0 = (1 - e) / lam
        i1 = (h - i0) / lam
        prev = e * prev + u[k - 1] * i0 + slope * i1
        y[k] = prev
    return y


def maxwell_force(t, v, stiffness: float, damping: float) -> np.ndarray:
    """Force of a Maxwell element (spring k_m in series with a dashpot c_m) along a velocity history:
    Ḟ = k_m v − (k_m / c_m) F, F(0) = 0, by the exact exponential integrator."""
    v = np.asarray(v, float)
    return linear_lag(t, stiffness * v, stiffness / damping)


# -- ordinary differential equations ---------------------------------------------------------------------------


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


# -- noise -------------------------------------------------------------------------------------------------------


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
