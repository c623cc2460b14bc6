"""Damper cases: imposed displacement (mm) or angle (rad) in, force or torque out."""

from __future__ import annotations

import math

import numpy as np

from . import ops
from .core import Chirp, Decaying, Multisine, RampHold, Sine, fine, finish, grid, record, sine_name, switched_off

DAMPER = "damper"


def _sine_plan(plan, fs, unit):
    """[(A, f, cycles)] -> [(name, Sine, t, conditions)]."""
    out = []
    for amp, freq, cycles in plan:
        out.append((sine_name(amp, freq, unit), Sine(amp, freq), grid(fs, cycles / freq), {"amplitude": amp,
                                                                                            "frequency_hz": freq}))
    return out


# ----------------------------------------------------------------------------------------------------------------------
# Clean controls
# ----------------------------------------------------------------------------------------------------------------------


def clean_linear_damper(noise=True, nominal=False):
    effects = ()
    off = switched_off(nominal, effects)
    k, c = 12.0, 0.8
    fs = 200.0
    plan = [(2, 0.5, 3), (10, 0.5, 3), (2, 2, 6), (10, 2, 6), (5, 0.5, 3), (5, 1, 4)]
    recs = []
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        recs.append(record(name, t, x, k * x + c * v, **cond))
    return finish(
        name="clean_linear_damper", effects=effects, off=off,
        law="F = k x + c v",
        params=f"k = {k} N/mm, c = {c} N s/mm",
        integrator="none needed: closed-form output from the analytic x(t), v(t)",
        sampling="sines x = A sin(2 pi f t) [mm], fs = 200 Hz (100-400 samples per cycle), whole cycles",
        initial="t = 0 at x = 0 moving up; the law has no memory",
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=0.5, noise_model=("white",), records=recs,
        held_out=["sine_A5mm_f1Hz"], validation=["sine_A5mm_f0.5Hz"], noise=noise, seed=1101,
    )


def clean_pressure_coulomb_damper(noise=True, nominal=False):
    effects = ()
    off = switched_off(nominal, effects)
    eps = 0.5  # mm/s
    fs = 500.0
    recs = []
    for p in (2.0, 4.0, 6.0, 8.0):
        k = 0.20 + 0.05 * p
        c = 0.010 * (1.0 + 0.25 * p**1.3)
        fc = 0.05 + 0.03 * p
        for name, sig, t, cond in _sine_plan([(8, 1, 2), (4, 3, 6)], fs, "mm"):
            x, v = sig.x(t), sig.v(t)
            y = k * x + c * v + fc * ops.smooth_sign(v, eps)
            recs.append(record(f"p{p:g}bar_{name}", t, x, y, pressure_bar=p, **cond))
    return finish(
        name="clean_pressure_coulomb_damper", effects=effects, off=off,
        law="F = k(p) x + c(p) v + Fc(p) tanh(v / eps)",
        params=("k(p) = 0.20 + 0.05 p kN/mm, c(p) = 0.010 (1 + 0.25 p^1.3) kN s/mm, Fc(p) = 0.05 + 0.03 p kN "
                "(p = charge pressure in bar, condition pressure_bar in {2, 4, 6, 8}), eps = 0.5 mm/s"),
        integrator="none needed: closed-form output from the analytic x(t), v(t)",
        sampling="at each pressure: sine 8 mm at 1 Hz (2 cycles) and 4 mm at 3 Hz (6 cycles), fs = 500 Hz "
                 "(500 and 167 samples per cycle)",
        initial="t = 0 at x = 0 moving up; no memory",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "mm", "y": "kN"}, mass_kg=None,
        noise_sd=0.01, noise_model=("ar1", 0.7), records=recs,
        held_out=["p6bar_sine_A8mm_f1Hz", "p6bar_sine_A4mm_f3Hz"], validation=["p4bar_sine_A4mm_f3Hz"],
        noise=noise, seed=1102,
    )


# ----------------------------------------------------------------------------------------------------------------------
# Single effects
# ----------------------------------------------------------------------------------------------------------------------


