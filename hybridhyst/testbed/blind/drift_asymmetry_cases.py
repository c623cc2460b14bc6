"""Blind cases 11, 12 and 17, drift and asymmetry: a viscous damper whose damping drifts with a thermal state
(``solve_ivp`` DOP853), a friction damper with direction-dependent levels and a thermal drift (own Crank-Nicolson),
and a viscous damper whose damping depends on the direction of motion."""

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import sine_input
from .integrators import simulate_thermal_viscous, thermal_friction_cn
from .operators import sign_algebraic

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
