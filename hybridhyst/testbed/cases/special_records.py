"""The records of the cases that are not standard sine matrices: the inertia case's multisines, the clearance
whose level follows a coil current, and the two control-channel cases (a condition that varies in time within each
record): the MR damper under a coil-voltage staircase and the friction damper under an underpressure ramp."""

from __future__ import annotations

import math

import numpy as np

from .. import generators as g
from ..laws import clearance_law, control_friction_law, mr_lag_law, on_fine, static_law
from .assembly import _records


def _clearance_current_records(seed: int = 35):
    """±1 in at 0.5 Hz from x = 0 upwards, 200 samples per cycle, 3 cycles, at seven coil currents I [A]:
    F = 0.05 v + 0.3 sign(v) + a Dahl element σ0 30 kip/in behind a clearance r 0.08 in, its level 1 + 1.5 I kip
    both ways, the gap closed on the negative side at the start (q0 = −r: the rig left it there); exact per step
    on a 20× finer path; 0.05 kip white noise (the user trial's generator, an LSODA integration, rebuilt with the
    bed's exact operator)."""
    from ...data.records import Record, RecordSet

    rng = np.random.default_rng(seed)
    out = []
    for current in (0.0, 0.3, 0.6, 0.9, 1.2, 1.5, 2.0):
        level = 1.0 + 1.5 * current
        gap = clearance_law(0.0, 0.05, r=0.08, sigma0=30.0, Fc_pos=level, Fc_neg=level, q0=-0.08)
        law = on_fine(lambda tf, sig, gap=gap: gap(tf, sig) + 0.3 * g.sgn(sig.v(tf), "exact"), 20)
        t = np.arange(601) / 100.0
        sig = g.sine(1.0, 0.5)
        out.append(Record(name=f"I{current:.1f}A", t=t, x=sig.x(t), y=law(t, sig) + g.white_noise(len(t), 0.05, rng),
                          conditions={"current_a": current}, units={"x": "in", "y": "kip"}))
    return RecordSet(out, "clearance~current+start")


# the control-channel cases: every record a test of its own, a categorical label to split on
CONTROL_SPLIT = {"held_out": {"set": ["held_out"]}, "val": {"set": ["val"]}}
CONTROL_SETS = ("fit", "fit", "fit", "fit", "val", "held_out")
MR_ETA, MR_NOISE = 50.0, 2.0  # 1/s; N (about 1 % of the force's standard deviation, 150–215 N)
RAMP_NOISE = 0.5  # N


def _mr_voltage_records(seed: int = 61):
    """Six 4 s tests at 250 Hz, each a band-limited random motion (8 sines at random frequencies in 0.5–3 Hz,
    random phases, faded in from rest over 0.25 s, peak 8 mm) under a random coil-voltage staircase (0–2 V, levels
    held 0.3–0.8 s, 5 ms slew): F = (c_a + c_b u) ẋ + (α_a + α_b u) z + k x, u̇ = −η (u − v) (``laws.mr_lag_law``,
    computed on a 20× finer grid; Bouc–Wen exact in displacement, the lag by the exact exponential integrator);
    AR(1) noise (φ 0.5). The voltage is the record's control channel ``voltage``; ``set`` labels the split."""
    from ...data.records import Record, RecordSet

    rng = np.random.default_rng(seed)
    duration, rate = 4.0, 250
    t = np.arange(int(duration * rate) + 1) / rate
    out = []
    for i, label in enumerate(CONTROL_SETS):
        sig = g.random_motion(8.0, 0.5, 3.0, 8, seed=seed * 100 + i, duration=duration)
        volts = g.staircase(duration, 0.0, 2.0, seed=seed * 100 + 50 + i)
        law = on_fine(mr_lag_law(volts, c_a=1.0, c_b=1.5, alpha_a=20.0, alpha_b=60.0, k=2.0, beta=0.4, gamma=0.3,
                                 eta=MR_ETA), 20)
        y = law(t, sig) + g.ar1_noise(len(t), MR_NOISE, 0.5, rng)
        out.append(Record(name=f"mr{i + 1}_{label}", t=t, x=sig.x(t), y=y, conditions={"set": label},
                          units={"x": "mm", "y": "N", "voltage": "V"}, controls={"voltage": volts(t)}))
    return RecordSet(out, "mr_damper~voltage+lag")


# (amplitude mm, frequency Hz, pressure at the start and at the end MPa) of the pressure-ramp tests
RAMP_TESTS = [(5.0, 1.0, 0.02, 0.09), (5.0, 2.0, 0.09, 0.02), (8.0, 1.25, 0.03, 0.07), (3.0, 2.5, 0.06, 0.09),
              (6.0, 1.0, 0.05, 0.02), (6.0, 2.0, 0.02, 0.08)]


def _pressure_ramp_records(seed: int = 62):
    """Six 4 s tests at 250 Hz (``RAMP_TESTS``; a whole number of cycles, x = −A cos 2πft from rest), the
    underpressure held 0.5 s at its start value, ramped linearly to its end value and held for the last 0.5 s:
    F = 4 x + 0.6 ẋ + (10 + 400 p(t)) sgn(ẋ) (exact sign) N; white noise. The pressure is the control channel
    ``pressure_mpa``; ``set`` labels the split."""
    from ...data.records import Record, RecordSet

    rng = np.random.default_rng(seed)
    duration, rate = 4.0, 250
    t = np.arange(int(duration * rate) + 1) / rate
    out = []
    for (a, f, p0, p1), label in zip(RAMP_TESTS, CONTROL_SETS, strict=True):
        sig = g.sine(a, f, phase=-math.pi / 2)
        p = g.ramp(duration, p0, p1, lead=0.5)
        law = control_friction_law(p, k=4.0, c=0.6, level=lambda q: 10.0 + 400.0 * q)
        y = law(t, sig) + g.white_noise(len(t), RAMP_NOISE, rng)
        out.append(Record(name=f"A{a:g}_{f:g}Hz_p{p0:g}-{p1:g}_{label}", t=t, x=sig.x(t), y=y,
                          conditions={"set": label}, units={"x": "mm", "y": "N", "pressure_mpa": "MPa"},
                          controls={"pressure_mpa": p(t)}))
    return RecordSet(out, "friction~pressure_ramp+viscous")


def _inertia_records():
    """Multisines (6 lines, 0.5–3 Hz, one 2 s period at 100 Hz, faded in over 0.25 s) at three rms levels ×
    two phase realisations: F = 2x + 0.3v + 0.006 ẍ."""
    law = static_law(k=2.0, c=0.3, m=0.006)
    tests = []
    t = np.arange(201) / 100.0
    lines = [0.5 * i for i in range(1, 7)]
    for rms in (0.3, 0.45, 0.6):
        for j, tag in enumerate("ab"):
            sig = g.multisine(rms, lines, seed=100 + j, fade=0.25)
            tests.append((f"ms_{rms:g}_{tag}", sig, {"rms_in": rms, "phases": tag}, t))
    return _records("inertia", tests, law, 0.03, None, 11, {"x": "in", "y": "kip"})
