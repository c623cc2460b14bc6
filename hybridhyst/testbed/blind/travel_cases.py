"""Blind cases 9-10, laws that change with the distance travelled: a damper whose stiffness softens with
travel (an effect the library has no family for) and a friction damper whose level drifts with travel."""

import numpy as np

from .building import _af, _rec, _sine_name
from .inputs import cos_sum, sine_input
from .operators import cumulative_travel, sign_arctan


# ---------------------------------------------------------------- 9 travel stiffness
def _spec_travel_softening_damper(off):
    k0, kinf, s0, c = 50.0, 32.0, 60.0, 1.5
    kinf_true = kinf
    if off:
        kinf = k0
    spc, cyc, refine = 400, 4, 5
    tests = [(5.0, 1.0), (10.0, 0.5), (10.0, 2.0), (15.0, 1.0), (20.0, 1.0)]
    recs = []
    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        sf = cumulative_travel(xf)
        t, x, v, s = tf[::refine], xf[::refine], vf[::refine], sf[::refine]
        kk = kinf + (k0 - kinf) * np.exp(-s / s0)
        y = kk * x + c * v
        recs.append(_rec(_sine_name("A", A, f), t, x, y, _af(A, f)))
    desc = (
        "Elastomeric damper whose stiffness softens with cumulative travel (Mullins-like, "
        "secant form): F = k(s) x + c v, k(s) = kinf + (k0 - kinf) exp(-s/s0), s = integral of "
        "|dx| from the start of each record (each record starts on a rested specimen, s = 0). "
        f"k0 = {k0:g} N/mm, kinf = {kinf_true:g} N/mm, s0 = {s0:g} mm, c = {c:g} N s/mm. x in mm, "
        f"F in N. Sines x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, "
        f"(A mm, f Hz) = {tests}. Travel accumulated exactly (sum of |dx|) on a 5x finer grid "
        "containing every turning point. Nominal variant: kinf = k0. Held out: A20_f1 (largest "
        "amplitude); validation A10_f2."
    )
    return dict(
        effects=("travel_stiffness",),
        base_law="spring + viscous",
        kind="damper",
        units={"x": "mm", "y": "N", "t": "s"},
        noise_sd=6.0,
        noise_model=("ar1", 0.5),
        seed=19001,
        records=recs,
        held_out=["A20_f1"],
        validation=["A10_f2"],
        description=desc,
    )


# ---------------------------------------------------------------- 10 travel friction
def _spec_travel_friction_damper(off):
    k, c, Fc0, Fcinf, s0, dl = 1.0, 0.3, 3.0, 1.8, 4.0, 0.01
    Fcinf_true = Fcinf
    if off:
        Fcinf = Fc0
    spc, cyc, refine = 150, 3, 10
    tests = [(0.5, 0.5), (1.0, 0.5), (1.0, 1.0), (1.5, 0.25), (2.0, 0.5)]
    recs = []

    def law(x, v, s):
        Fc = Fcinf + (Fc0 - Fcinf) * np.exp(-s / s0)
        return k * x + c * v + Fc * sign_arctan(v, dl)

    for A, f in tests:
        tf, xf, vf = sine_input(A, f, cyc, spc, refine)
        sf = cumulative_travel(xf)
        sl = slice(None, None, refine)
        recs.append(_rec(_sine_name("A", A, f), tf[sl], xf[sl], law(xf[sl], vf[sl], sf[sl]), _af(A, f)))
    # cos-sum record with minor reversals
    fs, f0, A = 100.0, 0.5, 1.5
    T = 3.0 / f0
    tf = np.arange(int(round(T * fs * refine)) + 1) / (fs * refine)
    xf, vf = cos_sum(tf, [A * 0.7, A * 0.3], [f0, 4.0 * f0])
    sf = cumulative_travel(xf)
    sl = slice(None, None, refine)
    recs.append(_rec("MS_A1.5_f0.5", tf[sl], xf[sl], law(xf[sl], vf[sl], sf[sl]), _af(A, f0)))
    desc = (
        "Friction damper whose friction level runs in (drops) with cumulative travel: "
        "F = k x + c v + Fc(s) (2/pi) arctan(v/delta), Fc(s) = Fcinf + (Fc0 - Fcinf) exp(-s/s0), "
        "s = integral of |dx| from the start of each record (fresh pads each record). "
        f"k = {k:g} kip/in, c = {c:g} kip s/in, Fc0 = {Fc0:g} kip, Fcinf = {Fcinf_true:g} kip, "
        f"s0 = {s0:g} in, delta = {dl:g} in/s. x in inches, F in kip. Records: sines "
        f"x = -A cos(2 pi f t), {cyc} cycles, {spc} samples per cycle, (A in, f Hz) = {tests}; "
        "and MS_A1.5_f0.5: x = -(1.05 cos(2 pi 0.5 t) + 0.45 cos(2 pi 2 t)) in, 3 fundamental "
        "cycles at 100 Hz (minor reversals). Travel accumulated exactly on a 10x finer grid. "
        "Nominal variant: Fcinf = Fc0. Held out: A2_f0.5 (largest amplitude, most travel); "
        "validation A1_f1."
    )
    return dict(
        effects=("travel_friction",),
        base_law="spring + viscous + coulomb",
        kind="damper",
        units={"x": "in", "y": "kip", "t": "s"},
        noise_sd=0.04,
        noise_model=("white",),
        seed=20001,
        records=recs,
        held_out=["A2_f0.5"],
        validation=["A1_f1"],
        description=desc,
    )