def play_linkage_damper(noise=True, nominal=False):
    effects = ("play",)
    off = switched_off(nominal, effects)
    k, c, r = 20.0, 1.5, 0.5
    fs, q = 400.0, 16
    plan = [(1.5, 1, 3), (4, 1, 3), (1.5, 4, 8), (2.5, 2, 5), (4, 4, 8), (2.5, 1, 3)]
    recs = []
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        if "play" in off:
            y = k * x + c * v
        else:
            tf = fine(t, q)
            _, force = ops.backlash_linkage(sig.x(tf), sig.v(tf), r, k, c, tf[1] - tf[0])
            y = force[::q]
        recs.append(record(name, t, x, y, **cond))
    return finish(
        name="play_linkage_damper", effects=effects, off=off,
        law=("spring k parallel to dashpot c (massless piston z) driven through a pin with clearance +-r: "
             "|x - z| <= r; free: c z' + k z = 0; in contact z' = x'; F = k z + c z' (0 while free)"),
        params=f"k = {k} N/mm, c = {c} N s/mm, r = {r} mm (total free play 1.0 mm)",
        integrator=("exact exponential relaxation of the free piston + projection onto the contact, on a grid 16x "
                    "finer than the samples (step 1/6400 s), force read at the samples"),
        sampling="sines, fs = 400 Hz (100-400 samples per cycle)",
        initial="every record starts with the piston centred at z = 0 and x = 0 (at rest)",
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=1.0, noise_model=("white",), records=recs,
        held_out=["sine_A2.5mm_f2Hz"], validation=["sine_A2.5mm_f1Hz"], noise=noise, seed=1105,
    )


def stribeck_rotary_damper(noise=True, nominal=False):
    effects = ("stribeck",)
    off = switched_off(nominal, effects)
    k, c, tc, ts, ws, eps = 3.0, 0.4, 1.2, 2.0, 0.15, 0.004
    if "stribeck" in off:
        ts = tc
    fs = 50.0
    plan = [(0.5, 0.05, 1), (1.0, 0.05, 1), (0.5, 0.2, 2), (1.0, 0.5, 3), (0.75, 0.2, 2), (0.5, 0.5, 3)]
    recs = []
    for name, sig, t, cond in _sine_plan(plan, fs, "rad"):
        x, v = sig.x(t), sig.v(t)
        level = tc + (ts - tc) * np.exp(-((v / ws) ** 2))
        recs.append(record(name, t, x, k * x + c * v + level * ops.smooth_sign(v, eps), **cond))
    return finish(
        name="stribeck_rotary_damper", effects=effects, off=off,
        law="T = k x + c w + [Tc + (Ts - Tc) exp(-(w / ws)^2)] tanh(w / eps)   (x angle, w angular speed)",
        params=(f"k = {k} Nm/rad, c = {c} Nm s/rad, Tc = {tc} Nm (kinetic), Ts = 2.0 Nm (static), "
                f"ws = {ws} rad/s, eps = {eps} rad/s"),
        integrator="none needed: closed-form output from the analytic angle and speed",
        sampling="slow sines, fs = 50 Hz (1000 samples per cycle at 0.05 Hz, 100 at 0.5 Hz)",
        initial="t = 0 at x = 0 moving up; no memory",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "rad", "y": "Nm"}, mass_kg=None,
        noise_sd=0.03, noise_model=("white",), records=recs,
        held_out=["sine_A0.75rad_f0.2Hz"], validation=["sine_A0.5rad_f0.5Hz"], noise=noise, seed=1107,
    )


