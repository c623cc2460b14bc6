"""The true laws of the independent discovery test bed: closures over their true values, computed by
``generators`` (numpy/scipy only: exact path operators, exact or other smoothing functions than the library's,
scipy's integrators on finer grids), and seed 000's VPPTD loops with parameters that vary with the
underpressure. Nothing here imports the library's effects, models or simulator.
"""

from __future__ import annotations

import math

import numpy as np

from . import generators as g


def on_fine(law_fine, refine: int = 20):
    """A law computed on a grid ``refine`` times finer than the samples (path operators), then sampled."""

    def law(t, sig):
        tf = g.fine_grid(t, refine)
        return law_fine(tf, sig)[::refine]

    return law


# -- the laws (closures over their true values, computed by generators) ----------------------------------------


def static_law(k=0.0, c=0.0, Fc=0.0, sign="exact", width=0.0, k3=0.0, dF=0.0, dFs=0.0, vs=1.0, m=0.0, tau=0.0,
            cog=(0.0, 1.0)):
    """F = k x + k3 x³ + c v + (Fc + dFs e^{−(v/vs)²}) s + dF |s| + m a + cogging, all read τ late."""

    def law(t, sig):
        td = np.asarray(t) - tau
        x, v, a = sig.x(td), sig.v(td), sig.a(td)
        s = g.sgn(v, sign, width)
        level = Fc + dFs * np.exp(-((v / vs) ** 2))
        return k * x + k3 * x**3 + c * v + level * s + dF * np.abs(s) + m * a + g.cogging(x, *cog)

    return law


def play_law(r, k, c, Fc=0.0, k3=0.0, sign="exact", velocity_scale=1.0, stribeck=(0.0, 1.0)):
    """Forces on the exact play output y: k y + k3 y³ + c s ẏ + (Fc + dFs e^{−(ẏ/vs)²}) sgn ẏ."""

    def fine(tf, sig):
        x, v = sig.x(tf), sig.v(tf)
        y = g.play(x, r)
        dy = g.play_rate(x, v, y, r)
        level = Fc + stribeck[0] * np.exp(-((dy / stribeck[1]) ** 2))
        return k * y + k3 * y**3 + c * velocity_scale * dy + level * g.sgn(dy, sign)

    return fine


def dahl_law(k, c, sigma0, Fc, drift=0.0, sign="erf", width=0.02):
    def fine(tf, sig):
        x, v = sig.x(tf), sig.v(tf)
        z = g.dahl_exact(x, sigma0, Fc)
        out = k * x + c * v + sigma0 * z
        if drift:
            out = out + drift * g.cumulative_travel(x) * g.sgn(v, sign, width)
        return out

    return fine


def drift_law(k, c, Fc, dF, sign="arctan", width=0.01):
    def fine(tf, sig):
        x, v = sig.x(tf), sig.v(tf)
        return k * x + c * v + (Fc + dF * g.cumulative_travel(x)) * g.sgn(v, sign, width)

    return fine


def softening_law(k0, s0, c, Fc, sign="arctan", width=0.01):
    """k(s) x + c v + Fc sgn(v) with a stiffness that softens hyperbolically with the travel s since the record's
    start, k(s) = k0 / (1 + s/s0) (not the library's form, a stiffness linear in s)."""
    def fine(tf, sig):
        x, v = sig.x(tf), sig.v(tf)
        return k0 / (1.0 + g.cumulative_travel(x) / s0) * x + c * v + Fc * g.sgn(v, sign, width)

    return fine


def bw_law(k, c, Fy, xy, n, b):
    def law(t, sig):
        return k * sig.x(t) + c * sig.v(t) + g.bouc_wen_yield(t, sig, Fy, xy, n, b)

    return law


def lugre_law(k, c, **lugre):
    def law(t, sig):
        return k * sig.x(t) + c * sig.v(t) + g.lugre(t, sig, **lugre)

    return law


def clearance_law(k, c, r, sigma0, Fc_pos, Fc_neg, q0=0.0):
    """k x + c v + a Dahl element behind a gap of half-width r (exact per step on the refined path), its state
    q0 at the first point."""

    def fine(tf, sig):
        x = sig.x(tf)
        return k * x + c * sig.v(tf) + g.clearance_dahl(x, r, sigma0, Fc_pos, Fc_neg, q0)

    return fine


def rough_law(k, c, Fc, depth, period, sign="arctan", width=0.01):
    """k x + c v + Fc (1 + depth cos(2π x / period)) sgn(v): a sliding level that varies along the stroke."""

    def law(t, sig):
        x, v = sig.x(t), sig.v(t)
        return k * x + c * v + Fc * (1 + depth * np.cos(2 * math.pi * x / period)) * g.sgn(v, sign, width)

    return law


