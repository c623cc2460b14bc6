"""Oscillator cases: drive force (N) on a mass in, the mass's displacement out; every record starts at rest."""

from __future__ import annotations

import math

from . import ops
from .core import Chirp, Multisine, Sine, fine, finish, grid, record, round_sig1, sine_name, switched_off

OSC = "oscillator"


def _sine_runs(plan, fs, duration):
    return [(sine_name(a, f, "N"), Sine(a, f), grid(fs, duration), {"amplitude": a, "frequency_hz": f})
            for a, f in plan]


def clean_linear_oscillator(noise=True, nominal=False):
    effects = ()
    off = switched_off(nominal, effects)
    m, c, k = 2.3, 12.0, 8000.0
    fs, q = 500.0, 4
    runs = [
        ("multisine_rms5N_a", Multisine(1.0, 30.0, 30, 5.0, seed=31, fade=0.2), grid(fs, 4.0), {"rms": 5.0}),
        ("sweep_A4N_2to20Hz", Chirp(4.0, 2.0, 20.0, 4.0), grid(fs, 4.0), {"amplitude": 4.0}),
        *_sine_runs([(3, 5), (3, 14), (2, 9)], fs, 2.0),
        ("multisine_rms3N_b", Multisine(1.0, 30.0, 30, 3.0, seed=32, fade=0.2), grid(fs, 3.0), {"rms": 3.0}),
    ]
    recs = []
    for name, sig, t, cond in runs:
        tf = fine(t, q)
        x = ops.linear_oscillator_foh(m, c, k, sig.x(tf), tf[1] - tf[0])[::q]
        recs.append(record(name, t, sig.x(t), 1000.0 * x, **cond))
    return finish(
        name="clean_linear_oscillator", effects=effects, off=off,
        law="m x'' + c x' + k x = u",
        params=f"m = {m} kg (declared {round_sig1(m)} kg), c = {c} N s/m, k = {k} N/m (fn = 9.39 Hz, zeta = 0.044)",
        integrator=("exact first-order-hold discretisation (matrix exponential) on a grid 4x finer than the samples "
                    "(h = 0.5 ms), run as a recursive filter"),
        sampling=("fs = 500 Hz: multisines of 30 equal tones 1-30 Hz (random phases, 0.2 s fade-in), a linear sweep "
                  "2 -> 20 Hz, and sines (36-100 samples per cycle)"),
        initial="each record starts at rest (x = x' = 0, u(0) = 0)",
        base_law="m x'' + c x' + k x = u", kind=OSC, units={"x": "N", "y": "mm"}, mass_kg=round_sig1(m),
        noise_sd=0.005, noise_model=("lowpass", 2, 0.3), records=recs,
        held_out=["sine_A2N_f9Hz"], validation=["multisine_rms3N_b"], noise=noise, seed=1203,
    )


def clean_cubic_oscillator_temperature(noise=True, nominal=False):
    effects = ()
    off = switched_off(nominal, effects)
    m = 0.82
    fs, sub = 400.0, 3
    recs = []
    runs = [(temp, f"T{temp:g}C_sweep_A6N_4to25Hz", Chirp(6.0, 4.0, 25.0, 6.0), grid(fs, 6.0), {"amplitude": 6.0})
            for temp in (10.0, 25.0, 40.0, 55.0)]
    runs.append((25.0, "T25C_" + sine_name(4, 12, "N"), Sine(4.0, 12.0), grid(fs, 2.0),
                 {"amplitude": 4.0, "frequency_hz": 12.0}))
    for temp, name, sig, t, cond in runs:
        k = 5000.0 * (1.0 - 0.006 * (temp - 25.0))
        k3 = 3.0e7 * (1.0 - 0.004 * (temp - 25.0))
        c = 6.0 * math.exp(-0.015 * (temp - 25.0))

        def rhs(s, u, k=k, k3=k3, c=c):
            return [s[1], (u[0] - c * s[1] - k * s[0] - k3 * s[0] ** 3) / m]

        x = ops.rk4(rhs, [0.0, 0.0], t, sub, sig.x)[:, 0]
        recs.append(record(name, t, sig.x(t), x, temperature_c=temp, **cond))
    return finish(
        name="clean_cubic_oscillator_temperature", effects=effects, off=off,
        law="m x'' + c(T) x' + k(T) x + k3(T) x^3 = u   (T = temperature setpoint of the climate chamber)",
        params=(f"m = {m} kg (declared {round_sig1(m)} kg), k(T) = 5000 (1 - 0.006 (T - 25)) N/m, "
                "k3(T) = 3.0e7 (1 - 0.004 (T - 25)) N/m^3, c(T) = 6 exp(-0.015 (T - 25)) N s/m, "
                "T in degC (condition temperature_c in {10, 25, 40, 55})"),
        integrator="RK4, 3 steps per sample (h = 0.83 ms) with the exact analytic force at every stage",
        sampling="fs = 400 Hz: linear sweeps 4 -> 25 Hz over 6 s (16-100 samples per cycle) and a 12 Hz sine",
        initial="each record starts at rest",
        base_law="m x'' + c x' + k x + k3 x^3 (cubic) = u", kind=OSC, units={"x": "N", "y": "m"},
        mass_kg=round_sig1(m), noise_sd=2.0e-5, noise_model=("white",), records=recs,
        held_out=["T40C_sweep_A6N_4to25Hz"], validation=["T25C_sine_A4N_f12Hz"], noise=noise, seed=1204,
    )


