"""Independent "blind" data generators for testing hysteresis-model discovery.

These generators were written without reading the discovery tool's code.  Every
law, parameter value and numerical method below is this module's own choice.
The module depends only on numpy, scipy and the Python standard library
(math, dataclasses, typing).

Each case is a function ``case_fn(noise=True, nominal=False) -> BlindCase``.
``noise=False`` returns the noise-free truth (same inputs, same records).
``nominal=True`` returns the same experiment with all listed effects switched
off (effect parameters at their neutral values, documented per case as
"Nominal variant"); ``nominal="play"`` (an effect name, or an iterable of
names) switches off only those.  The nominal variants are for diagnostics only
(e.g. measuring the size of an effect); they are not blind data.
Every case is deterministic (fixed numpy seeds).  The noise-free simulation of a
case is computed once per process and cached; callers always receive copies.

Kinds
-----
* ``damper``: input ``x`` = imposed displacement, output ``y`` = force.
* ``oscillator``: input ``x`` = drive force on a mass, output ``y`` = the mass's
  displacement.  Oscillators always start at rest (x = 0, v = 0).

Sine tests on dampers start from rest at -A: ``x = -A cos(2 pi f t)``, whole
cycles, endpoint included.  "cos-sum" inputs ``x = -sum a_i cos(2 pi f_i t)``
also start from rest at ``-sum a_i``.  Tapered multisines use a raised-cosine
fade-in/out so they start and end at rest at zero.

Noise models: white Gaussian; AR(1) ``e_k = phi e_{k-1} + sd sqrt(1-phi^2) w_k``
started from its stationary law; low-pass noise = white noise through a
Butterworth filter (causal, 4000-sample burn-in), scaled with the filter's
exact noise gain so that the *marginal* sd is ``noise_sd``.  Noise is added to
``y`` only; ``x`` is exact.

Cases
-----

Laws (the nominal/base law a user would declare is in each case's ``base_law``):

================================  ================  ===============================================================
name                              effects           law (truth; x' = v; the base law is this minus the effects)
================================  ================  ===============================================================
clean_symmetric_damper            -                 F = k x + c v + Fc sgn(v)
clean_pressure_cubic_damper       -                 F = k(p) x + c(p) v + k3(p) x^3 (k, k3 linear, c exp in p)
clean_linear_oscillator           -                 m x'' + c x' + k x = u
clean_duffing_oscillator          -                 m x'' + c x' + k x + k3 x^3 = u
play_friction_damper              play              F = k x + c z' + Fc sgn(z'), z = play_r[x]
play_stribeck_rotary_damper       play, stribeck    T = k th + c z' + S(z') z'/sqrt(z'^2+d^2), z = play_r[th]
stribeck_friction_damper          stribeck          F = k x + c v + [Fc + (Fs-Fc) exp(-(v/vs)^2)] sgn(v)
stribeck_oscillator               stribeck          m x'' + c x' + k x + [Fc + (Fs-Fc) exp(-(v/vs)^2)] erf(v/d) = u
travel_softening_damper           travel_stiffness  F = k(s) x + c v, k(s) exponential in travel s
travel_friction_damper            travel_friction   F = k x + c v + Fc(s) (2/pi) atan(v/d)
thermal_drift_viscous_damper      drift             F = k x + c0 exp(-b th) v, th' = c v^2/C - th/tau
asymmetric_friction_drift_damper  asymmetry, drift  F = k x + c v + Fdir(v) exp(-b th) s(v), th' = P/C - th/tau
maxwell_relaxation_damper         relaxation        F = k x + Fm, Fm' = km x' - Fm/tau
air_spring_relaxation_oscillator  relaxation        m x'' + c x' + k(p) x + Fm = u, Fm' = km(p) x' - Fm/tau
dahl_friction_damper              hysteretic        F = k x + c v + Fd, dFd/dx = sigma (1 - Fd/Fc sgn(x'))
mr_bouc_wen_damper                hysteretic        F = k x + c(I) v + alpha(I) z, own Bouc-Wen z
asymmetric_viscous_damper         asymmetry         F = k x + [cbar + dc v/sqrt(v^2+d^2)] v
cogging_rotary_damper             outside           T = k th + c w + Tc erf(w/d) + Tcog sin(2 pi th/p + ph)
endstop_contact_oscillator        outside           m x'' + c x' + k x + kc max(|x| - g, 0) sgn(x) = u
================================  ================  ===============================================================

Numerics, sampling and noise:

================================  ===============================  =================  =================
name                              integrator (grid / sample grid)  sampling           noise (model, sd)
================================  ===============================  =================  =================
clean_symmetric_damper            closed form, exact sign          200/cycle          white, 0.08 kip
clean_pressure_cubic_damper       closed form                      100 Hz multisine   AR(1) .7, 6 N
clean_linear_oscillator           exact FOH (expm), 16x            100/cycle, 200 Hz  low-pass, 0.4 mm
clean_duffing_oscillator          own implicit midpoint, 20x       80/cycle, 150 Hz   white, 0.25 mm
play_friction_damper              exact clamp recursion, 4x        500/cycle          AR(1) .3, 3 N
play_stribeck_rotary_damper       exact clamp recursion, 10x       100 Hz cos-sums    white, 0.15 Nm
stribeck_friction_damper          closed form, exact sign          1000/cycle         low-pass, .05 kip
stribeck_oscillator               solve_ivp LSODA 1e-9             100/cycle          AR(1) .5, 0.4 mm
travel_softening_damper           exact travel sum, 5x             400/cycle          AR(1) .5, 6 N
travel_friction_damper            exact travel sum, 10x            150/cycle, 100 Hz  white, .04 kip
thermal_drift_viscous_damper      solve_ivp DOP853 1e-10           25/cycle           white, 5 N
asymmetric_friction_drift_damper  own Crank-Nicolson, 20x          120/cycle          low-pass, .04 kip
maxwell_relaxation_damper         exact exponential, 10x           100/cycle, 200 Hz  AR(1) .8, 1.5 N
air_spring_relaxation_oscillator  exact FOH (expm), 8x             250 Hz multisine   AR(1) .6, 0.1 mm
dahl_friction_damper              exact Dahl recursion, 10x        400/cycle          low-pass, 1.5 N
mr_bouc_wen_damper                solve_ivp DOP853 1e-10           400 Hz cos-sum     white, 3 N
asymmetric_viscous_damper         closed form                      80/cycle           AR(1) .9, 4 N
cogging_rotary_damper             closed form                      250/cycle          white, 0.08 Nm
endstop_contact_oscillator        solve_ivp DOP853 1e-10           60/cycle           AR(1) .4, 0.3 mm
================================  ===============================  =================  =================

The exact parameter values, units, initial states, record lists and noise
levels of each case are in its ``description``.  Cases whose base-law
parameters vary with an operating condition: clean_pressure_cubic_damper
(``pressure_kpa``), air_spring_relaxation_oscillator (``pressure_kpa``),
mr_bouc_wen_damper (``current_a``).  All others use conditions ``amplitude``
and ``frequency_hz``.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.special import erf

TWO_PI = 2.0 * math.pi


@dataclass
class BlindCase:
    name: str
    effects: tuple[str, ...]
    description: str
    base_law: str
    kind: str
    units: dict
    noise_sd: float
    records: list[dict]
    held_out: list[str]
    validation: list[str]
    noise_model: tuple = ("white",)  # ("white",), ("ar1", phi) or ("lowpass", order, cutoff fraction)


# =============================================================================
# Elementary operators (public so that they can be checked against known
# solutions)
# =============================================================================


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


# ----------------------------------------------------------------- ODE cases


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


# =============================================================================
# Inputs
# =============================================================================


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


# =============================================================================
# Noise
# =============================================================================


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


# =============================================================================
# Case machinery
# =============================================================================

_CACHE: dict[tuple[str, frozenset], dict] = {}


def _off_set(effects, nominal):
    if nominal is True:
        return frozenset(effects)
    if nominal is False or nominal is None:
        return frozenset()
    off = frozenset([nominal]) if isinstance(nominal, str) else frozenset(nominal)
    unknown = off - frozenset(effects)
    if unknown:
        raise ValueError(f"effects {sorted(unknown)} are not part of this case {effects}")
    return off


def _build(name, spec_fn, effects, noise, nominal):
    off = _off_set(effects, nominal)
    key = (name, off)
    spec = _CACHE.get(key)
    if spec is None:
        spec = spec_fn(off)
        _CACHE[key] = spec
    rng = np.random.default_rng(spec["seed"])
    records = []
    for rname, t, x, y, cond in spec["records"]:
        e = make_noise(rng, len(t), spec["noise_sd"], spec["noise_model"])
        yy = y + e if noise else y.copy()
        records.append(
            {"name": rname, "t": t.copy(), "x": x.copy(), "y": yy, "conditions": {k: float(v) for k, v in cond.items()}}
        )
    desc = spec["description"] + " " + _noise_text(spec["noise_model"], spec["noise_sd"], spec["units"]["y"])
    if off:
        desc = f"[NOMINAL VARIANT for diagnostics: effect(s) {', '.join(sorted(off))} switched off] " + desc
    return BlindCase(
        name=name,
        effects=tuple(spec["effects"]),
        description=desc,
        base_law=spec["base_law"],
        kind=spec["kind"],
        units=dict(spec["units"]),
        noise_sd=float(spec["noise_sd"]),
        records=records,
        held_out=list(spec["held_out"]),
        validation=list(spec["validation"]),
        noise_model=tuple(spec["noise_model"]),
    )


def _rec(name, t, x, y, cond):
    return (name, np.asarray(t, float), np.asarray(x, float), np.asarray(y, float), cond)


def _af(A, f):
    return {"amplitude": float(A), "frequency_hz": float(f)}


def _sine_name(prefix, A, f):
    return f"{prefix}{A:g}_f{f:g}"


# =============================================================================
# Cases
# =============================================================================


# ---------------------------------------------------------------- 1
def _spec_clean_symmetric_damper(off):
    k, c, Fc = 1.8, 0.9, 1.2
    spc, cyc = 200, 3
    tests = [(0.25, 0.5), (0.5, 0.5), (0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (1.5, 1.0)]
    recs = []
    for A, f in tests:
        t, x, v = sine_input(A, f, cyc, spc)
        y = k * x + c * v + Fc * sign_exact(v)
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Symmetric linear damper, clean control. Law: F = k x + c v + Fc sgn(v) with "
        f"k = {k:g} kip/in, c = {c:g} kip s/in, Fc = {Fc:g} kip, exact sign (sgn(0) = 0 at the turning "
        "points). x in inches, F in kip. Inputs: sines x = -A cos(2 pi f t) from rest, "
        f"{cyc} whole cycles, {spc} samples per cycle, (A in, f Hz) = {tests}. Integrator: closed "
        "form with the analytic velocity. Held out: largest amplitude A1.5_f1; validation A0.5_f1."
    )
    return dict(
        effects=(),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "in", "y": "kip", "t": "s"},
        noise_sd=0.08,
        noise_model=("white",),
        seed=11001,
        records=recs,
        held_out=["A1.5_f1"],
        validation=["A0.5_f1"],
        description=desc,
    )


# ---------------------------------------------------------------- 2
def _spec_clean_pressure_cubic_damper(off):
    levels = [100.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0]
    fs, T, ramp, peak = 100.0, 10.0, 1.0, 15.0
    freqs = [0.4, 1.0, 1.8, 3.1]
    rel = [1.0, 0.6, 0.3, 0.15]
    rng = np.random.default_rng(12002)
    phases = rng.uniform(0, TWO_PI, len(freqs))
    t = np.arange(int(round(T * fs)) + 1) / fs
    x, v = tapered_multisine(t, rel, freqs, phases, T, ramp)
    sc = peak / np.max(np.abs(x))
    x, v = x * sc, v * sc
    recs = []
    for p in levels:
        k = 20.0 + 0.08 * p
        c = 0.6 * math.exp(p / 250.0)
        k3 = 0.03 + 5e-5 * p
        y = k * x + c * v + k3 * x**3
        recs.append(_rec(f"p{p:g}", t, x, y, {"pressure_kpa": p}))
    desc = (
        "Pressurised damper with a cubic spring, clean control; base-law parameters vary "
        "with pressure p (kPa): F = k(p) x + c(p) v + k3(p) x^3, k(p) = 20 + 0.08 p N/mm "
        "(linear), c(p) = 0.6 exp(p/250) N s/mm (exponential), k3(p) = 0.03 + 5e-5 p N/mm^3 "
        f"(linear). x in mm, F in N. Pressure levels {levels} kPa, one record each, all with the "
        "same input: tapered multisine (raised-cosine fade 1 s at both ends) with tones "
        f"{freqs} Hz, relative amplitudes {rel}, random phases (seed 12002), scaled to peak "
        "|x| = 15 mm, duration 10 s, sampled at 100 Hz (250 samples per 0.4 Hz cycle). Closed "
        "form with analytic velocity. Held out: p400 (highest level, extrapolation); "
        "validation p250."
    )
    return dict(
        effects=(),
        base_law="spring + viscous + cubic",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=6.0,
        noise_model=("ar1", 0.7),
        seed=12001,
        records=recs,
        held_out=["p400"],
        validation=["p250"],
        description=desc,
    )


# ---------------------------------------------------------------- 3
_LIN_OSC = dict(m=2.0, k=2.0 * (TWO_PI * 3.0) ** 2, c=2.0 * 0.04 * 2.0 * TWO_PI * 3.0)


def linear_oscillator_matrices(m, c, k):
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    B = np.array([0.0, 1.0 / m])
    C = np.array([1.0, 0.0])
    return A, B, C


def _osc_sine_records(sim, tests, spc, refine, scale=1000.0):
    """sim(t_fine, u_fine, u_mid_fine) -> displacement (m) on t_fine."""
    recs = []
    for F0, f, ncyc in tests:
        n = int(ncyc * spc * refine)
        tf = np.arange(n + 1) / (f * spc * refine)
        uf = F0 * np.sin(TWO_PI * f * tf)
        um = F0 * np.sin(TWO_PI * f * (tf[:-1] + 0.5 * (tf[1] - tf[0])))
        xf = sim(tf, uf, um)
        recs.append(_rec(_sine_name("F", F0, f), tf[::refine], uf[::refine], scale * xf[::refine], _af(F0, f)))
    return recs


def _spec_clean_linear_oscillator(off):
    p = _LIN_OSC
    A, B, C = linear_oscillator_matrices(p["m"], p["c"], p["k"])
    refine = 16

    def sim(tf, uf, um):
        return lti_foh_response(A, B, C, tf[1] - tf[0], uf)

    tests = [(5.0, 1.5, 4), (5.0, 2.5, 5), (8.0, 3.0, 5), (10.0, 4.5, 5), (10.0, 6.0, 5)]
    recs = _osc_sine_records(sim, tests, 100, refine)
    # band-limited multisine record
    fs, T, ramp = 200.0, 6.0, 0.5
    amps, freqs, phases = _ms_design(13003, 0.5, 8.0, 16)
    tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
    uf, _ = tapered_multisine(tf, amps, freqs, phases, T, ramp)
    sc = 10.0 / np.max(np.abs(uf))
    uf = uf * sc
    xf = sim(tf, uf, None)
    recs.append(_rec("MS_F10_f8", tf[::refine], uf[::refine], 1000.0 * xf[::refine], _af(10.0, 8.0)))
    desc = (
        f"Linear mass-spring-damper, clean control: m x'' + c x' + k x = u, m = {p['m']:g} kg, "
        f"k = {p['k']:.4f} N/m (natural frequency 3.0 Hz), c = {p['c']:.5f} N s/m (damping "
        "ratio 0.04). Input u = drive force in N, output = displacement in mm; starts at rest. "
        f"Records: sines u = F0 sin(2 pi f t) (F0 N, f Hz, cycles) = {tests} at 100 samples per "
        "cycle, and MS_F10_f8: tapered multisine (16 equal tones 0.5-8 Hz, random phases seed "
        "13003, 0.5 s raised-cosine fades, peak 10 N, 6 s at 200 Hz; conditions amplitude = 10 N "
        "peak, frequency_hz = 8 = top of band). Integrator: exact first-order-hold "
        "discretisation (matrix exponential of the augmented system) on a grid 16x finer than "
        "the samples; the input is exactly piecewise linear on that fine grid. Held out: F10_f6 "
        "(highest frequency, above resonance); validation F5_f2.5."
    )
    return dict(
        effects=(),
        base_law="oscillator(mass, viscous, spring)",
        kind="oscillator",
        units={"x": "N", "y": "mm", "t": "s"},
        noise_sd=0.4,
        noise_model=("lowpass", 2, 0.2),
        seed=13001,
        records=recs,
        held_out=["F10_f6"],
        validation=["F5_f2.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 4 (Duffing, clean)
_DUFF = dict(m=0.5, k=200.0, c=0.6, k3=4.0e5)


def _spec_clean_duffing_oscillator(off):
    p = _DUFF
    refine = 20

    def sim(tf, uf, um):
        return duffing_midpoint(tf, um, p)

    tests = [(2.0, 2.0, 4), (4.0, 2.5, 4), (4.0, 4.0, 5), (6.0, 3.0, 4), (8.0, 3.5, 4)]
    recs = _osc_sine_records(sim, tests, 80, refine)
    fs, T, ramp = 150.0, 5.0, 0.5
    amps, freqs, phases = _ms_design(14003, 0.5, 7.0, 14, corner=4.0)
    tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
    h = tf[1] - tf[0]
    uf, _ = tapered_multisine(tf, amps, freqs, phases, T, ramp)
    um, _ = tapered_multisine(tf[:-1] + 0.5 * h, amps, freqs, phases, T, ramp)
    sc = 6.0 / np.max(np.abs(uf))
    xf = sim(tf, uf * sc, um * sc)
    recs.append(_rec("MS_F6_f7", tf[::refine], sc * uf[::refine], 1000.0 * xf[::refine], _af(6.0, 7.0)))
    desc = (
        "Hardening Duffing oscillator, clean control: m x'' + c x' + k x + k3 x^3 = u with "
        f"m = {p['m']:g} kg, c = {p['c']:g} N s/m, k = {p['k']:g} N/m (linear natural frequency "
        f"3.18 Hz), k3 = {p['k3']:g} N/m^3 (x in metres inside the law). Input u = force in N, "
        f"output displacement in mm, from rest. Records: sines F0 sin(2 pi f t) (F0 N, f Hz, "
        f"cycles) = {tests} at 80 samples per cycle, and MS_F6_f7: tapered multisine (14 tones "
        "0.5-7 Hz, amplitudes 1/sqrt(1+(f/4)^4), random phases seed 14003, 0.5 s fades, peak "
        "6 N, 5 s at 150 Hz). Integrator: own implicit midpoint rule (second order, Newton on "
        "the midpoint displacement, input evaluated at step midpoints) on a grid 20x finer than "
        "the samples. Held out: F8_f3.5 (largest force); validation F4_f2.5."
    )
    return dict(
        effects=(),
        base_law="oscillator(mass, viscous, spring, cubic)",
        kind="oscillator",
        units={"x": "N", "y": "mm", "t": "s"},
        noise_sd=0.25,
        noise_model=("white",),
        seed=14001,
        records=recs,
        held_out=["F8_f3.5"],
        validation=["F4_f2.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 5 play
def _spec_play_friction_damper(off):
    k, c, Fc = 30.0, 2.0, 80.0
    r_true = 0.6
    r = 0.0 if off else r_true
    spc, cyc, refine = 500, 3, 4
    tests = [(2.0, 1.0), (4.0, 0.5), (4.0, 2.0), (6.0, 1.0), (8.0, 1.0)]
    recs = []
    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        zf = play_operator(xf, r, z0=xf[0] + r)
        t, x, v, z = tf[::refine], xf[::refine], vf[::refine], zf[::refine]
        vz = play_velocity(x, z, v, r)
        y = k * x + c * vz + Fc * sign_exact(vz)
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Friction damper driven through a clearance, with a parallel spring: F = k x + "
        "c z' + Fc sgn(z'), z = P_r[x] the play (backlash) operator of half-width r, i.e. the "
        "viscous+Coulomb element sees no motion (and transmits no force) while x crosses the "
        f"dead band 2r after each reversal. k = {k:g} N/mm, c = {c:g} N s/mm, Fc = {Fc:g} N, "
        f"r = {r_true:g} mm (dead band {2 * r_true:g} mm). x in mm, F in N. Initial play state "
        "z(0) = x(0) + r (gap closed on the negative side, as after the move down to -A). "
        "z' = x' when the band edge is engaged and pushed, else 0; exact sign. Sines "
        f"x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, (A mm, f Hz) = {tests}. "
        "Integrator: exact clamp recursion z_i = min(max(z_{i-1}, x_i - r), x_i + r) on a grid "
        "4x finer than the samples (turning points lie on the grid). Nominal variant: r = 0. "
        "Held out: A8_f1 (largest amplitude); validation A4_f2."
    )
    return dict(
        effects=("play",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=3.0,
        noise_model=("ar1", 0.3),
        seed=15001,
        records=recs,
        held_out=["A8_f1"],
        validation=["A4_f2"],
        description=desc,
    )


# ---------------------------------------------------------------- 6 play + stribeck
def _spec_play_stribeck_rotary_damper(off):
    kth, c, Tc, Ts, ws, dl = 0.4, 0.012, 3.0, 5.5, 12.0, 0.2
    Ts_true = Ts
    r_true = 0.8
    r = r_true
    if "play" in off:
        r = 0.0
    if "stribeck" in off:
        Ts = Tc
    fs, refine = 100.0, 10
    rel = np.array([1.0, 0.35, 0.2])
    harm = np.array([1.0, 2.0, 3.0])
    tests = [(10.0, 0.5), (20.0, 0.25), (20.0, 0.5), (30.0, 0.25), (30.0, 0.5), (40.0, 0.5)]
    recs = []
    for A, f0 in tests:
        T = 2.0 / f0
        tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
        amps = A * rel / rel.sum()
        xf, vf = cos_sum(tf, amps, f0 * harm)
        zf = play_operator(xf, r, z0=xf[0] + r)
        t, x, v, z = tf[::refine], xf[::refine], vf[::refine], zf[::refine]
        vz = play_velocity(x, z, v, r)
        S = Tc + (Ts - Tc) * np.exp(-np.abs(vz) / ws)
        y = kth * x + c * vz + S * sign_algebraic(vz, dl)
        recs.append(_rec(_sine_name("A", A, f0), t, x, y, _af(A, f0)))
    desc = (
        "Rotary friction damper with backlash and Stribeck friction, parallel torsion spring: "
        "T = kth th + c z' + S(z') z'/sqrt(z'^2 + delta^2), S(w) = Tc + (Ts - Tc) exp(-|w|/ws), "
        "z = P_r[th] (exact play operator), z' = th' when engaged else 0. "
        f"kth = {kth:g} Nm/deg, c = {c:g} Nm s/deg, Tc = {Tc:g} Nm, Ts = {Ts_true:g} Nm, "
        f"ws = {ws:g} deg/s, delta = {dl:g} deg/s (algebraic sign smoothing), r = {r_true:g} deg "
        f"(dead band {2 * r_true:g} deg), z(0) = th(0) + r. th in deg, T in Nm. Inputs: periodic "
        "cos-sums th = -sum a_i cos(2 pi h_i f0 t), h = (1, 2, 3), a proportional to "
        "(1, 0.35, 0.2) summing to A (start at rest at -A), 2 fundamental cycles, 100 Hz; "
        f"(A deg, f0 Hz) = {tests}; conditions amplitude = A, frequency_hz = f0. Integrator: "
        "exact clamp recursion on a 10x finer grid, closed-form torque. Nominal variant: r = 0 "
        "(play off), Ts = Tc (Stribeck off). Held out: A40_f0.5 (largest amplitude); "
        "validation A20_f0.25."
    )
    return dict(
        effects=("play", "stribeck"),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "deg", "y": "Nm", "t": "s"},
        noise_sd=0.15,
        noise_model=("white",),
        seed=16001,
        records=recs,
        held_out=["A40_f0.5"],
        validation=["A20_f0.25"],
        description=desc,
    )


# ---------------------------------------------------------------- 7 stribeck damper
def _spec_stribeck_friction_damper(off):
    k, c, Fc, Fs, vs = 0.6, 0.25, 2.0, 3.5, 0.4
    Fs_true = Fs
    if off:
        Fs = Fc
    spc, cyc = 1000, 2
    tests = [(0.5, 0.1), (0.5, 0.5), (1.0, 0.25), (1.0, 1.0), (2.0, 0.1), (2.0, 0.5)]
    recs = []
    for A, f in tests:
        t, x, v = sine_input(A, f, cyc, spc)
        y = k * x + c * v + (Fc + (Fs - Fc) * np.exp(-((v / vs) ** 2))) * sign_exact(v)
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Friction damper with a Stribeck (Gaussian) friction-velocity curve: F = k x + c v + "
        "[Fc + (Fs - Fc) exp(-(v/vs)^2)] sgn(v), exact sign (sgn(0) = 0). "
        f"k = {k:g} kip/in, c = {c:g} kip s/in, Fc = {Fc:g} kip, Fs = {Fs_true:g} kip, "
        f"vs = {vs:g} in/s. x in inches, F in kip. Sines x = -A cos(2 pi f t), {cyc} cycles, "
        f"{spc} samples per cycle, (A in, f Hz) = {tests} (peak velocities 0.31-6.3 in/s). "
        "Closed form with the analytic velocity. Nominal variant: Fs = Fc. Held out: A2_f0.5 "
        "(largest amplitude and speed); validation A1_f0.25."
    )
    return dict(
        effects=("stribeck",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "in", "y": "kip", "t": "s"},
        noise_sd=0.05,
        noise_model=("lowpass", 2, 0.05),
        seed=17001,
        records=recs,
        held_out=["A2_f0.5"],
        validation=["A1_f0.25"],
        description=desc,
    )


# ---------------------------------------------------------------- 8 stribeck oscillator
_STRIB_OSC = dict(m=1.5, k=1.5 * (TWO_PI * 2.5) ** 2, c=2.0, Fc=1.5, Fs=4.0, vs=0.03, delta=1e-3)


def _spec_stribeck_oscillator(off):
    p = dict(_STRIB_OSC)
    if off:
        p["Fs"] = p["Fc"]
    spc = 100
    tests = [(5.0, 1.0, 3), (5.0, 2.0, 4), (7.0, 1.5, 4), (7.0, 3.5, 5), (9.0, 2.2, 5), (10.0, 1.0, 3)]
    recs = []
    for F0, f, ncyc in tests:
        t = np.arange(ncyc * spc + 1) / (f * spc)
        u = F0 * np.sin(TWO_PI * f * t)
        x = simulate_stribeck_oscillator(t, F0, f, p)
        recs.append(_rec(_sine_name("F", F0, f), t, u, 1000.0 * x, _af(F0, f)))
    desc = (
        "Mass on a spring with viscous and Stribeck friction: m x'' + c x' + k x + "
        "[Fc + (Fs - Fc) exp(-(x'/vs)^2)] erf(x'/delta) = u, "
        f"m = {p['m']:g} kg, k = {p['k']:.4f} N/m (2.5 Hz), c = {p['c']:g} N s/m, "
        f"Fc = {p['Fc']:g} N, Fs = {_STRIB_OSC['Fs']:g} N, vs = {p['vs']:g} m/s, "
        f"delta = {p['delta']:g} m/s (erf smoothing of the sign). Input u = force (N), output "
        "displacement in mm, from rest. Sines F0 sin(2 pi f t) (F0 N, f Hz, cycles) = "
        f"{tests} at 100 samples per cycle. Integrator: scipy solve_ivp LSODA, rtol 1e-9, "
        "atol 1e-12 (m, m/s), max_step = sample interval / 10. Nominal variant: Fs = Fc. "
        "Held out: F10_f1 (largest force); validation F7_f1.5."
    )
    return dict(
        effects=("stribeck",),
        base_law="oscillator(mass, viscous, spring, coulomb)",
        kind="oscillator",
        units={"x": "N", "y": "mm", "t": "s"},
        noise_sd=0.4,
        noise_model=("ar1", 0.5),
        seed=18001,
        records=recs,
        held_out=["F10_f1"],
        validation=["F7_f1.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 9 travel stiffness
def _spec_travel_softening_damper(off):
    k0, kinf, s0, c = 50.0, 32.0, 60.0, 1.5
    kinf_true = kinf
    if off:
        kinf = k0
    spc, cyc, refine = 400, 4, 5
    tests = [(5.0, 1.0), (10.0, 0.5), (10.0, 2.0), (15.0, 1.0), (20.0, 1.0)]
    recs = []
    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        sf = cumulative_travel(xf)
        t, x, v, s = tf[::refine], xf[::refine], vf[::refine], sf[::refine]
        kk = kinf + (k0 - kinf) * np.exp(-s / s0)
        y = kk * x + c * v
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Elastomeric damper whose stiffness softens with cumulative travel (Mullins-like, "
        "secant form): F = k(s) x + c v, k(s) = kinf + (k0 - kinf) exp(-s/s0), s = integral of "
        "|dx| from the start of each record (each record starts on a rested specimen, s = 0). "
        f"k0 = {k0:g} N/mm, kinf = {kinf_true:g} N/mm, s0 = {s0:g} mm, c = {c:g} N s/mm. x in mm, "
        f"F in N. Sines x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, "
        f"(A mm, f Hz) = {tests}. Travel accumulated exactly (sum of |dx|) on a 5x finer grid "
        "containing every turning point. Nominal variant: kinf = k0. Held out: A20_f1 (largest "
        "amplitude); validation A10_f2."
    )
    return dict(
        effects=("travel_stiffness",),
        base_law="spring + viscous",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=6.0,
        noise_model=("ar1", 0.5),
        seed=19001,
        records=recs,
        held_out=["A20_f1"],
        validation=["A10_f2"],
        description=desc,
    )


# ---------------------------------------------------------------- 10 travel friction
def _spec_travel_friction_damper(off):
    k, c, Fc0, Fcinf, s0, dl = 1.0, 0.3, 3.0, 1.8, 4.0, 0.01
    Fcinf_true = Fcinf
    if off:
        Fcinf = Fc0
    spc, cyc, refine = 150, 3, 10
    tests = [(0.5, 0.5), (1.0, 0.5), (1.0, 1.0), (1.5, 0.25), (2.0, 0.5)]
    recs = []

    def law(x, v, s):
        Fc = Fcinf + (Fc0 - Fcinf) * np.exp(-s / s0)
        return k * x + c * v + Fc * sign_arctan(v, dl)

    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        sf = cumulative_travel(xf)
        sl = slice(None, None, refine)
        recs.append(_rec(_sine_name("A", A, f), tf[sl], xf[sl], law(xf[sl], vf[sl], sf[sl]), _af(A, f)))
    # cos-sum record with minor reversals
    fs, f0, A = 100.0, 0.5, 1.5
    T = 3.0 / f0
    tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
    xf, vf = cos_sum(tf, [A * 0.7, A * 0.3], [f0, 4.0 * f0])
    sf = cumulative_travel(xf)
    sl = slice(None, None, refine)
    recs.append(_rec("MS_A1.5_f0.5", tf[sl], xf[sl], law(xf[sl], vf[sl], sf[sl]), _af(A, f0)))
    desc = (
        "Friction damper whose friction level runs in (drops) with cumulative travel: "
        "F = k x + c v + Fc(s) (2/pi) arctan(v/delta), Fc(s) = Fcinf + (Fc0 - Fcinf) exp(-s/s0), "
        "s = integral of |dx| from the start of each record (fresh pads each record). "
        f"k = {k:g} kip/in, c = {c:g} kip s/in, Fc0 = {Fc0:g} kip, Fcinf = {Fcinf_true:g} kip, "
        f"s0 = {s0:g} in, delta = {dl:g} in/s. x in inches, F in kip. Records: sines "
        f"x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, (A in, f Hz) = {tests}; "
        "and MS_A1.5_f0.5: x = -(1.05 cos(2 pi 0.5 t) + 0.45 cos(2 pi 2 t)) in, 3 fundamental "
        "cycles at 100 Hz (minor reversals). Travel accumulated exactly on a 10x finer grid. "
        "Nominal variant: Fcinf = Fc0. Held out: A2_f0.5 (largest amplitude, most travel); "
        "validation A1_f1."
    )
    return dict(
        effects=("travel_friction",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "in", "y": "kip", "t": "s"},
        noise_sd=0.04,
        noise_model=("white",),
        seed=20001,
        records=recs,
        held_out=["A2_f0.5"],
        validation=["A1_f1"],
        description=desc,
    )


# ---------------------------------------------------------------- 11 thermal drift
_THERM = dict(k=15.0, c0=4.0, b=0.025, C=1.0e4, tau=60.0)


def _spec_thermal_drift_viscous_damper(off):
    p = dict(_THERM)
    if off:
        p["b"] = 0.0
    spc, cyc = 25, 5
    tests = [(10.0, 0.5), (10.0, 1.0), (20.0, 0.5), (20.0, 1.0), (15.0, 2.0), (30.0, 1.0)]
    recs = []
    for A, f in tests:
        t, x, v = sine_input(A, f, cyc, spc)
        th = simulate_thermal_viscous(t, A, f, p)
        y = p["k"] * x + p["c0"] * np.exp(-p["b"] * th) * v
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Viscous damper that heats up: F = k x + c(th) v, c(th) = c0 exp(-b th), with a "
        "temperature-rise state th (K): th' = c(th) v^2 / C - th / tau, th(0) = 0 at the start "
        f"of every record (cooled between tests). k = {p['k']:g} N/mm, c0 = {p['c0']:g} N s/mm, "
        f"b = {_THERM['b']:g} 1/K, heat capacity C = {p['C']:g} N mm/K (10 J/K), cooling time "
        f"tau = {p['tau']:g} s. x in mm, F in N. Sines x = -A cos(2 pi f t), {cyc} cycles, "
        f"{spc} samples per cycle, (A mm, f Hz) = {tests}. Integrator: scipy solve_ivp DOP853 for "
        "th with the analytic velocity, rtol 1e-10, atol 1e-12, max_step = sample interval / 10; "
        "force in closed form. Nominal variant: b = 0. Held out: A30_f1 (largest amplitude, "
        "most heating); validation A20_f0.5."
    )
    return dict(
        effects=("drift",),
        base_law="spring + viscous",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=5.0,
        noise_model=("white",),
        seed=21001,
        records=recs,
        held_out=["A30_f1"],
        validation=["A20_f0.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 12 asymmetry + drift
_ASYMDRIFT = dict(k=0.8, c=0.15, Fbar=2.0, dF=0.5, delta=0.02, b=0.012, C=2.4, tau=30.0)


def _spec_asymmetric_friction_drift_damper(off):
    p = dict(_ASYMDRIFT)
    if "asymmetry" in off:
        p["dF"] = 0.0
    if "drift" in off:
        p["b"] = 0.0
    spc, cyc, refine = 120, 4, 20
    tests = [(0.5, 0.5), (1.0, 0.5), (1.0, 1.0), (1.5, 1.0), (2.0, 1.0)]
    recs = []
    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        thf = thermal_friction_cn(tf, vf, p)
        sl = slice(None, None, refine)
        x, v, th = xf[sl], vf[sl], thf[sl]
        s = sign_algebraic(v, p["delta"])
        y = p["k"] * x + p["c"] * v + (p["Fbar"] + p["dF"] * s) * np.exp(-p["b"] * th) * s
        recs.append(_rec(_sine_name("A", A, f), tf[sl], x, y, _af(A, f)))
    q = _ASYMDRIFT
    desc = (
        "Friction damper with direction-dependent friction that fades as it heats: "
        "F = k x + c v + Fdir(v) exp(-b th) s(v), s(v) = v / sqrt(v^2 + delta^2), "
        f"Fdir(v) = Fbar + dF s(v) (so about {q['Fbar'] + q['dF']:g} kip in extension v > 0 and "
        f"{q['Fbar'] - q['dF']:g} kip in compression), temperature-like state th (K): "
        "th' = [Fdir(v) exp(-b th) s(v) v + c v^2] / C - th / tau, th(0) = 0 every record. "
        f"k = {q['k']:g} kip/in, c = {q['c']:g} kip s/in, Fbar = {q['Fbar']:g} kip, "
        f"dF = {q['dF']:g} kip, delta = {q['delta']:g} in/s, b = {q['b']:g} 1/K, "
        f"C = {q['C']:g} kip in/K, tau = {q['tau']:g} s. x in inches, F in kip. Sines "
        f"x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, (A in, f Hz) = {tests}. "
        "Integrator: own Crank-Nicolson (trapezoidal) scheme with Newton iterations on a grid "
        "20x finer than the samples, analytic velocity. Nominal variant: dF = 0 (asymmetry "
        "off), b = 0 (drift off). Held out: A2_f1 (largest amplitude, most heating); "
        "validation A1_f1."
    )
    return dict(
        effects=("asymmetry", "drift"),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "in", "y": "kip", "t": "s"},
        noise_sd=0.04,
        noise_model=("lowpass", 2, 0.15),
        seed=22001,
        records=recs,
        held_out=["A2_f1"],
        validation=["A1_f1"],
        description=desc,
    )


# ---------------------------------------------------------------- 13 Maxwell relaxation
def _spec_maxwell_relaxation_damper(off):
    k, km, cm = 10.0, 40.0, 3.0
    km_true = km
    if off:
        km = 1.0e9  # Maxwell branch -> plain dashpot c_m
    tau = cm / km
    refine = 10
    spc, cyc, A = 100, 3, 5.0
    freqs = [0.5, 1.0, 2.0, 4.0, 8.0]
    recs = []
    for f in freqs:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        Fm = maxwell_force(xf, tf[1] - tf[0], km, tau)
        sl = slice(None, None, refine)
        recs.append(_rec(_sine_name("A", A, f), tf[sl], xf[sl], k * xf[sl] + Fm[sl], _af(A, f)))
    # filtered random displacement records (piecewise linear on the fine grid)
    fs, T = 200.0, 8.0
    for j, (peak, fc) in enumerate([(8.0, 3.0), (6.0, 6.0)]):
        rng = np.random.default_rng(23100 + j)
        nf = int(round(T * fs * refine))
        sos = signal.butter(4, fc / (0.5 * fs * refine), output="sos")
        wnz = signal.sosfilt(sos, rng.standard_normal(nf + 1 + 20000))[20000:]
        tf = np.arange(nf + 1) / (fs * refine)
        wt, _ = _taper(tf, T, 0.5)
        xf = wnz * wt
        xf = xf * (peak / np.max(np.abs(xf)))
        Fm = maxwell_force(xf, tf[1] - tf[0], km, tau)
        sl = slice(None, None, refine)
        recs.append(_rec(f"RND_A{peak:g}_f{fc:g}", tf[sl], xf[sl], k * xf[sl] + Fm[sl], _af(peak, fc)))
    desc = (
        "Spring in parallel with a Maxwell element (spring km in series with dashpot cm): "
        "F = k x + Fm, Fm' = km x' - Fm / tau, tau = cm / km, Fm(0) = 0 (relaxed). "
        f"k = {k:g} N/mm, km = {km_true:g} N/mm, cm = {cm:g} N s/mm, tau = {cm / km_true:g} s "
        "(corner 2.12 Hz). x in mm, F in N. Records: sines x = -A cos(2 pi f t), A = 5 mm, "
        f"{cyc} cycles, {spc} samples per cycle, f = {freqs} Hz; and two filtered-random records "
        "RND_A8_f3 / RND_A6_f6: white noise (seeds 23100 / 23101) through a causal 4th-order "
        "Butterworth low-pass at 3 / 6 Hz on a 2 kHz grid, 0.5 s raised-cosine fades, scaled to "
        "peak 8 / 6 mm, 8 s sampled at 200 Hz (x piecewise linear on the 2 kHz grid; conditions "
        "amplitude = peak, frequency_hz = cut-off). Integrator: exact exponential "
        "(first-order-hold) recursion on a grid 10x finer than the samples. Nominal variant: "
        "km -> 1e9 (pure dashpot cm). Held out: A5_f8 (highest frequency, extrapolation); "
        "validation A5_f2."
    )
    return dict(
        effects=("relaxation",),
        base_law="spring + viscous",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=1.5,
        noise_model=("ar1", 0.8),
        seed=23001,
        records=recs,
        held_out=["A5_f8"],
        validation=["A5_f2"],
        description=desc,
    )


# ---------------------------------------------------------------- 14 SLS oscillator, pressure
_AIR = dict(m=4.0, c=5.0, kp=8.0, kmp=6.0, tau=0.04)


def sls_oscillator_matrices(m, c, k, km, tau):
    """States (x, v, Fm): m x'' + c x' + k x + Fm = u, Fm' = km x' - Fm/tau."""
    A = np.array([[0.0, 1.0, 0.0], [-k / m, -c / m, -1.0 / m], [0.0, km, -1.0 / tau]])
    B = np.array([0.0, 1.0 / m, 0.0])
    C = np.array([1.0, 0.0, 0.0])
    return A, B, C


