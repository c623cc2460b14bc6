"""Blind cases 18-19, effects outside every library family: a rotary damper with cogging and an oscillator
against end stops (``solve_ivp`` DOP853)."""

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import sine_input
from .integrators import simulate_endstop_oscillator
from .operators import TWO_PI, sign_erf


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
