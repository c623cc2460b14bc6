"""Blind cases 5-8, play and Stribeck friction: a friction damper behind a play, a rotary damper with play
and Stribeck friction, a Stribeck friction damper and a Stribeck oscillator (``solve_ivp`` LSODA)."""

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import cos_sum, sine_input
from .integrators import simulate_stribeck_oscillator
from .operators import TWO_PI, play_operator, play_velocity, sign_algebraic, sign_exact


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