def travel_stiffness_damper(noise=True, nominal=False):
    effects = ("travel_stiffness",)
    off = switched_off(nominal, effects)
    k0, a, s0, c, s_init = 50.0, 0.35, 500.0, 0.6, 150.0
    fs, q = 250.0, 20

    def stiffness(s):
        return k0 * (1.0 - a * (1.0 - np.exp(-s / s0)))

    plan = [(3, 1, 5), (10, 1, 5), (6, 2, 8), (3, 3, 10), (10, 3, 10), (6, 1, 5)]
    recs = []
    travel = s_init
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        s = ops.cumulative_travel(sig.x(fine(t, q)), travel)
        travel = s[-1] + abs(sig.x(t[-1] + 1.0 / fs) - x[-1])  # the record ends one sample before its last cycle ends
        k = stiffness(np.full(t.size, s_init) if "travel_stiffness" in off else s[::q])
        recs.append(record(name, t, x, k * x + c * v, **cond))
    return finish(
        name="travel_stiffness_damper", effects=effects, off=off,
        law="F = k(s) x + c v, k(s) = k0 [1 - a (1 - exp(-s / s0))], s = cumulative travel (integral of |v| dt)",
        params=(f"k0 = {k0} N/mm, a = {a}, s0 = {s0} mm, c = {c} N s/mm; elastomer spring softening with use; "
                f"travel before the first record s = {s_init} mm, carried from record to record in test order"),
        integrator="travel = running sum of |dx| on a grid 20x finer than the samples; output closed form",
        sampling="sines, fs = 250 Hz (83-250 samples per cycle)",
        initial="device run in for 150 mm of travel before recording; travel accumulates across records",
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=1.5, noise_model=("lowpass", 2, 0.3), records=recs,
        held_out=["sine_A6mm_f2Hz"], validation=["sine_A6mm_f1Hz"], noise=noise, seed=1109,
    )


def travel_friction_damper(noise=True, nominal=False):
    effects = ("travel_friction",)
    off = switched_off(nominal, effects)
    k, c, f0, finf, sr, eps = 8.0, 0.3, 40.0, 22.0, 600.0, 1.0
    fs, q = 100.0, 20

    def level(s):
        return finf + (f0 - finf) * np.exp(-s / sr)

    runs = [
        ("multisine_rms4mm_a", Multisine(0.2, 3.0, 8, 4.0, seed=11, fade=1.0), grid(fs, 20.0), {"rms": 4.0}),
        ("sine_A5mm_f0.5Hz", Sine(5, 0.5), grid(fs, 6.0), {"amplitude": 5, "frequency_hz": 0.5}),
        ("sine_A8mm_f1Hz", Sine(8, 1.0), grid(fs, 4.0), {"amplitude": 8, "frequency_hz": 1.0}),
        ("sine_A12mm_f0.5Hz", Sine(12, 0.5), grid(fs, 6.0), {"amplitude": 12, "frequency_hz": 0.5}),
        ("sine_A5mm_f2Hz", Sine(5, 2.0), grid(fs, 4.0), {"amplitude": 5, "frequency_hz": 2.0}),
        ("multisine_rms4mm_b", Multisine(0.2, 3.0, 8, 4.0, seed=12, fade=1.0), grid(fs, 20.0), {"rms": 4.0}),
    ]
    recs = []
    travel = 0.0
    for name, sig, t, cond in runs:
        x, v = sig.x(t), sig.v(t)
        s = ops.cumulative_travel(sig.x(fine(t, q)), travel)
        travel = s[-1]
        fc = np.full(t.size, f0) if "travel_friction" in off else level(s[::q])
        recs.append(record(name, t, x, k * x + c * v + fc * ops.smooth_sign(v, eps), **cond))
    return finish(
        name="travel_friction_damper", effects=effects, off=off,
        law="F = k x + c v + Fc(s) tanh(v / eps), Fc(s) = Fc_inf + (Fc0 - Fc_inf) exp(-s / sr), s = cumulative travel",
        params=(f"k = {k} N/mm, c = {c} N s/mm, Fc0 = {f0} N (new seal), Fc_inf = {finf} N (run in), sr = {sr} mm, "
                f"eps = {eps} mm/s"),
        integrator="travel = running sum of |dx| on a grid 20x finer than the samples; output closed form",
        sampling=("fs = 100 Hz; multisines of 8 equal tones 0.2-3 Hz (random phases, 1 s raised-cosine fade-in, "
                  "rms 4 mm, 20 s) and sines (50-200 samples per cycle)"),
        initial="new device: travel 0 at the start of the first record, carried across records in test order",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=1.0, noise_model=("lowpass", 4, 0.2), records=recs,
        held_out=["sine_A8mm_f1Hz"], validation=["multisine_rms4mm_b"], noise=noise, seed=1110,
    )