def _spec_air_spring_relaxation_oscillator(off):
    p = _AIR
    levels = [150.0, 200.0, 250.0, 300.0, 350.0, 400.0]
    fs, T, ramp, refine = 250.0, 6.0, 0.5, 8
    amps, freqs, phases = _ms_design(24003, 0.5, 10.0, 20, corner=6.0)
    tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
    uf, _ = tapered_multisine(tf, amps, freqs, phases, T, ramp)
    uf = uf * (40.0 / np.max(np.abs(uf)))
    recs = []
    for pk in levels:
        k = p["kp"] * pk
        km = 0.0 if off else p["kmp"] * pk
        A, B, C = sls_oscillator_matrices(p["m"], p["c"], k, km, p["tau"])
        xf = lti_foh_response(A, B, C, tf[1] - tf[0], uf)
        sl = slice(None, None, refine)
        recs.append(_rec(f"p{pk:g}", tf[sl], uf[sl], 1000.0 * xf[sl], {"pressure_kpa": pk}))
    desc = (
        "Mass on an air spring with viscoelastic relaxation (standard linear solid), stiffness "
        "proportional to pressure p (kPa): m x'' + c x' + k(p) x + Fm = u, "
        f"Fm' = km(p) x' - Fm/tau, k(p) = {p['kp']:g} p N/m, km(p) = {p['kmp']:g} p N/m, "
        f"tau = {p['tau']:g} s, m = {p['m']:g} kg, c = {p['c']:g} N s/m; from rest. Input "
        f"u = force in N, output displacement in mm. Levels p = {levels} kPa, one record each, "
        "same input: tapered multisine (20 tones 0.5-10 Hz, amplitudes 1/sqrt(1+(f/6)^4), "
        "random phases seed 24003, 0.5 s fades, peak 40 N), 6 s at 250 Hz. Integrator: exact "
        "first-order-hold discretisation of the 3-state linear system (matrix exponential) on a "
        "grid 8x finer than the samples. Nominal variant: km = 0. Held out: p400 (highest, "
        "extrapolation); validation p250."
    )
    return dict(
        effects=("relaxation",),
        base_law="oscillator(mass, viscous, spring)",
        kind="oscillator",
        units={"x": "N", "y": "mm", "t": "s"},
        noise_sd=0.1,
        noise_model=("ar1", 0.6),
        seed=24001,
        records=recs,
        held_out=["p400"],
        validation=["p250"],
        description=desc,
    )


