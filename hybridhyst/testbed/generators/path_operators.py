"""Input operators and path-dependent states of the first bed, exact between consecutive points of a (refined)
path: the play operator and its rate, Dahl friction, Bouc-Wen with n = 2, Dahl friction behind a clearance,
cumulative travel; and the exact exponential integrator of a first-order lag (``linear_lag``), of a Maxwell
element and of a spring-dashpot driven through a clearance."""

from __future__ import annotations

import math

import numpy as np


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


def kelvin_behind_play(t, x, v, r: float, stiffness: float, damping: float, z0: float = 0.0) -> np.ndarray:
    """Force of a spring k parallel to a dashpot c (a massless piston z) driven through a pin with clearance ±r
    along a (refined) input path x, v at times t: while |x − z| < r the pin is free, no force acts and the
    piston creeps back, c ż + k z = 0, exactly z ← z e^(−(k/c) h) over a step h; where that leaves |x − z| ≥ r
    the pin is in contact and pushes the piston, z = x ∓ r, F = k z + c ẋ. The piston starts at ``z0`` (at rest).
    """
    t, x, v = (np.asarray(a, float) for a in (t, x, v))
    lam = stiffness / damping
    z = float(z0)
    force = np.zeros_like(x)
    for i in range(len(x)):
        if i:
            z *= math.exp(-lam * (t[i] - t[i - 1]))
        gap = x[i] - z
        if abs(gap) >= r:
            z = x[i] - math.copysign(r, gap)
            force[i] = stiffness * z + damping * v[i]
    return force