def play_gap_oscillator(noise=True, nominal=False):
    effects = ("play",)
    off = switched_off(nominal, effects)
    m, c, k, g = 1.4, 25.0, 3.0e4, 0.3e-3
    if "play" in off:
        g = 0.0
    fs, sub = 1000.0, 4

    def rhs(s, u):
        x = s[0]
        spring = x - g if x > g else (x + g if x < -g else 0.0)
        return [s[1], (u[0] - c * s[1] - k * spring) / m]

    def region(s):
        return int(s[0] > g) - int(s[0] < -g)

    runs = _sine_runs([(10, 10), (40, 10), (15, 20), (40, 25), (25, 15), (25, 10)], fs, 1.2)
    recs = []
    for name, sig, t, cond in runs:
        x = ops.rk4(rhs, [0.0, 0.0], t, sub, sig.x, region=region)[:, 0]
        recs.append(record(name, t, sig.x(t), 1000.0 * x, **cond))
    return finish(
        name="play_gap_oscillator", effects=effects, off=off,
        law="m x'' + c x' + k dz(x) = u, dz(x) = x - clip(x, -g, g): the spring mount has a clearance +-g",
        params=f"m = {m} kg (declared {round_sig1(m)} kg), c = {c} N s/m, k = {k:g} N/m, g = 0.3 mm",
        integrator=("RK4, 4 steps per sample (h = 0.25 ms), exact analytic force at every stage; a step that crosses a "
                    "kink of the dead zone is redone with 16 sub-steps (h = 15.6 us)"),
        sampling="sines, fs = 1000 Hz (40-100 samples per cycle), 1.2 s each",
        initial="each record starts at rest at x = 0 (centre of the clearance)",
        base_law="m x'' + c x' + k x = u", kind=OSC, units={"x": "N", "y": "mm"}, mass_kg=round_sig1(m),
        noise_sd=0.01, noise_model=("ar1", 0.5), records=recs,
        held_out=["sine_A25N_f15Hz"], validation=["sine_A25N_f10Hz"], noise=noise, seed=1206,
    )


def stribeck_oscillator(noise=True, nominal=False):
    effects = ("stribeck",)
    off = switched_off(nominal, effects)
    m, k, c, fc, fs_, vs, eps = 3.2, 2000.0, 4.0, 2.0, 3.5, 0.02, 0.004
    if "stribeck" in off:
        fs_ = fc

    def rhs(s, u):
        v = s[1]
        fr = (fc + (fs_ - fc) * math.exp(-((v / vs) ** 2))) * math.tanh(v / eps)
        return [v, (u[0] - c * v - k * s[0] - fr) / m]

    fs, sub = 500.0, 4
    runs = _sine_runs([(6, 1.5), (12, 1.5), (6, 3), (12, 3), (9, 2), (9, 3)], fs, 2.0)
    recs = []
    for name, sig, t, cond in runs:
        x = ops.rk4(rhs, [0.0, 0.0], t, sub, sig.x)[:, 0]
        recs.append(record(name, t, sig.x(t), 1000.0 * x, **cond))
    return finish(
        name="stribeck_oscillator", effects=effects, off=off,
        law="m x'' + c x' + k x + [Fc + (Fs - Fc) exp(-(x'/vs)^2)] tanh(x'/eps) = u   (mass sliding on a guide)",
        params=(f"m = {m} kg (declared {round_sig1(m)} kg), k = {k} N/m, c = {c} N s/m, Fc = {fc} N, Fs = 3.5 N, "
                f"vs = {vs} m/s, eps = {eps} m/s"),
        integrator="RK4, 4 steps per sample (h = 0.5 ms), exact analytic force at every stage",
        sampling="sines, fs = 500 Hz (167-333 samples per cycle), 2 s each",
        initial="each record starts at rest at x = 0",
        base_law="m x'' + c x' + k x + coulomb Fc sgn(x') = u", kind=OSC, units={"x": "N", "y": "mm"},
        mass_kg=round_sig1(m), noise_sd=0.02, noise_model=("white",), records=recs,
        held_out=["sine_A9N_f2Hz"], validation=["sine_A9N_f3Hz"], noise=noise, seed=1208,
    )


