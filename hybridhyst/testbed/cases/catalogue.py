"""The first bed's case list: every case with its truth, data, nominal, split and what the loop should name
(``CASES``, ``CASE_BY_NAME``) and the two small cases of quick runs (``FAST_CASES``)."""

from __future__ import annotations

import math

from ..laws import (
    VPPTD_SPLIT,
    bw_law,
    clearance_law,
    dahl_law,
    drift_law,
    lugre_law,
    osc_law,
    p_const,
    p_exp,
    p_linear,
    play_law,
    rough_law,
    softening_law,
    static_law,
    vpptd_records,
)
from .assembly import (
    FREQ_SPLIT,
    FREQS,
    OSC,
    OSC_SPLIT,
    SLOW,
    SMALL,
    SMALL_SPLIT,
    STD,
    STD_SPLIT,
    _coul,
    _damper,
    _osc_records,
    _oscillator,
    _sine_records,
    _spring,
    _visc,
    _vpptd_nominal,
    maxwell_records,
)
from .case import COULOMB, DAHL, MM_UNITS, Case
from .special_records import (
    CONTROL_SPLIT,
    MR_ETA,
    MR_NOISE,
    RAMP_NOISE,
    _clearance_current_records,
    _inertia_records,
    _mr_voltage_records,
    _pressure_ramp_records,
)


def _case(name, category, expected, keys, noise, records, nominal, split, description, spc, noise_kind="white"):
    return Case(name=name, category=category, expected=tuple(frozenset(e) for e in expected), keys=tuple(keys),
                noise=noise, make_records=records, make_nominal=nominal, split=split, description=description,
                samples_per_cycle=spc, noise_kind=noise_kind)


