"""Blind cases 1-4, the clean controls (no effect beyond the base law): a symmetric friction damper, a
pressurised damper with a cubic spring whose parameters follow the pressure, a linear oscillator (exact
first-order hold) and a Duffing oscillator (own implicit midpoint rule). Also the oscillators' sine-record helper
and the linear oscillator's state-space matrices."""

import math

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import _ms_design, sine_input, tapered_multisine
from .integrators import duffing_midpoint
from .operators import TWO_PI, lti_foh_response, sign_exact


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
