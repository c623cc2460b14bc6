"""Blind cases 15-16, hysteresis: a Dahl friction damper (exact Dahl recursion) and an MR damper whose own
Bouc-Wen variant (``solve_ivp`` DOP853) and damping follow the coil current."""

import math

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import cos_sum, sine_input
from .integrators import simulate_bouc_wen
from .operators import dahl_operator, sign_exact


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
