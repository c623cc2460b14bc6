"""Integrators of the blind cases' nonlinear laws.

``solve_ivp`` simulations from rest (the Stribeck and end-stop oscillators, the own Bouc-Wen variant, the thermal
state of the drifting viscous damper) and two own fixed-step schemes (Crank-Nicolson with Newton for the thermal
friction damper, the implicit midpoint rule for the Duffing oscillator).
"""

import math

import numpy as np
from scipy.integrate import solve_ivp

from .operators import TWO_PI


def simulate_stribeck_oscillator(t, F0, f, p, rtol=1e-9, atol=1e-12, max_step=None):
    """m x'' + c x' + k x + [Fc + (Fs-Fc) exp(-(x'/vs)^2)] erf(x'/delta) = F0 sin(2 pi f t),
    from rest; solve_ivp LSODA.  Returns x (m) at t."""
    m, c, k, Fc, Fs, vs, dl = (p["m"], p["c"], p["k"], p["Fc"], p["Fs"], p["vs"], p["delta"])
    w = TWO_PI * f
    dF = Fs - Fc

    def rhs(tt, y):
        x, v = y
        fr = (Fc + dF * math.exp(-((v / vs) ** 2))) * math.erf(v / dl)
        return [v, (F0 * math.sin(w * tt) - c * v - k * x - fr) / m]

    if max_step is None:
        max_step = (t[1] - t[0]) / 10.0
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=rtol, atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.y[0]


def simulate_endstop_oscillator(t, F0, f, p, rtol=1e-10, atol=1e-13, max_step=None):
    """m x'' + c x' + k x + kc max(|x|-g, 0) sgn(x) = F0 sin(2 pi f t), from rest;
    solve_ivp DOP853.  Returns x (m) at t."""
    m, c, k, kc, g = p["m"], p["c"], p["k"], p["kc"], p["g"]
    w = TWO_PI * f

    def rhs(tt, y):
        x, v = y
        ax = abs(x)
        fc = kc * (ax - g) * (1.0 if x > 0 else -1.0) if ax > g else 0.0
        return [v, (F0 * math.sin(w * tt) - c * v - k * x - fc) / m]

    if max_step is None:
        max_step = (t[1] - t[0]) / 10.0
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], method="DOP853", t_eval=t, rtol=rtol, atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.y[0]


def simulate_bouc_wen(t, amps, freqs, p, z0=-1.0, rtol=1e-10, atol=1e-12, max_step=None):
    """Own Bouc-Wen variant driven by x = -sum a_i cos(2 pi f_i t):
    z' = (x'/xy) [1 - |z|^n (gam + bet sgn(x' z))], bet + gam = 1 (|z| <= 1).
    solve_ivp DOP853.  Returns z at t."""
    xy, n, bet, gam = p["xy"], p["n"], p["beta"], p["gamma"]
    comps = [(a * TWO_PI * fr, TWO_PI * fr) for a, fr in zip(amps, freqs)]

    def rhs(tt, y):
        z = y[0]
        v = 0.0
        for aw, w in comps:
            v += aw * math.sin(w * tt)
        s = 1.0 if v * z > 0 else (-1.0 if v * z < 0 else 0.0)
        return [v / xy * (1.0 - abs(z) ** n * (gam + bet * s))]

    if max_step is None:
        max_step = (t[1] - t[0]) / 10.0
    sol = solve_ivp(rhs, (t[0], t[-1]), [z0], method="DOP853", t_eval=t, rtol=rtol, atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.y[0]


def simulate_thermal_viscous(t, A, f, p, rtol=1e-10, atol=1e-12, max_step=None):
    """Temperature-like state th (K) of a viscous damper driven by
    x = -A cos(2 pi f t): th' = c0 exp(-b th) v^2 / C - th / tau, th(0) = 0.
    solve_ivp DOP853.  Returns th at t."""
    c0, b, C, tau = p["c0"], p["b"], p["C"], p["tau"]
    w = TWO_PI * f
    aw = A * w

    def rhs(tt, y):
        th = y[0]
        v = aw * math.sin(w * tt)
        return [c0 * math.exp(-b * th) * v * v / C - th / tau]

    if max_step is None:
        max_step = (t[1] - t[0]) / 10.0
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], method="DOP853", t_eval=t, rtol=rtol, atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.y[0]


def thermal_friction_cn(t, v, p):
    """Own Crank-Nicolson integration (Newton on the implicit equation) of
    th' = [Fdir(v) exp(-b th) s(v) v + c v^2] / C - th / tau, th(0) = 0,
    with Fdir(v) = Fbar + dF s(v), s(v) = v / sqrt(v^2 + delta^2),
    on the grid t (uniform) with velocities v given at the grid points."""
    Fbar, dF, b, C, tau, c, dl = (p["Fbar"], p["dF"], p["b"], p["C"], p["tau"], p["c"], p["delta"])
    v = np.asarray(v, float)
    s = v / np.sqrt(v * v + dl * dl)
    a_arr = ((Fbar + dF * s) * s * v / C).tolist()  # friction heating / exp(-b th)
    e_arr = (c * v * v / C).tolist()  # viscous heating
    h = float(t[1] - t[0])
    hh = 0.5 * h
    th = 0.0
    out = [0.0]
    a0, e0 = a_arr[0], e_arr[0]
    for i in range(1, len(a_arr)):
        a1, e1 = a_arr[i], e_arr[i]
        f0 = a0 * math.exp(-b * th) + e0 - th / tau
        rhs0 = th + hh * (f0 + e1)
        x = th + h * f0
        for _ in range(6):
            ex = math.exp(-b * x)
            R = x - rhs0 - hh * (a1 * ex - x / tau)
            dR = 1.0 + hh * (a1 * b * ex + 1.0 / tau)
            dx = R / dR
            x -= dx
            if abs(dx) < 1e-14 * (1.0 + abs(x)):
                break
        th = x
        out.append(th)
        a0, e0 = a1, e1
    return np.asarray(out)


def duffing_midpoint(t, u_mid, p):
    """Own implicit-midpoint integration of m x'' + c x' + k x + k3 x^3 = u from
    rest on the uniform grid t; u_mid[i] is the input at (t[i]+t[i+1])/2.
    The midpoint displacement solves a monotone scalar equation by Newton."""
    m, c, k, k3 = p["m"], p["c"], p["k"], p["k3"]
    h = float(t[1] - t[0])
    q = h / (2.0 * m)
    x0, v0 = 0.0, 0.0
    xs = [0.0]
    for um in np.asarray(u_mid, float).tolist():
        xm = x0 + 0.5 * h * v0
        for _ in range(8):
            dxm = xm - x0
            G = 2.0 * dxm / h - v0 - q * (um - (2.0 * c / h) * dxm - k * xm - k3 * xm**3)
            dG = 2.0 / h + q * (2.0 * c / h + k + 3.0 * k3 * xm * xm)
            step = G / dG
            xm -= step
            if abs(step) < 1e-16 + 1e-13 * abs(xm):
                break
        vm = 2.0 * (xm - x0) / h
        x0 = 2.0 * xm - x0
        v0 = 2.0 * vm - v0
        xs.append(x0)
    return np.asarray(xs)
