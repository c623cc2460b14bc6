"""Elementary operators of the blind generators, public so that they can be checked against known solutions.

Exact and smoothed sign functions; the exact play (backlash) operator and the velocity of its output; cumulative
travel; exact Dahl friction (rate independent, piecewise exponential in displacement); the exact Maxwell branch
(exponential integrator); the exact first-order-hold discretisation of a linear system and its response from rest.
Also ``TWO_PI``, shared by every blind module. numpy, scipy and the standard library only.
"""

import math

import numpy as np
from scipy import signal
from scipy.linalg import expm
from scipy.special import erf

TWO_PI = 2.0 * math.pi


def sign_exact(v):
    """Exact sign, sgn(0) = 0."""
    return np.sign(v)


def sign_arctan(v, delta):
    """(2/pi) arctan(v/delta)."""
    return (2.0 / math.pi) * np.arctan(np.asarray(v, float) / delta)


def sign_erf(v, delta):
    """erf(v/delta)."""
    return erf(np.asarray(v, float) / delta)


def sign_algebraic(v, delta):
    """v / sqrt(v^2 + delta^2)."""
    v = np.asarray(v, float)
    return v / np.sqrt(v * v + delta * delta)


def play_operator(x, r, z0=None):
    """Exact play (backlash) operator: z_i = clamp(z_{i-1}, x_i - r, x_i + r).

    Exact for an input that is monotone between consecutive grid points.
    ``z0`` is the state before the first sample (default x[0]); it is clamped
    into the band at the first sample.
    """
    x = np.asarray(x, float)
    z = np.empty_like(x)
    zc = float(x[0]) if z0 is None else float(z0)
    r = float(r)
    for i, xi in enumerate(x.tolist()):
        lo = xi - r
        hi = xi + r
        if zc < lo:
            zc = lo
        elif zc > hi:
            zc = hi
        z[i] = zc
    return z


def play_velocity(x, z, v, r):
    """Velocity of the play operator's output: v where the band edge is engaged
    and the input pushes outward, else 0."""
    x = np.asarray(x, float)
    z = np.asarray(z, float)
    v = np.asarray(v, float)
    tol = 1e-9 * (abs(r) + float(np.max(np.abs(x))) + 1e-300)
    d = x - z
    up = (d >= r - tol) & (v > 0)
    dn = (d <= -r + tol) & (v < 0)
    return np.where(up | dn, v, 0.0)


def cumulative_travel(x):
    """s_i = sum_{j<=i} |x_j - x_{j-1}|, s_0 = 0 (exact for inputs monotone
    between grid points)."""
    x = np.asarray(x, float)
    return np.concatenate([[0.0], np.cumsum(np.abs(np.diff(x)))])


def dahl_operator(x, Fc, sigma, F0=0.0):
    """Exact Dahl friction (exponent 1), rate independent:
    dF/dx = sigma (1 - (F/Fc) sgn(dx)), so over a monotone step dx
    F_new = s Fc + (F_old - s Fc) exp(-sigma |dx| / Fc), s = sgn(dx)."""
    x = np.asarray(x, float)
    dx = np.diff(x)
    s = np.sign(dx) * Fc
    a = np.exp(-sigma * np.abs(dx) / Fc)
    out = [float(F0)]
    Fp = float(F0)
    for si, ai in zip(s.tolist(), a.tolist()):
        Fp = si + (Fp - si) * ai
        out.append(Fp)
    return np.asarray(out)


def maxwell_force(x, h, k_m, tau, F0=0.0):
    """Maxwell branch (spring k_m in series with a dashpot c_m = k_m tau)
    driven by a displacement that is piecewise linear on a uniform grid of step
    h: F' = k_m x' - F/tau, integrated exactly:
    F_{i+1} = e F_i + k_m tau (1-e) (x_{i+1}-x_i)/h, e = exp(-h/tau)."""
    x = np.asarray(x, float)
    e = math.exp(-h / tau)
    g = k_m * tau * (1.0 - e) / h
    dx = np.diff(x)
    y, _ = signal.lfilter([g], [1.0, -e], dx, zi=[e * F0])
    return np.concatenate([[F0], y])


def foh_discretize(A, B, h):
    """Exact discretisation of s' = A s + B u for u piecewise linear over
    steps h: s_{k+1} = Phi s_k + G0 u_k + G1 u_{k+1} (augmented expm)."""
    A = np.atleast_2d(np.asarray(A, float))
    B = np.asarray(B, float).reshape(-1, 1)
    n = A.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = A
    M[:n, n : n + 1] = B
    M[n, n + 1] = 1.0
    E = expm(M * h)
    Phi = E[:n, :n]
    Ga = E[:n, n]
    Gb = E[:n, n + 1]
    G1 = Gb / h
    G0 = Ga - G1
    return Phi, G0, G1


def lti_foh_response(A, B, C, h, u):
    """Output C s of s' = A s + B u from rest (s = 0 at the first sample),
    with u piecewise linear between samples of step h.  Requires u[0] == 0.
    Implemented as the equivalent discrete filter (second-order sections)."""
    u = np.asarray(u, float)
    if abs(u[0]) > 0.0:
        raise ValueError("lti_foh_response needs u[0] == 0 (start at rest)")
    Phi, G0, G1 = foh_discretize(A, B, h)
    C = np.asarray(C, float).reshape(1, -1)
    # w_k = s_k - G1 u_k  ->  w_{k+1} = Phi w_k + (Phi G1 + G0) u_k
    Bd = (Phi @ G1 + G0).reshape(-1, 1)
    Dd = (C @ G1.reshape(-1, 1)).reshape(1, 1)
    z, p, kgain = signal.ss2zpk(Phi, Bd, C, Dd)
    sos = signal.zpk2sos(z, p, kgain)
    return signal.sosfilt(sos, u)
