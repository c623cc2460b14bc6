"""Numerical operators and integrators of the blind2 generators (own implementations; numpy/scipy only)."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal as sps


def smooth_sign(v, eps: float):
    """Smoothed sign: tanh(v / eps)."""
    return np.tanh(np.asarray(v, dtype=float) / eps)


def dead_zone(x, g: float):
    """Dead zone of half-width g: 0 inside [-g, g], x -/+ g outside."""
    x = np.asarray(x, dtype=float)
    return x - np.clip(x, -g, g)


def play_operator(x, r: float, z0: float = 0.0) -> np.ndarray:
    """Exact discrete play (backlash) operator of half-width r: z_k = min(max(z_(k-1), x_k - r), x_k + r)."""
    out = []
    z = float(z0)
    for xi in np.asarray(x, dtype=float).tolist():
        if z < xi - r:
            z = xi - r
        elif z > xi + r:
            z = xi + r
        out.append(z)
    return np.array(out)


def stop_operator(x, k: float, f: float, s0: float = 0.0) -> np.ndarray:
    """Jenkins element (spring k in series with a slider of level f), exact on a piecewise-monotone input grid:
    s_k = clip(s_(k-1) + k (x_k - x_(k-1)), -f, f); returns the element force s."""
    xs = np.asarray(x, dtype=float).tolist()
    s = min(max(float(s0), -f), f)
    out = [s]
    for a, b in zip(xs[:-1], xs[1:]):
        s += k * (b - a)
        if s > f:
            s = f
        elif s < -f:
            s = -f
        out.append(s)
    return np.array(out)


def cumulative_travel(x, s0: float = 0.0) -> np.ndarray:
    """Distance travelled so far: s0 + sum |x_k - x_(k-1)| (exact for input monotone between grid points)."""
    x = np.asarray(x, dtype=float)
    return s0 + np.concatenate([[0.0], np.cumsum(np.abs(np.diff(x)))])


def backlash_linkage(x, v, r: float, k: float, c: float, h: float, z0: float = 0.0):
    """Spring k in parallel with a dashpot c (massless piston at z) driven through a pin with clearance +-r.

    Free (pin not in contact): c z' + k z = 0, stepped exactly z <- z exp(-k h / c); if the relaxed piston would
    leave the clearance, it is put back on the contact (z = x -+ r) and follows the pin (z' = v).  The transmitted
    force is k z + c z': 0 while free, k z + c v in contact.  Returns (z, F) on the grid of x (step h)."""
    decay = math.exp(-k * h / c)
    zs, fs_ = [], []
    z = float(z0)
    first = True
    for xi, vi in zip(np.asarray(x, dtype=float).tolist(), np.asarray(v, dtype=float).tolist()):
        zf = z if first else z * decay
        first = False
        if xi - zf >= r:
            z = xi - r
            f = k * z + c * vi
        elif xi - zf <= -r:
            z = xi + r
            f = k * z + c * vi
        else:
            z = zf
            f = 0.0
        zs.append(z)
        fs_.append(f)
    return np.array(zs), np.array(fs_)


def _rk4_step(f, s, h, u0, um, u1):
    """One classical RK4 step (generic state length)."""
    h2 = 0.5 * h
    k1 = f(s, u0)
    k2 = f([a + h2 * b for a, b in zip(s, k1)], um)
    k3 = f([a + h2 * b for a, b in zip(s, k2)], um)
    k4 = f([a + h * b for a, b in zip(s, k3)], u1)
    h6 = h / 6.0
    return [a + h6 * (b1 + 2.0 * (b2 + b3) + b4) for a, b1, b2, b3, b4 in zip(s, k1, k2, k3, k4)]


def _rk4_step2(f, s, h, u0, um, u1):
    """The same step written out for a state of length 2 (speed only)."""
    h2 = 0.5 * h
    x, y = s
    a1, b1 = f(s, u0)
    a2, b2 = f([x + h2 * a1, y + h2 * b1], um)
    a3, b3 = f([x + h2 * a2, y + h2 * b2], um)
    a4, b4 = f([x + h * a3, y + h * b3], u1)
    h6 = h / 6.0
    return [x + h6 * (a1 + 2.0 * (a2 + a3) + a4), y + h6 * (b1 + 2.0 * (b2 + b3) + b4)]


def _rk4_step3(f, s, h, u0, um, u1):
    """The same step written out for a state of length 3 (speed only)."""
    h2 = 0.5 * h
    x, y, z = s
    a1, b1, c1 = f(s, u0)
    a2, b2, c2 = f([x + h2 * a1, y + h2 * b1, z + h2 * c1], um)
    a3, b3, c3 = f([x + h2 * a2, y + h2 * b2, z + h2 * c2], um)
    a4, b4, c4 = f([x + h * a3, y + h * b3, z + h * c3], u1)
    h6 = h / 6.0
    return [
        x + h6 * (a1 + 2.0 * (a2 + a3) + a4),
        y + h6 * (b1 + 2.0 * (b2 + b3) + b4),
        z + h6 * (c1 + 2.0 * (c2 + c3) + c4),
    ]


def rk4(f, s0, t, substeps: int, inputs, region=None, refine: int = 16) -> np.ndarray:
    """Classical fixed-step RK4 for s' = f(s, u), `substeps` steps per sample interval of the uniform grid t.

    `inputs(tt)` returns the exogenous inputs (array of shape (n_inputs, len(tt))) evaluated analytically at the
    half-step grid, so every stage sees the exact input.  f takes (state list, input list) and returns a list.
    For a right-hand side with kinks, `region(s)` names the smooth piece the state is in; a step that ends in another
    piece is redone with `refine` RK4 sub-steps (inputs evaluated exactly at the finer stages).
    Returns the state at the samples, shape (len(t), n_state)."""
    t = np.asarray(t, dtype=float)
    n = t.size
    h = (t[1] - t[0]) / substeps
    th = t[0] + np.arange(2 * substeps * (n - 1) + 1) * (0.5 * h)
    u = np.atleast_2d(np.asarray(inputs(th), dtype=float)).T.tolist()
    s = [float(a) for a in s0]
    out = [s]
    j = 0
    hr = h / refine
    step = {2: _rk4_step2, 3: _rk4_step3}.get(len(s), _rk4_step)
    piece = region(s) if region is not None else None
    for _ in range(n - 1):
        for _ in range(substeps):
            new = step(f, s, h, u[j], u[j + 1], u[j + 2])
            if region is not None and region(new) != piece:
                tr = th[j] + np.arange(2 * refine + 1) * (0.5 * hr)
                ur = np.atleast_2d(np.asarray(inputs(tr), dtype=float)).T.tolist()
                new = s
                for i in range(refine):
                    new = step(f, new, hr, ur[2 * i], ur[2 * i + 1], ur[2 * i + 2])
                piece = region(new)
            s = new
            j += 2
        out.append(s)
    return np.array(out)


def linear_oscillator_foh(m: float, c: float, k: float, u, dt: float) -> np.ndarray:
    """Displacement of m x'' + c x' + k x = u from rest, exact for an input linear between grid points
    (first-order-hold discretisation by matrix exponential, scipy cont2discrete 'foh', run by lfilter).
    u must start at 0 (a force applied from rest)."""
    num, den, _ = sps.cont2discrete(([1.0], [m, c, k]), dt, method="foh")
    return sps.lfilter(np.ravel(num), np.ravel(den), np.asarray(u, dtype=float))


def cool(temp: float, ambient: float, tau: float, pause: float) -> float:
    """Exact Newtonian cooling over an unrecorded pause."""
    return ambient + (temp - ambient) * math.exp(-pause / tau)