def _build_cases() -> list[Case]:
    cases: list[Case] = []
    add = cases.append
    # ---------------------------------------------------------------- single
    add(_case("viscous", "single", [{"viscous"}], [("viscous.c", 0.25, 0.10)], 0.03,
              lambda: _sine_records("viscous", STD, static_law(k=2.0, c=0.25, Fc=0.5, sign="algebraic", width=0.02),
                                    spc=100, cycles=2, noise=0.03, seed=1),
              lambda: _damper({"spring": _spring(1.5), "coulomb": _coul(0.3)}), STD_SPLIT,
              "2x + 0.25v + 0.5 v/√(v²+0.02²); nominal spring + Coulomb", "100"))
    add(_case("coulomb", "single", [COULOMB], [("coulomb.Fc", 0.5, 0.10)], 0.03,
              lambda: _sine_records("coulomb", STD, static_law(k=2.0, c=0.2, Fc=0.5), spc=200, cycles=1.5, noise=0.03,
                                    phi=0.6, seed=2),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3)}), STD_SPLIT,
              "2x + 0.2v + 0.5 sign(v) (exact); nominal spring + viscous", "200", "AR(1) 0.6"))
    add(_case("asymmetric_coulomb", "single", [{"asymmetric_coulomb"}], [("asymmetric_coulomb.dF", 0.2, 0.15)], 0.03,
              lambda: _sine_records("asymmetric_coulomb", STD,
                                    static_law(k=2.0, c=0.2, Fc=0.6, dF=0.2, sign="arctan", width=0.01),
                                    spc=100, cycles=2, noise=0.03, seed=3),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3)}), STD_SPLIT,
              "2x + 0.2v + levels +0.8/−0.4 (arctan sign); nominal spring + viscous", "100"))
    add(_case("stribeck", "single", [{"stribeck"}], [("stribeck.dFs", 0.5, 0.20)], 0.03,
              lambda: _sine_records("stribeck", SLOW,
                                    static_law(k=2.0, c=0.2, Fc=0.4, dFs=0.5, vs=1.0, sign="erf", width=0.02),
                                    spc=150, cycles=2, noise=0.03, seed=4),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3), "coulomb": _coul(0.6)}), STD_SPLIT,
              "2x + 0.2v + (0.4 + 0.5 e^{−(v/1)²}) erf(v/0.02); nominal spring + viscous + Coulomb", "150"))
    add(_case("linear_stiffness", "single", [{"linear_stiffness"}], [("linear_stiffness.k", 1.5, 0.05)], 0.03,
              lambda: _sine_records("linear_stiffness", STD, static_law(k=1.5, k3=0.3, c=0.3), spc=20, cycles=4,
                                    noise=0.03, seed=5),
              lambda: _damper({"viscous": _visc(0.4), "cubic": {"effect": "cubic_stiffness", "k3": 0.5}}), STD_SPLIT,
              "1.5x + 0.3x³ + 0.3v; nominal viscous + cubic spring", "20"))
    add(_case("cubic_stiffness", "single", [{"cubic_stiffness"}], [("cubic_stiffness.k3", 0.8, 0.10)], 0.05,
              lambda: _sine_records("cubic_stiffness", STD, static_law(k=1.0, k3=0.8, c=0.2), spc=25, cycles=3,
                                    noise=0.05, seed=6),
              lambda: _damper({"spring": _spring(2.0), "viscous": _visc(0.3)}), STD_SPLIT,
              "x + 0.8x³ + 0.2v; nominal spring + viscous", "25"))
    add(_case("bouc_wen", "single", [{"bouc_wen"}], [("bouc_wen.k", 0.8 / 0.25, 0.25)], 0.03,
              lambda: _sine_records("bouc_wen", SMALL, bw_law(1.0, 0.2, Fy=0.8, xy=0.25, n=2.0, b=0.5), spc=150,
                                    cycles=2, noise=0.03, phi=0.5, seed=7),
              lambda: _damper({"spring": _spring(2.0), "viscous": _visc(0.3)}), SMALL_SPLIT,
              "x + 0.2v + Bouc–Wen yield form Fy 0.8, xy 0.25, n 2, b ½ (LSODA); k = 3.2, β = γ = 8",
              "150", "AR(1) 0.5"))
    add(_case("dahl", "single", [DAHL], [("dahl.Fc", 0.6, 0.10)], 0.03,
              lambda: _sine_records("dahl", SMALL, dahl_law(2.0, 0.2, sigma0=8.0, Fc=0.6), spc=100, cycles=2,
                                    noise=0.03, seed=8, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3)}), SMALL_SPLIT,
              "2x + 0.2v + Dahl σ0 8, Fc 0.6 (exact in displacement); nominal spring + viscous", "100"))
    add(_case("lugre", "single", [{"lugre"}], [("lugre.Fc", 0.4, 0.15), ("lugre.Fs", 0.8, 0.20)], 0.03,
              lambda: _sine_records("lugre", SMALL[:2] + SMALL[3:5],
                                    lugre_law(2.0, 0.2, sigma0=30.0, sigma1=0.2, sigma2=0.0, Fc=0.4, Fs=0.8, vs=1.0),
                                    spc=1000, cycles=1, noise=0.03, seed=9),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3)}),
              {"held_out": {"amplitude_in": [1.2]}, "val": {"amplitude_in": [0.6]}},
              "2x + 0.2v + LuGre σ0 30, σ1 0.2, Fc 0.4, Fs 0.8, vs 1 (LSODA); nominal spring + viscous", "1000"))
    add(_case("backlash", "single", [{"backlash"}], [("backlash.r", 0.1, 0.15)], 0.03,
              lambda: _sine_records("backlash", STD, play_law(0.1, 2.0, 0.3), spc=200, cycles=1.5, noise=0.03,
                                    seed=10, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2)}), STD_SPLIT,
              "exact play r 0.1 in, then 2y + 0.3ẏ; nominal spring + viscous", "200"))
    add(_case("inertia", "single", [{"inertia"}], [("inertia.m", 0.006, 0.10)], 0.03,
              _inertia_records,
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.4)}),
              {"held_out": {"rms_in": [0.6]}, "val": {"rms_in": [0.45], "phases": ["b"]}},
              "multisine 0.5–3 Hz (faded in): 2x + 0.3v + 0.006 ẍ; nominal spring + viscous",
              "33–200 (multisine)"))
    add(_case("attenuation", "single", [{"attenuation"}], [("attenuation.xi", 0.8, 0.10)], 0.005,
              lambda: _osc_records("attenuation", OSC, osc_law(0.005, 0.02, 2.0, xi=0.8), spc=100, cycles=2,
                                   noise=0.005, seed=12),
              lambda: _oscillator({"viscous": _visc(0.03), "spring": _spring(1.5)}, mass=0.004), OSC_SPLIT,
              "oscillator 0.005ẍ + 0.02ẋ + 2x + 0.8|x|u = u (DOP853); nominal linear oscillator", "100"))
    add(_case("time_delay", "single", [{"time_delay"}], [("time_delay.tau", 0.015, 0.15)], 0.03,
              lambda: _sine_records("time_delay", STD,
                                    static_law(k=2.0, c=0.3, Fc=0.5, sign="algebraic", width=0.05, tau=0.015),
                                    spc=100, cycles=2, noise=0.03, seed=13),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2), "coulomb": _coul(0.3)}), STD_SPLIT,
              "force read 15 ms late: 2x + 0.3v + 0.5 v/√(v²+0.05²)", "100"))
    add(_case("travel_drift", "single", [{"travel_drift"}], [("travel_drift.dF", 0.04, 0.15)], 0.03,
              lambda: _sine_records("travel_drift", STD, drift_law(2.0, 0.2, 0.4, 0.04), spc=100, cycles=3,
                                    noise=0.03, seed=14, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3), "coulomb": _coul(0.6)}), STD_SPLIT,
              "2x + 0.2v + (0.4 + 0.04 s) arctan sign, s = travel; nominal spring + viscous + Coulomb", "100"))
    # the secant slope of k0/(1 + s/s0) over the training records' travel (0–12 in) is -0.0217; its tangent at 0 -0.025
    add(_case("travel_stiffness", "single", [{"travel_stiffness"}], [("travel_stiffness.dk", -0.0225, 0.20)], 0.03,
              lambda: _sine_records("travel_stiffness", STD, softening_law(2.0, 80.0, 0.2, 0.4), spc=100, cycles=3,
                                    noise=0.03, seed=29, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3), "coulomb": _coul(0.6)}), STD_SPLIT,
              "2/(1 + s/80) x + 0.2v + 0.4 arctan sign, s = travel; nominal spring + viscous + Coulomb", "100"))
    add(_case("maxwell", "single", [{"maxwell"}], [("maxwell.k_m", 2.0, 0.15), ("maxwell.tau", 0.1, 0.15)], 0.03,
              maxwell_records,
              lambda: _damper({"spring": _spring(2.0), "viscous": _visc(0.3)}), FREQ_SPLIT,
              "1.5x + 0.1v + Maxwell (k_m 2 in series with c_m 0.2, τ 0.1 s; exact exponential integrator); "
              "nominal spring + viscous", "100", "AR(1) 0.5"))
    # levels 0.5 (v > 0) and 0.7 (v < 0): the library's Fc (1 ± a) with Fc 0.6, a = −1/6
    add(_case("clearance", "single", [{"clearance"}], [("clearance.r", 0.06, 0.20)], 0.03,
              lambda: _sine_records("clearance", STD, clearance_law(2.0, 0.3, r=0.06, sigma0=15.0, Fc_pos=0.5,
                                                                     Fc_neg=0.7),
                                    spc=150, cycles=2, noise=0.03, seed=15, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2),
                               "dahl": {"effect": "dahl", "sigma0": 10.0, "Fc": 0.5}}), STD_SPLIT,
              "2x + 0.3v + Dahl σ0 15 behind a clearance r 0.06 in, levels 0.5 (v > 0) / 0.7 (v < 0) (exact per "
              "step, split at the gap); nominal spring + viscous + Dahl", "150"))
    # the same device, each test started as a rig starts it: moved down to −A first, so the gap is closed on the
    # negative side and the element fully deflected (q0 = −(r + Fc_neg / σ0) = −0.1067 in); the first upward
    # stroke then crosses the whole gap unloaded. The library's clearance.q0 has the same meaning.
    add(_case("clearance+start", "single", [{"clearance"}], [("clearance.r", 0.06, 0.20),
                                                             ("clearance.q0", -(0.06 + 0.7 / 15.0), 0.25)], 0.03,
              lambda: _sine_records("clearance+start", STD, clearance_law(2.0, 0.3, r=0.06, sigma0=15.0, Fc_pos=0.5,
                                                                           Fc_neg=0.7, q0=-(0.06 + 0.7 / 15.0)),
                                    spc=150, cycles=2, noise=0.03, seed=16, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2),
                               "dahl": {"effect": "dahl", "sigma0": 10.0, "Fc": 0.5}}), STD_SPLIT,
              "the clearance case, each test started with the gap closed on the negative side and the element "
              "fully deflected (as the rig's move down to −A leaves it); nominal spring + viscous + Dahl", "150"))
    # ---------------------------------------------------------------- pair
    add(_case("backlash+coulomb", "pair", [{"backlash"}, COULOMB],
              [("backlash.r", 0.08, 0.20), ("coulomb.Fc", 0.4, 0.15)], 0.03,
              lambda: _sine_records("backlash+coulomb", STD, play_law(0.08, 2.0, 0.3, Fc=0.4), spc=200, cycles=1.5,
                                    noise=0.03, seed=21, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2)}), STD_SPLIT,
              "exact play r 0.08, then 2y + 0.3ẏ + 0.4 sign(ẏ); nominal spring + viscous", "200"))
    add(_case("stribeck+cubic", "pair", [{"stribeck"}, {"cubic_stiffness"}],
              [("stribeck.dFs", 0.4, 0.25), ("cubic_stiffness.k3", 0.6, 0.10)], 0.03,
              lambda: _sine_records("stribeck+cubic", SLOW,
                                    static_law(k=1.0, k3=0.6, c=0.2, Fc=0.4, dFs=0.4, vs=1.0, sign="erf", width=0.02),
                                    spc=120, cycles=2, noise=0.03, phi=0.7, seed=22),
              lambda: _damper({"spring": _spring(2.0), "viscous": _visc(0.3), "coulomb": _coul(0.6)}), STD_SPLIT,
              "x + 0.6x³ + 0.2v + (0.4 + 0.4 e^{−v²}) erf sign; nominal spring + viscous + Coulomb", "120",
              "AR(1) 0.7"))
    add(_case("dahl+travel_drift", "pair", [DAHL, {"travel_drift"}],
              [("dahl.Fc", 0.5, 0.15), ("travel_drift.dF", 0.05, 0.20)], 0.03,
              lambda: _sine_records("dahl+travel_drift", SMALL, dahl_law(2.0, 0.2, 10.0, 0.5, drift=0.05), spc=100,
                                    cycles=3, noise=0.03, seed=23, refine=20),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3)}), SMALL_SPLIT,
              "2x + 0.2v + Dahl σ0 10, Fc 0.5 + 0.05 s erf sign; nominal spring + viscous", "100"))
    add(_case("bouc_wen+viscous", "pair", [{"bouc_wen"}, {"viscous"}],
              [("bouc_wen.k", 0.6 / 0.2, 0.25), ("viscous.c", 0.3, 0.15)], 0.03,
              lambda: _sine_records("bouc_wen+viscous", FREQS, bw_law(1.5, 0.3, Fy=0.6, xy=0.2, n=1.5, b=0.6),
                                    spc=100, cycles=2, noise=0.03, seed=24),
              lambda: _damper({"spring": _spring(2.0)}), FREQ_SPLIT,
              "1.5x + 0.3v + Bouc–Wen Fy 0.6, xy 0.2, n 1.5, b 0.6 (k 3, β 6.7, γ 4.5); nominal spring", "100"))
    add(_case("osc_cubic+coulomb", "pair", [{"cubic_stiffness"}, COULOMB],
              [("cubic_stiffness.k3", 1.5, 0.15), ("coulomb.Fc", 0.1, 0.25)], 0.005,
              lambda: _osc_records("osc_cubic+coulomb", OSC, osc_law(0.005, 0.02, 2.0, k3=1.5, Fc=0.1, method="LSODA"),
                                   spc=100, cycles=2, noise=0.005, seed=25),
              lambda: _oscillator({"viscous": _visc(0.03), "spring": _spring(1.5)}, mass=0.004), OSC_SPLIT,
              "oscillator + 1.5x³ + 0.1 arctan sign(ẋ) (LSODA); nominal linear oscillator", "100"))
    # ---------------------------------------------------------------- condition (VPPTD, seed 000)
    add(_case("vpptd_linear+clearance", "condition", [{"backlash"}], [("backlash.r", 0.5, 0.20)], 0.2,
              lambda: vpptd_records("vpptd_linear+clearance", p_const(6.7), p_linear(0.65, 1.65), p_const(0.0055),
                                     p_linear(9.5, 15.0), clearance=0.5, seed=31),
              _vpptd_nominal, VPPTD_SPLIT,
              "k, Ms linear in p (0.65→1.65, 9.5→15); exact play r 0.5° on the angle", "500"))
    add(_case("vpptd_exp+stribeck", "condition", [{"stribeck"}], [("stribeck.dFs", 4.0, 0.25)], 0.2,
              lambda: vpptd_records("vpptd_exp+stribeck", p_const(6.7), p_exp(0.65, 1.3), p_const(0.0055),
                                     p_exp(9.5, 19.0), stribeck=(4.0, 15.0), seed=32),
              _vpptd_nominal, VPPTD_SPLIT,
              "k, Ms ×2 exponentially over p; + 4 e^{−(φ̇/15°/s)²} Nm Stribeck", "500"))
    add(_case("vpptd_linear+delay", "condition", [{"time_delay"}], [("time_delay.tau", 0.008, 0.20)], 0.2,
              lambda: vpptd_records("vpptd_linear+delay", p_linear(6.7, 8.3), p_const(0.65), p_const(0.0055),
                                     p_linear(9.5, 15.0), tau=0.008, phase=-math.pi / 2, seed=33),
              _vpptd_nominal, VPPTD_SPLIT,
              "c, Ms linear in p (6.7→8.3, 9.5→15); torque channel 8 ms late; starts from rest at −10°", "500"))
    # the effect's own level depends on the condition: the loop must give the added effect a trend too
    add(_case("vpptd_linear+stribeck~p", "condition", [{"stribeck"}], [("stribeck.vs", 15.0, 0.25)], 0.2,
              lambda: vpptd_records("vpptd_linear+stribeck~p", p_const(6.7), p_linear(0.65, 1.65), p_const(0.0055),
                                     p_linear(9.5, 15.0), stribeck=(p_linear(1.5, 6.0), 15.0), seed=34),
              _vpptd_nominal, VPPTD_SPLIT,
              "k, Ms linear in p (0.65→1.65, 9.5→15); Stribeck excess linear in p too (1.5→6 Nm, "
              "e^{−(φ̇/15°/s)²})", "500"))
    # a user trial (2026-11-26): a friction damper whose clearance's level rises with a coil current, every test
    # started with the gap closed; the held-out 2.0 A lies beyond every training current
    add(_case("clearance~current+start", "condition", [{"clearance"}],
              [("clearance.r", 0.08, 0.20), ("clearance.q0", -0.08, 0.25)], 0.05,
              _clearance_current_records,
              lambda: _damper({"viscous": _visc(0.1), "coulomb": _coul(0.5),
                               "dahl": {"effect": "dahl", "sigma0": 10.0, "Fc": 2.0}}),
              {"held_out": {"current_a": [0.9, 2.0]}, "val": {"current_a": [1.5]}},
              "0.05v + 0.3 sign(v) (exact) + Dahl σ0 30 behind a clearance r 0.08 in whose level 1 + 1.5 I rises "
              "with the current I (0–2 A), each test started with the gap closed (q0 = −r); nominal viscous + "
              "Coulomb + Dahl", "200"))
    # control channels (issue 39): the condition varies in time within each record (Record.controls)
    add(_case("mr_damper~voltage+lag", "condition", [{"control_lag"}], [("lag_voltage.eta", MR_ETA, 0.20)], MR_NOISE,
              _mr_voltage_records,
              lambda: _damper({"viscous": _visc(2.0), "stiffness": _spring(1.0),
                               "hysteresis": {"effect": "bouc_wen", "kappa": 50.0, "beta": 0.5, "gamma": 0.5,
                                              "n": 1.5, "alpha": 0.0, "k": 1.0, "k1": 0.0, "A": 1.0, "D": 1.0,
                                              "fixed": ["alpha", "k", "k1", "A", "D"]}}, units=MM_UNITS),
              CONTROL_SPLIT,
              "MR damper (N, mm, s, V): F = (1 + 1.5 u) ẋ + (20 + 60 u) z + 2 x, Bouc–Wen z (n 2, A 1, β 0.4, γ 0.3 "
              "1/mm², exact in displacement), coil u̇ = −50 (u − v) behind a random voltage staircase v (0–2 V, "
              "levels held 0.3–0.8 s, 5 ms slew), band-limited random motion (8 lines 0.5–3 Hz, peak 8 mm); "
              "nominal viscous + spring + Bouc–Wen (κ z), constant parameters", "250 Hz (random 0.5–3 Hz)",
              "AR(1) 0.5"))
    add(_case("friction~pressure_ramp+viscous", "condition", [{"viscous"}], [("viscous.c", 0.6, 0.15)],
              RAMP_NOISE, _pressure_ramp_records,
              lambda: _damper({"spring": _spring(3.0),
                               "coulomb": {"effect": "coulomb", "Fc": 30.0, "v_s": 0.1, "fixed": ["v_s"]}},
                              units=MM_UNITS),
              CONTROL_SPLIT,
              "4 x + 0.6 ẋ + (10 + 400 p) sgn(ẋ) (exact) N, mm, s, with the underpressure p [MPa] ramped within "
              "each record (0.02–0.09, up or down, a different ramp per record); sines from rest; nominal spring + "
              "Coulomb (constant level)", "100–250"))
    # ---------------------------------------------------------------- clean controls
    add(_case("clean_friction", "clean", [], [], 0.03,
              lambda: _sine_records("clean_friction", STD, static_law(k=2.0, c=0.3, Fc=0.5), spc=100, cycles=2,
                                    noise=0.03, seed=41),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2), "coulomb": _coul(0.3)}), STD_SPLIT,
              "2x + 0.3v + 0.5 sign(v) (exact); nominal the same structure", "100"))
    add(_case("clean_oscillator_ar1", "clean", [], [], 0.005,
              lambda: _osc_records("clean_oscillator_ar1", OSC, osc_law(0.005, 0.02, 2.0), spc=40, cycles=3,
                                   noise=0.005, phi=0.8, seed=42),
              lambda: _oscillator({"viscous": _visc(0.03), "spring": _spring(1.5)}, mass=0.004), OSC_SPLIT,
              "linear oscillator (DOP853); nominal linear oscillator", "40", "AR(1) 0.8"))
    add(_case("clean_dahl_1000", "clean", [], [], 0.03,
              lambda: _sine_records("clean_dahl_1000", SMALL[:2] + SMALL[3:5], dahl_law(2.0, 0.2, 10.0, 0.5),
                                    spc=1000, cycles=1, noise=0.03, phi=0.9, seed=43, refine=10),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.3),
                               "dahl": {"effect": "dahl", "sigma0": 5.0, "Fc": 0.8}}),
              {"held_out": {"amplitude_in": [1.2]}, "val": {"amplitude_in": [0.6]}},
              "2x + 0.2v + Dahl σ0 10, Fc 0.5 (exact); nominal spring + viscous + Dahl", "1000", "AR(1) 0.9"))
    # ---------------------------------------------------------------- out of library
    add(_case("cogging", "out_of_library", [], [], 0.03,
              lambda: _sine_records("cogging", STD, static_law(k=2.0, c=0.3, Fc=0.4, sign="arctan", width=0.01,
                                                            cog=(0.25, 0.35)),
                                    spc=200, cycles=1.5, noise=0.03, seed=51),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2), "coulomb": _coul(0.3)}), STD_SPLIT,
              "2x + 0.3v + 0.4 arctan sign + 0.25 sin(2πx / 0.35 in); nominal spring + viscous + Coulomb", "200"))
    add(_case("rough_patch", "out_of_library", [], [], 0.03,
              lambda: _sine_records("rough_patch", STD, rough_law(2.0, 0.3, Fc=0.4, depth=0.6, period=0.8),
                                    spc=200, cycles=1.5, noise=0.03, seed=53),
              lambda: _damper({"spring": _spring(1.5), "viscous": _visc(0.2), "coulomb": _coul(0.3)}), STD_SPLIT,
              "2x + 0.3v + 0.4 (1 + 0.6 cos(2πx / 0.8 in)) arctan sign: a friction level varying along the stroke; "
              "nominal spring + viscous + Coulomb", "200"))
    return cases


CASES: list[Case] = _build_cases()
CASE_BY_NAME: dict[str, Case] = {c.name: c for c in CASES}
# two small cases for quick runs (``--fast``): a clean control (the default test runs this one end to end:
# about 3 s with a warm compile cache, 25 s cold) and an algebraic single case at 20 samples per cycle
FAST_CASES = ("clean_friction", "linear_stiffness")