# ---------------------------------------------------------------- 15 Dahl
def _spec_dahl_friction_damper(off):
    k, c, Fc, sigma = 12.0, 0.4, 60.0, 120.0
    sigma_true = sigma
    if off:
        sigma = None
    spc, cyc, refine = 400, 3, 10
    tests = [(1.0, 1.0), (2.0, 0.5), (2.0, 2.0), (4.0, 1.0), (8.0, 1.0)]

    def fric(xf, vf):
        if sigma is None:
            return Fc * sign_exact(vf)
        return dahl_operator(xf, Fc, sigma, F0=-Fc)

    recs = []
    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        Fd = fric(xf, vf)
        sl = slice(None, None, refine)
        recs.append(_rec(_sine_name("A", A, f), tf[sl], xf[sl], k * xf[sl] + c * vf[sl] + Fd[sl], _af(A, f)))
    f0, A = 1.0, 4.0
    tf = np.arange(int(round(3 * spc * refine)) + 1) / (f0 * spc * refine)
    xf, vf = cos_sum(tf, [3.0, 1.0], [f0, 5.0 * f0])
    Fd = fric(xf, vf)
    sl = slice(None, None, refine)
    recs.append(_rec("MS_A4_f1", tf[sl], xf[sl], k * xf[sl] + c * vf[sl] + Fd[sl], _af(A, f0)))
    desc = (
        "Dry-friction damper with Dahl pre-sliding (rate-independent smooth hysteresis): "
        "F = k x + c v + Fd, dFd/dx = sigma (1 - (Fd/Fc) sgn(x')), Fd(0) = -Fc (after the move "
        f"down to -A). k = {k:g} N/mm, c = {c:g} N s/mm, Fc = {Fc:g} N, sigma = {sigma_true:g} "
        f"N/mm (pre-sliding length Fc/sigma = {Fc / sigma_true:g} mm). x in mm, F in N. Records: "
        f"sines x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, (A mm, f Hz) = "
        f"{tests}; and MS_A4_f1: x = -(3 cos(2 pi t) + cos(10 pi t)) mm (minor loops), 3 s at "
        "400 Hz. Integrator: exact Dahl recursion Fd <- s Fc + (Fd - s Fc) exp(-sigma |dx| / Fc) "
        "on a 10x finer grid (exact for inputs monotone between grid points). Nominal variant: "
        "ideal Coulomb Fc sgn(v) (sigma -> inf). Held out: A8_f1 (largest amplitude); "
        "validation A2_f2."
    )
    return dict(
        effects=("hysteretic",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=1.5,
        noise_model=("lowpass", 2, 0.3),
        seed=25001,
        records=recs,
        held_out=["A8_f1"],
        validation=["A2_f2"],
        description=desc,
    )


# ---------------------------------------------------------------- 16 Bouc-Wen MR, current
_BW = dict(xy=0.8, n=1.5, beta=0.65, gamma=0.35)


def _spec_mr_bouc_wen_damper(off):
    k = 5.0
    levels = [0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75]
    fs, T = 400.0, 3.0
    amps, freqs = [8.0, 2.0], [1.0, 4.2]
    t = np.arange(int(round(T * fs)) + 1) / fs
    x, v = cos_sum(t, amps, freqs)
    if off:
        z = sign_exact(v)
    else:
        z = simulate_bouc_wen(t, amps, freqs, _BW, z0=-1.0)
    recs = []
    for cur in levels:
        alpha = 40.0 + 160.0 * cur
        c = 0.5 * math.exp(0.9 * cur)
        y = k * x + c * v + alpha * z
        recs.append(_rec(f"I{cur:g}", t, x, y, {"current_a": cur}))
    desc = (
        "Magnetorheological damper, own Bouc-Wen form, yield force and viscosity grow with "
        "coil current I (A): F = k x + c(I) v + alpha(I) z, z' = (v/xy) [1 - |z|^n (gamma + "
        "beta sgn(v z))], beta + gamma = 1 so |z| <= 1, z(0) = -1. "
        f"k = {k:g} N/mm, alpha(I) = 40 + 160 I N (linear), c(I) = 0.5 exp(0.9 I) N s/mm "
        f"(exponential), xy = {_BW['xy']:g} mm, n = {_BW['n']:g}, beta = {_BW['beta']:g}, "
        f"gamma = {_BW['gamma']:g}. x in mm, F in N. Currents {levels} A, one record each with "
        "the same input x = -(8 cos(2 pi t) + 2 cos(2 pi 4.2 t)) mm (from rest at -10 mm, minor "
        "reversals), 3 s at 400 Hz. Integrator: scipy solve_ivp DOP853 for z with the analytic "
        "velocity, rtol 1e-10, atol 1e-12, max_step = sample interval / 10. Nominal variant: "
        "z = sgn(v) (ideal Coulomb, xy -> 0). Held out: I1 (middle level) and I1.75 (highest, "
        "extrapolation); validation I0.5."
    )
    return dict(
        effects=("hysteretic",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=3.0,
        noise_model=("white",),
        seed=26001,
        records=recs,
        held_out=["I1", "I1.75"],
        validation=["I0.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 17 asymmetric viscous
def _spec_asymmetric_viscous_damper(off):
    k, cbar, dc, dl = 8.0, 1.2, 0.5, 2.0
    dc_true = dc
    if off:
        dc = 0.0
    spc, cyc = 80, 4
    tests = [(10.0, 0.5), (10.0, 1.0), (10.0, 2.0), (20.0, 1.0), (20.0, 2.0), (30.0, 1.5)]
    recs = []
    for A, f in tests:
        t, x, v = sine_input(A, f, cyc, spc)
        y = k * x + (cbar + dc * sign_algebraic(v, dl)) * v
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Hydraulic damper with different damping in extension and compression: F = k x + "
        "c(v) v, c(v) = cbar + dc v / sqrt(v^2 + delta^2) "
        f"(-> {cbar + dc_true:g} N s/mm in extension v > 0, {cbar - dc_true:g} in compression). "
        f"k = {k:g} N/mm, cbar = {cbar:g} N s/mm, dc = {dc_true:g} N s/mm, delta = {dl:g} mm/s. "
        f"x in mm, F in N. Sines x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, "
        f"(A mm, f Hz) = {tests}. Closed form with the analytic velocity. Nominal variant: "
        "dc = 0. Held out: A30_f1.5 (largest amplitude); validation A20_f1."
    )
    return dict(
        effects=("asymmetry",),
        base_law="spring + viscous",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=4.0,
        noise_model=("ar1", 0.9),
        seed=27001,
        records=recs,
        held_out=["A30_f1.5"],
        validation=["A20_f1"],
        description=desc,
    )


# ---------------------------------------------------------------- 18 cogging
def _spec_cogging_rotary_damper(off):
    kth, c, Tc, dl = 0.05, 0.004, 1.5, 0.5
    Tcog, period, ph = 0.8, 15.0, 0.6
    Tcog_true = Tcog
    if off:
        Tcog = 0.0
    spc, cyc = 250, 2
    tests = [(30.0, 0.5), (45.0, 1.0), (60.0, 0.25), (60.0, 0.5), (90.0, 0.25), (120.0, 0.25)]
    recs = []
    for A, f in tests:
        t, x, v = sine_input(A, f, cyc, spc)
        y = kth * x + c * v + Tc * sign_erf(v, dl) + Tcog * np.sin(TWO_PI * x / period + ph)
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Rotary friction damper on a motor with magnetic cogging (position-periodic detent "
        "torque): T = kth th + c w + Tc erf(w/delta) + Tcog sin(2 pi th / p + phase), w = th'. "
        f"kth = {kth:g} Nm/deg, c = {c:g} Nm s/deg, Tc = {Tc:g} Nm, delta = {dl:g} deg/s, "
        f"Tcog = {Tcog_true:g} Nm, period p = {period:g} deg (24 detents per turn), "
        f"phase = {ph:g} rad. th in deg, T in Nm. Sines th = -A cos(2 pi f t), {cyc} cycles, "
        f"{spc} samples per cycle, (A deg, f Hz) = {tests}. Closed form with the analytic "
        "velocity. Nominal variant: Tcog = 0. Held out: A120_f0.25 (largest amplitude); "
        "validation A60_f0.5."
    )
    return dict(
        effects=("outside",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "deg", "y": "Nm", "t": "s"},
        noise_sd=0.08,
        noise_model=("white",),
        seed=28001,
        records=recs,
        held_out=["A120_f0.25"],
        validation=["A60_f0.5"],
        description=desc,
    )


# ---------------------------------------------------------------- 19 end stop
_ENDSTOP = dict(m=1.0, k=250.0, c=0.8, kc=4000.0, g=0.015)


def _spec_endstop_contact_oscillator(off):
    p = dict(_ENDSTOP)
    if off:
        p["kc"] = 0.0
    spc = 60
    tests = [(2.0, 1.5, 4), (3.0, 2.0, 5), (3.0, 3.5, 5), (4.0, 2.5, 5), (6.0, 2.5, 5)]
    recs = []
    for F0, f, ncyc in tests:
        t = np.arange(ncyc * spc + 1) / (f * spc)
        u = F0 * np.sin(TWO_PI * f * t)
        x = simulate_endstop_oscillator(t, F0, f, p)
        recs.append(_rec(_sine_name("F", F0, f), t, u, 1000.0 * x, _af(F0, f)))
    desc = (
        "Mass-spring-damper whose travel is limited by elastic end stops beyond a gap: "
        "m x'' + c x' + k x + kc max(|x| - g, 0) sgn(x) = u, "
        f"m = {p['m']:g} kg, k = {p['k']:g} N/m (2.52 Hz), c = {p['c']:g} N s/m, "
        f"kc = {_ENDSTOP['kc']:g} N/m, g = {p['g']:g} m (15 mm); from rest. Input u = force "
        "in N, output displacement in mm. Sines F0 sin(2 pi f t) (F0 N, f Hz, cycles) = "
        f"{tests} at 60 samples per cycle. Integrator: scipy solve_ivp DOP853, rtol 1e-10, "
        "atol 1e-13, max_step = sample interval / 10 (exact piecewise-linear contact law, no "
        "smoothing). Nominal variant: kc = 0. Held out: F6_f2.5 (largest force, deepest "
        "contact); validation F3_f2."
    )
    return dict(
        effects=("outside",),
        base_law="oscillator(mass, viscous, spring)",
        kind="oscillator",
        units={"x": "N", "y": "mm", "t": "s"},
        noise_sd=0.3,
        noise_model=("ar1", 0.4),
        seed=29001,
        records=recs,
        held_out=["F6_f2.5"],
        validation=["F3_f2"],
        description=desc,
    )


# =============================================================================
# Public case functions
# =============================================================================


def _make_case_fn(name, spec_fn, effects):
    def fn(noise: bool = True, nominal=False) -> BlindCase:
        return _build(name, spec_fn, effects, noise, nominal)

    fn.__name__ = name
    fn.__qualname__ = name
    fn.__doc__ = (
        f"Blind case {name!r} (effects: {', '.join(effects) or 'none'}).  noise=False: noise-free "
        "truth.  nominal=True: the same experiment with every effect switched off; "
        "nominal=<effect name or iterable of names>: only those switched off (diagnostics only)."
    )
    fn.effects = tuple(effects)
    return fn


clean_symmetric_damper = _make_case_fn("clean_symmetric_damper", _spec_clean_symmetric_damper, ())
clean_pressure_cubic_damper = _make_case_fn("clean_pressure_cubic_damper", _spec_clean_pressure_cubic_damper, ())
clean_linear_oscillator = _make_case_fn("clean_linear_oscillator", _spec_clean_linear_oscillator, ())
clean_duffing_oscillator = _make_case_fn("clean_duffing_oscillator", _spec_clean_duffing_oscillator, ())
play_friction_damper = _make_case_fn("play_friction_damper", _spec_play_friction_damper, ("play",))
play_stribeck_rotary_damper = _make_case_fn(
    "play_stribeck_rotary_damper", _spec_play_stribeck_rotary_damper, ("play", "stribeck")
)
stribeck_friction_damper = _make_case_fn("stribeck_friction_damper", _spec_stribeck_friction_damper, ("stribeck",))
stribeck_oscillator = _make_case_fn("stribeck_oscillator", _spec_stribeck_oscillator, ("stribeck",))
travel_softening_damper = _make_case_fn("travel_softening_damper", _spec_travel_softening_damper, ("travel_stiffness",))
travel_friction_damper = _make_case_fn("travel_friction_damper", _spec_travel_friction_damper, ("travel_friction",))
thermal_drift_viscous_damper = _make_case_fn(
    "thermal_drift_viscous_damper", _spec_thermal_drift_viscous_damper, ("drift",)
)
asymmetric_friction_drift_damper = _make_case_fn(
    "asymmetric_friction_drift_damper", _spec_asymmetric_friction_drift_damper, ("asymmetry", "drift")
)
maxwell_relaxation_damper = _make_case_fn("maxwell_relaxation_damper", _spec_maxwell_relaxation_damper, ("relaxation",))
air_spring_relaxation_oscillator = _make_case_fn(
    "air_spring_relaxation_oscillator", _spec_air_spring_relaxation_oscillator, ("relaxation",)
)
dahl_friction_damper = _make_case_fn("dahl_friction_damper", _spec_dahl_friction_damper, ("hysteretic",))
mr_bouc_wen_damper = _make_case_fn("mr_bouc_wen_damper", _spec_mr_bouc_wen_damper, ("hysteretic",))
asymmetric_viscous_damper = _make_case_fn("asymmetric_viscous_damper", _spec_asymmetric_viscous_damper, ("asymmetry",))
cogging_rotary_damper = _make_case_fn("cogging_rotary_damper", _spec_cogging_rotary_damper, ("outside",))
endstop_contact_oscillator = _make_case_fn("endstop_contact_oscillator", _spec_endstop_contact_oscillator, ("outside",))

CASES = [
    clean_symmetric_damper,
    clean_pressure_cubic_damper,
    clean_linear_oscillator,
    clean_duffing_oscillator,
    play_friction_damper,
    play_stribeck_rotary_damper,
    stribeck_friction_damper,
    stribeck_oscillator,
    travel_softening_damper,
    travel_friction_damper,
    thermal_drift_viscous_damper,
    asymmetric_friction_drift_damper,
    maxwell_relaxation_damper,
    air_spring_relaxation_oscillator,
    dahl_friction_damper,
    mr_bouc_wen_damper,
    asymmetric_viscous_damper,
    cogging_rotary_damper,
    endstop_contact_oscillator,
]

CASE_NAMES = [fn.__name__ for fn in CASES]


def case(name: str, noise: bool = True, nominal=False) -> BlindCase:
    """Build the case called ``name``."""
    for fn in CASES:
        if fn.__name__ == name:
            return fn(noise=noise, nominal=nominal)
    raise KeyError(f"unknown blind case {name!r}; known: {', '.join(CASE_NAMES)}")