def drift_oscillator(noise=True, nominal=False):
    effects = ("drift",)
    off = switched_off(nominal, effects)
    m, k, c0, beta, heat_cap, r_th, amb = 0.62, 2.4e4, 30.0, 0.03, 8.0, 3.0, 20.0
    tau, pause = heat_cap * r_th, 5.0
    if "drift" in off:
        beta = 0.0

    def rhs(s, u):
        c = c0 * math.exp(-beta * (s[2] - amb))
        return [s[1], (u[0] - c * s[1] - k * s[0]) / m, (c * s[1] * s[1] - (s[2] - amb) / r_th) / heat_cap]

    fs, sub = 1000.0, 3
    runs = _sine_runs([(20, 28), (40, 31), (20, 34), (30, 31), (40, 25)], fs, 2.0)
    recs = []
    temp = amb
    for name, sig, t, cond in runs:
        sol = ops.rk4(rhs, [0.0, 0.0, temp], t, sub, sig.x)
        temp = ops.cool(float(sol[-1, 2]), amb, tau, pause)
        recs.append(record(name, t, sig.x(t), 1000.0 * sol[:, 0], **cond))
    return finish(
        name="drift_oscillator", effects=effects, off=off,
        law=("m x'' + c(T) x' + k x = u, c(T) = c0 exp(-beta (T - Ta)); damper oil temperature "
             "C dT/dt = c(T) x'^2 - (T - Ta) / R"),
        params=(f"m = {m} kg (declared {round_sig1(m)} kg), k = {k:g} N/m (fn = 31.3 Hz), c0 = {c0} N s/m, "
                f"beta = 0.03 1/K, C = {heat_cap} J/K, R = {r_th} K/W (tau = {tau:g} s), Ta = {amb} degC"),
        integrator="RK4, 3 steps per sample (h = 0.33 ms), exact analytic force at every stage",
        sampling="sines near resonance, fs = 1000 Hz (29-40 samples per cycle), 2 s each",
        initial=(f"oil at Ta before the first record; mass at rest at the start of every record; records in test "
                 f"order with an unrecorded {pause:g} s pause between them (exact exponential cooling)"),
        base_law="m x'' + c x' + k x = u", kind=OSC, units={"x": "N", "y": "mm"}, mass_kg=round_sig1(m),
        noise_sd=0.02, noise_model=("ar1", 0.8), records=recs,
        held_out=["sine_A30N_f31Hz"], validation=["sine_A40N_f25Hz"], noise=noise, seed=1212,
    )


def hysteretic_boucwen_oscillator(noise=True, nominal=False):
    effects = ("hysteretic",)
    off = switched_off(nominal, effects)
    m, k, c, alpha, beta, gamma = 4.6, 1.5e4, 15.0, 0.4, 0.6e6, 0.4e6
    lin = "hysteretic" in off

    def rhs(s, u):
        x, v, z = s
        if lin:
            return [v, (u[0] - c * v - k * x) / m, 0.0]
        dz = v - beta * abs(v) * abs(z) * z - gamma * v * z * z
        return [v, (u[0] - c * v - alpha * k * x - (1.0 - alpha) * k * z) / m, dz]

    fs, sub = 500.0, 4
    runs = _sine_runs([(20, 3), (80, 3), (20, 8), (80, 8), (50, 5), (50, 3)], fs, 2.0)
    recs = []
    for name, sig, t, cond in runs:
        x = ops.rk4(rhs, [0.0, 0.0, 0.0], t, sub, sig.x)[:, 0]
        recs.append(record(name, t, sig.x(t), 1000.0 * x, **cond))
    return finish(
        name="hysteretic_boucwen_oscillator", effects=effects, off=off,
        law=("m x'' + c x' + alpha k x + (1 - alpha) k z = u, Bouc-Wen z' = x' - beta |x'| |z| z - gamma x' z^2 "
             "(n = 2, z saturates at 1 mm)"),
        params=(f"m = {m} kg (declared {round_sig1(m)} kg), k = {k:g} N/m, c = {c} N s/m, alpha = {alpha}, "
                "beta = 6e5 1/m^2, gamma = 4e5 1/m^2"),
        integrator="RK4, 4 steps per sample (h = 0.5 ms), exact analytic force at every stage",
        sampling="sines, fs = 500 Hz (62-167 samples per cycle), 2 s each",
        initial="each record starts at rest from the virgin state (x = x' = z = 0)",
        base_law="m x'' + c x' + k x = u", kind=OSC, units={"x": "N", "y": "mm"}, mass_kg=round_sig1(m),
        noise_sd=0.01, noise_model=("white",), records=recs,
        held_out=["sine_A50N_f5Hz"], validation=["sine_A50N_f3Hz"], noise=noise, seed=1216,
    )