def drift_viscous_damper(noise=True, nominal=False):
    effects = ("drift",)
    off = switched_off(nominal, effects)
    k, c0, beta, heat_cap, r_th, amb = 0.3, 0.05, 0.02, 1000.0, 0.3, 20.0
    tau = heat_cap * r_th
    pause = 20.0
    fs, sub = 200.0, 1
    plan = [(15, 2, 20), (5, 2, 20), (10, 2, 20), (15, 1, 10), (10, 1, 10), (20, 2, 20)]

    def visc(temp):
        return c0 * math.exp(-beta * (temp - amb))

    recs = []
    temp = amb
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        if "drift" in off:
            y = k * x + c0 * v
        else:
            def rhs(s, u):
                return [(visc(s[0]) * u[0] * u[0] - (s[0] - amb) / r_th) / heat_cap]

            temps = ops.rk4(rhs, [temp], t, sub, lambda tt, sig=sig: sig.v(tt))[:, 0]
            y = k * x + c0 * np.exp(-beta * (temps - amb)) * v
            temp = ops.cool(float(temps[-1]), amb, tau, pause)
        recs.append(record(name, t, x, y, **cond))
    return finish(
        name="drift_viscous_damper", effects=effects, off=off,
        law=("F = k x + c(T) v, c(T) = c0 exp(-beta (T - Ta)); oil temperature C dT/dt = c(T) v^2 - (T - Ta) / R "
             "(heated by the dissipated power, Newtonian cooling)"),
        params=(f"k = {k} kN/mm, c0 = {c0} kN s/mm, beta = {beta} 1/K, C = {heat_cap} J/K, R = {r_th} K/W "
                f"(tau = {tau:g} s), Ta = {amb} degC; 1 kN mm/s = 1 W"),
        integrator="RK4, 1 step per sample (h = 5 ms) with the exact analytic v(t) at every stage (incl. midpoints)",
        sampling="sines, fs = 200 Hz (100 and 200 samples per cycle), 10 s each",
        initial=(f"oil at Ta = {amb} degC before the first record; records run in test order with an unrecorded "
                 f"{pause:g} s pause between them (exact exponential cooling)"),
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "kN"}, mass_kg=None,
        noise_sd=0.03, noise_model=("white",), records=recs,
        held_out=["sine_A10mm_f2Hz"], validation=["sine_A10mm_f1Hz"], noise=noise, seed=1111,
    )


def asymmetry_damper(noise=True, nominal=False):
    effects = ("asymmetry",)
    off = switched_off(nominal, effects)
    k, c, fpos, fneg, eps = 5.0, 0.2, 60.0, 35.0, 0.5
    if "asymmetry" in off:
        fpos = fneg = 0.5 * (fpos + fneg)
    fs = 100.0
    runs = [(n, s, t, cd) for n, s, t, cd in _sine_plan([(5, 0.5, 3), (15, 0.5, 3), (5, 2, 8), (15, 2, 8)], fs, "mm")]
    runs.insert(2, ("sweep_A10mm_0.2to3Hz", Chirp(10, 0.2, 3.0, 15.0), grid(fs, 15.0), {"amplitude": 10}))
    runs += _sine_plan([(10, 1, 5)], fs, "mm")
    recs = []
    for name, sig, t, cond in runs:
        x, v = sig.x(t), sig.v(t)
        sg = ops.smooth_sign(v, eps)
        fric = 0.5 * (fpos + fneg) * sg + 0.5 * (fpos - fneg) * np.abs(sg)
        recs.append(record(name, t, x, k * x + c * v + fric, **cond))
    return finish(
        name="asymmetry_damper", effects=effects, off=off,
        law="F = k x + c v + Ff, Ff = F+ tanh(v/eps) for v > 0 and F- tanh(v/eps) for v < 0 (F+ != F-)",
        params=f"k = {k} N/mm, c = {c} N s/mm, F+ = 60.0 N (extension), F- = 35.0 N (compression), eps = {eps} mm/s",
        integrator="none needed: closed-form output from the analytic x(t), v(t)",
        sampling="fs = 100 Hz: sines (50-200 samples per cycle) and a linear sweep 0.2 -> 3 Hz over 15 s",
        initial="t = 0 at x = 0; no memory",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=2.0, noise_model=("white",), records=recs,
        held_out=["sine_A10mm_f1Hz"], validation=["sweep_A10mm_0.2to3Hz"], noise=noise, seed=1113,
    )