def maxwell_law(k, c, km, cm):
    def fine(tf, sig):
        v = sig.v(tf)
        return k * sig.x(tf) + c * v + g.maxwell_force(tf, v, km, cm)

    return fine


def mr_lag_law(voltage, c_a, c_b, alpha_a, alpha_b, k, beta, gamma, eta):
    """An MR damper whose field follows the coil voltage v(t) (``voltage``, a ``generators.Schedule``) through a
    first-order lag: u̇ = −η (u − v), u(0) = v(0); F = (c_a + c_b u) ẋ + (α_a + α_b u) z + k x with the Bouc–Wen
    state z (n = 2, A = 1, β, γ; exact in displacement, ``bouc_wen_n2``) and u by the exact exponential
    integrator (``linear_lag``: v is linear between the points of the fine grid but at the staircase's corners)."""

    def fine(tf, sig):
        x, v = sig.x(tf), sig.v(tf)
        volts = voltage(tf)
        u = g.linear_lag(tf, eta * volts, eta, y0=volts[0])
        z = g.bouc_wen_n2(x, beta, gamma)
        return (c_a + c_b * u) * v + (alpha_a + alpha_b * u) * z + k * x

    return fine


def control_friction_law(control, k, c, level, sign="exact", width=0.0):
    """k x + c ẋ + level(p(t)) sgn(ẋ): a friction level that follows a control channel p(t) (``control``, a
    ``generators.Schedule``) within the record; ``level`` a function of p."""

    def law(t, sig):
        v = sig.v(t)
        return k * sig.x(t) + c * v + level(control(t)) * g.sgn(v, sign, width)

    return law


def osc_law(m, c, k, xi=0.0, k3=0.0, Fc=0.0, width=0.02, method="DOP853"):
    def extra(x, v, u):
        return xi * np.abs(x) * u + k3 * x**3 + Fc * g.sgn(v, "arctan", width)

    def law(t, drive):
        return g.oscillator(t, drive, m, c, k, extra if (xi or k3 or Fc) else None, method=method)

    return law


# -- VPPTD (seed 000) ---------------------------------------------------------------------------------------------

PRESSURES = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09]
VPPTD_SPLIT = {"held_out": {"pressure_mpa": [0.05, 0.09]}, "val": {"pressure_mpa": [0.07]}}
RAD = math.pi / 180.0


def p_linear(v0, v1):
    """A parameter rising linearly from v0 at 0.01 MPa to v1 at 0.09 MPa."""
    return lambda p: v0 + (v1 - v0) * (p - 0.01) / 0.08


def p_exp(v0, v1):
    """A parameter rising exponentially from v0 at 0.01 MPa to v1 at 0.09 MPa."""
    return lambda p: v0 * (v1 / v0) ** ((p - 0.01) / 0.08)


def p_const(v):
    return lambda p: v


def vpptd_records(name, c, k, k2, Ms, *, clearance=0.0, stribeck=(0.0, 1.0), tau=0.0, phase=0.0, seed=0,
                   noise=0.2):
    """±10° at 0.8 Hz, 400 Hz sampling (500 samples per cycle, one cycle), at each underpressure; φ in deg,
    φ̇ in rad/s in the viscous term, torque in Nm; exact sign; optional exact play on the angle (mounting
    clearance), Stribeck weakening (dFs [Nm], vs [deg/s]; dFs a constant or, like the base parameters, a function
    of p) and a delay τ [s] of the measured torque; ``phase`` −π/2 starts the test from rest at −10° (what a
    delayed channel needs: the rig is at rest before t = 0). A delayed model holds the first sample, rates
    included, before t0: at rest the two agree but for the acceleration at t = 0, which no law here reads."""
    from ..data.records import Record, RecordSet

    rng = np.random.default_rng(seed)
    out = []
    for p in PRESSURES:
        t = np.arange(501) / 400.0
        sig = g.sine(10.0, 0.8, phase=phase)
        cp, kp, k2p, Mp = c(p), k(p), k2(p), Ms(p)
        weak = (stribeck[0](p) if callable(stribeck[0]) else stribeck[0], stribeck[1])
        if clearance:
            law = on_fine(play_law(clearance, kp, cp, Mp, k3=k2p, velocity_scale=RAD, stribeck=weak), 20)
        else:
            def law(tt, s, cp=cp, kp=kp, k2p=k2p, Mp=Mp, weak=weak):
                td = tt - tau
                x, v = s.x(td), s.v(td)
                level = Mp + weak[0] * np.exp(-((v / weak[1]) ** 2))
                return cp * RAD * v + kp * x + k2p * x**3 + level * g.sgn(v, "exact")
        y = law(t, sig) + g.white_noise(len(t), noise, rng)
        out.append(Record(name=f"p{p:.2f}MPa", t=t, x=sig.x(t), y=y, conditions={"pressure_mpa": p},
                          units={"x": "deg", "y": "Nm"}))
    return RecordSet(out, name)
