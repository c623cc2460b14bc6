"""Blind cases 13-14, relaxation: a damper with a Maxwell branch (exact exponential integrator) and an
oscillator on an air spring whose standard-linear-solid stiffness follows the pressure (exact first-order hold),
with that oscillator's state-space matrices."""

import numpy as np
from scipy import signal

from .building import _af, _rec, _sine_name
from .inputs import _ms_design, _taper, sine_input, tapered_multisine
from .operators import lti_foh_response, maxwell_force


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