def relaxation_damper(noise=True, nominal=False):
    effects = ("relaxation",)
    off = switched_off(nominal, effects)
    k, c = 10.0, 0.5
    k1, tau1, k2, tau2 = 15.0, 0.05, 8.0, 0.8
    fs, sub = 250.0, 2
    runs = [("ramp_hold_5mm", RampHold(5.0, 0.1), 4.0, 0.0, {"amplitude": 5.0})]
    for amp, freq, cycles in [(2, 0.25, 2), (2, 5, 10), (4, 1, 4), (3, 2, 6), (4, 5, 10)]:
        runs.append((sine_name(amp, freq, "mm"), Sine(amp, freq), cycles / freq, 2.0 / freq,
                     {"amplitude": amp, "frequency_hz": freq}))
    recs = []
    for name, sig, dur, pre, cond in runs:
        t = grid(fs, dur)
        x, v = sig.x(t), sig.v(t)
        y = k * x + c * v
        if "relaxation" not in off:
            tt = np.concatenate([t[0] - pre + np.arange(int(round(pre * fs))) / fs, t]) if pre > 0 else t
            qs = ops.rk4(lambda s, u: [k1 * u[0] - s[0] / tau1, k2 * u[0] - s[1] / tau2], [0.0, 0.0], tt, sub,
                         lambda z, sig=sig: sig.v(z))
            y = y + qs[-t.size:, 0] + qs[-t.size:, 1]
        recs.append(record(name, t, x, y, **cond))
    return finish(
        name="relaxation_damper", effects=effects, off=off,
        law="F = k x + c v + q1 + q2, Maxwell branches q_i' = k_i v - q_i / tau_i (standard linear solid, 2 branches)",
        params=f"k = {k} N/mm, c = {c} N s/mm, k1 = {k1} N/mm, tau1 = {tau1} s, k2 = {k2} N/mm, tau2 = {tau2} s",
        integrator="RK4, 2 steps per sample (h = 2 ms), exact analytic v(t) at every stage",
        sampling=("fs = 250 Hz: a 5 mm half-cosine ramp (0.1 s) and hold (4 s in all), and sines "
                  "(50-1000 samples per cycle)"),
        initial=("ramp-hold from rest (q = 0); every sine record is preceded by 2 unrecorded cycles of the same sine "
                 "from rest (device cycled before recording)"),
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=0.5, noise_model=("white",), records=recs,
        held_out=["sine_A3mm_f2Hz"], validation=["sine_A4mm_f5Hz"], noise=noise, seed=1114,
    )


def hysteretic_jenkins_damper(noise=True, nominal=False):
    effects = ("hysteretic",)
    off = switched_off(nominal, effects)
    k, c = 6.0, 0.25
    kj, levels = 4.0, (2.0, 5.0, 9.0, 14.0, 20.0)
    fs, q = 200.0, 10
    runs = [("decay_A8mm_f1Hz_virgin", Decaying(8.0, 1.0, 4.0), 10.0, 0.0, {"amplitude": 8.0, "frequency_hz": 1.0})]
    for amp, freq, cycles in [(1, 0.5, 2), (3, 0.5, 2), (6, 0.5, 2), (1, 4, 8), (6, 4, 8), (4.5, 2, 4), (3, 4, 8)]:
        runs.append((sine_name(amp, freq, "mm"), Sine(amp, freq), cycles / freq, 2.0 / freq,
                     {"amplitude": amp, "frequency_hz": freq}))
    recs = []
    for name, sig, dur, pre, cond in runs:
        t = grid(fs, dur)
        x, v = sig.x(t), sig.v(t)
        y = k * x + c * v
        if "hysteretic" not in off:
            tf = fine(np.concatenate([t[0] - pre + np.arange(int(round(pre * fs))) / fs, t]), q)
            xf = sig.x(tf)
            hyst = sum(ops.stop_operator(xf, kj, f) for f in levels)
            y = y + hyst[::q][-t.size:]
        recs.append(record(name, t, x, y, **cond))
    return finish(
        name="hysteretic_jenkins_damper", effects=effects, off=off,
        law=("F = k x + c v + sum_i S_i(x), S_i = Jenkins element (spring k_j in series with a slider of level f_i): "
             "a Prandtl-Ishlinskii stop-operator hysteresis with memory"),
        params=f"k = {k} N/mm, c = {c} N s/mm, k_j = {kj} N/mm for each of 5 elements, f_i = 2, 5, 9, 14, 20 N",
        integrator="exact discrete stop operators on a grid 10x finer than the samples (turning points resolved)",
        sampling=("fs = 200 Hz: a decaying sine 8 exp(-t/4 s) sin(2 pi t) mm from the virgin state, and sines "
                  "(50-400 samples per cycle)"),
        initial=("decay record starts virgin (all elements unloaded); every sine record is preceded by 2 unrecorded "
                 "cycles of the same sine starting from the virgin state"),
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=0.5, noise_model=("white",), records=recs,
        held_out=["sine_A4.5mm_f2Hz"], validation=["sine_A3mm_f4Hz"], noise=noise, seed=1115,
    )


# ----------------------------------------------------------------------------------------------------------------------
# Outside effects
# ----------------------------------------------------------------------------------------------------------------------


def outside_orifice_damper(noise=True, nominal=False):
    effects = ("outside",)
    off = switched_off(nominal, effects)
    k, c, c2 = 0.1, 0.01, 2.0e-5
    if "outside" in off:
        c2 = 0.0
    fs = 500.0
    plan = [(5, 1, 3), (15, 1, 3), (5, 3, 8), (15, 3, 8), (10, 2, 5), (10, 1, 3)]
    recs = []
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        recs.append(record(name, t, x, k * x + c * v + c2 * v * np.abs(v), **cond))
    return finish(
        name="outside_orifice_damper", effects=effects, off=off,
        law="F = k x + c v + c2 v |v|   (outside: turbulent orifice flow adds a quadratic damping force)",
        params=f"k = {k} kN/mm, c = {c} kN s/mm, c2 = 2.0e-05 kN s^2/mm^2",
        integrator="none needed: closed-form output from the analytic x(t), v(t)",
        sampling="sines, fs = 500 Hz (167-500 samples per cycle)",
        initial="t = 0 at x = 0; no memory",
        base_law="F = k x + c v", kind=DAMPER, units={"x": "mm", "y": "kN"}, mass_kg=None,
        noise_sd=0.01, noise_model=("lowpass", 2, 0.25), records=recs,
        held_out=["sine_A10mm_f2Hz"], validation=["sine_A10mm_f1Hz"], noise=noise, seed=1117,
    )


def outside_cogging_actuator(noise=True, nominal=False):
    effects = ("outside",)
    off = switched_off(nominal, effects)
    k, c, tc, eps, tcog, poles = 1.5, 0.05, 0.3, 0.01, 0.25, 12
    if "outside" in off:
        tcog = 0.0
    fs = 100.0
    runs = _sine_plan([(0.5, 0.2, 2), (1.5, 0.2, 2), (0.5, 1, 5), (1.5, 1, 5)], fs, "rad")
    runs.insert(2, ("multisine_rms0.6rad", Multisine(0.05, 1.0, 6, 0.6, seed=18, fade=2.0), grid(fs, 40.0),
                    {"rms": 0.6}))
    runs += _sine_plan([(1.0, 0.5, 3)], fs, "rad")
    recs = []
    for name, sig, t, cond in runs:
        x, v = sig.x(t), sig.v(t)
        y = k * x + c * v + tc * ops.smooth_sign(v, eps) + tcog * np.sin(poles * x)
        recs.append(record(name, t, x, y, **cond))
    return finish(
        name="outside_cogging_actuator", effects=effects, off=off,
        law=("T = k x + c w + Tc tanh(w / eps) + Tcog sin(N x)   (rotary actuator with return spring; outside: "
             "permanent-magnet cogging torque periodic in angle)"),
        params=f"k = {k} Nm/rad, c = {c} Nm s/rad, Tc = {tc} Nm, eps = {eps} rad/s, Tcog = 0.25 Nm, N = {poles}",
        integrator="none needed: closed-form output from the analytic angle and speed",
        sampling=("fs = 100 Hz: sines (100-500 samples per cycle) and a 40 s multisine of 6 tones 0.05-1 Hz "
                  "(rms 0.6 rad, 2 s fade-in)"),
        initial="t = 0 at x = 0 rad; no memory",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "rad", "y": "Nm"}, mass_kg=None,
        noise_sd=0.02, noise_model=("ar1", 0.6), records=recs,
        held_out=["sine_A1rad_f0.5Hz"], validation=["multisine_rms0.6rad"], noise=noise, seed=1118,
    )


# ----------------------------------------------------------------------------------------------------------------------
# Two effects
# ----------------------------------------------------------------------------------------------------------------------


def asymmetry_travel_friction_damper(noise=True, nominal=False):
    effects = ("asymmetry", "travel_friction")
    off = switched_off(nominal, effects)
    k, c, eps, sr, s_init = 4.0, 0.15, 0.5, 800.0, 100.0
    p0, pinf, n0, ninf = 50.0, 30.0, 30.0, 20.0
    fs, q = 200.0, 20
    plan = [(8, 0.5, 4), (3, 2, 8), (5, 1, 6), (8, 2, 8), (3, 0.5, 4), (5, 0.5, 4)]
    recs = []
    travel = s_init
    for name, sig, t, cond in _sine_plan(plan, fs, "mm"):
        x, v = sig.x(t), sig.v(t)
        s = ops.cumulative_travel(sig.x(fine(t, q)), travel)
        travel = s[-1] + abs(sig.x(t[-1] + 1.0 / fs) - x[-1])
        s = np.full(t.size, s_init) if "travel_friction" in off else s[::q]
        fpos = pinf + (p0 - pinf) * np.exp(-s / sr)
        fneg = ninf + (n0 - ninf) * np.exp(-s / sr)
        if "asymmetry" in off:
            fpos = fneg = 0.5 * (fpos + fneg)
        sg = ops.smooth_sign(v, eps)
        recs.append(record(name, t, x, k * x + c * v + 0.5 * (fpos + fneg) * sg + 0.5 * (fpos - fneg) * np.abs(sg),
                           **cond))
    return finish(
        name="asymmetry_travel_friction_damper", effects=effects, off=off,
        law=("F = k x + c v + Ff, Ff = F+(s) tanh(v/eps) for v > 0, F-(s) tanh(v/eps) for v < 0; "
             "F+-(s) = F+-_inf + (F+-_0 - F+-_inf) exp(-s / sr), s = cumulative travel (seal run-in)"),
        params=(f"k = {k} N/mm, c = {c} N s/mm, eps = {eps} mm/s, F+_0 = {p0} N, F+_inf = {pinf} N, "
                f"F-_0 = {n0} N, F-_inf = {ninf} N, sr = {sr} mm"),
        integrator="travel = running sum of |dx| on a grid 20x finer than the samples; output closed form",
        sampling="sines, fs = 200 Hz (100-400 samples per cycle)",
        initial=f"device already run for s = {s_init:g} mm before the first record; travel carried across records",
        base_law="F = k x + c v + coulomb Fc sgn(v)", kind=DAMPER, units={"x": "mm", "y": "N"}, mass_kg=None,
        noise_sd=1.0, noise_model=("white",), records=recs,
        held_out=["sine_A5mm_f1Hz"], validation=["sine_A5mm_f0.5Hz"], noise=noise, seed=1119,
    )
