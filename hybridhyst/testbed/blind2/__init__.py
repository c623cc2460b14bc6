"""blind2: independent data generators for blind tests of hysteresis-model discovery (numpy/scipy/stdlib only).

Each case is a function ``name(noise=True, nominal=False) -> BlindCase``; ``noise=False`` gives the noise-free truth on
the same inputs, ``nominal=True`` the same experiment with all the case's effects switched off, ``nominal="word"`` (or
an iterable of words) only those (diagnostics only).  Everything is deterministic (fixed seeds).  Units below: dampers
x [mm] or [rad] in, F [N]/[kN] or T [Nm] out; oscillators u [N] in, x [mm] or [m] out; s = cumulative travel,
sg(v) = tanh(v/eps) (own smoothing of the sign), T = an internal temperature unless a setpoint is said.

Lab notebook 1 -- the truths
============================

==================================  ==============================  ==============================================
case                                effects                         law (truth)
==================================  ==============================  ==============================================
clean_linear_damper                 --                              F = 12 x + 0.8 v  [N, mm, s]
clean_pressure_coulomb_damper       --                              F = k(p) x + c(p) v + Fc(p) sg(v); k, c, Fc
                                                                    rise with charge pressure p (2-8 bar) [kN]
clean_linear_oscillator             --                              2.3 x'' + 12 x' + 8000 x = u  [SI]
clean_cubic_oscillator_temperature  --                              0.82 x'' + c(T) x' + k(T) x + k3(T) x^3 = u;
                                                                    chamber setpoint T = 10-55 degC
play_linkage_damper                 play                            spring 20 N/mm || dashpot 1.5 N s/mm driven
                                                                    through a pin with +-0.5 mm clearance
play_gap_oscillator                 play                            1.4 x'' + 25 x' + 3e4 dz(x; 0.3 mm) = u
stribeck_rotary_damper              stribeck                        T = 3 x + 0.4 w + [1.2 + 0.8 exp(-(w/0.15)^2)] sg
stribeck_oscillator                 stribeck                        3.2 x'' + 4 x' + 2000 x
                                                                    + [2 + 1.5 exp(-(x'/0.02)^2)] sg(x') = u
travel_stiffness_damper             travel_stiffness                F = 50 [1 - 0.35 (1 - exp(-s/500 mm))] x + 0.6 v
travel_friction_damper              travel_friction                 F = 8 x + 0.3 v + [22 + 18 exp(-s/600 mm)] sg(v)
drift_viscous_damper                drift                           F = 0.3 x + 0.05 exp(-0.02 (T-20)) v [kN];
                                                                    1000 dT/dt = c(T) v^2 - (T-20)/0.3
drift_oscillator                    drift                           0.62 x'' + 30 exp(-0.03 (T-20)) x' + 2.4e4 x = u;
                                                                    8 dT/dt = c(T) x'^2 - (T-20)/3
asymmetry_damper                    asymmetry                       F = 5 x + 0.2 v + (60 N if v > 0, 35 N if v < 0)
                                                                    x sg(v)
relaxation_damper                   relaxation                      F = 10 x + 0.5 v + q1 + q2, Maxwell
                                                                    q_i' = k_i v - q_i/tau_i (15, 0.05 s; 8, 0.8 s)
hysteretic_jenkins_damper           hysteretic                      F = 6 x + 0.25 v + 5 Jenkins elements
                                                                    (4 N/mm, sliders 2, 5, 9, 14, 20 N)
hysteretic_boucwen_oscillator       hysteretic                      4.6 x'' + 15 x' + 0.4 k x + 0.6 k z = u,
                                                                    k = 1.5e4, Bouc-Wen z (n = 2, z_max 1 mm)
outside_orifice_damper              outside                         F = 0.1 x + 0.01 v + 2e-5 v|v|  [kN]
                                                                    (turbulent orifice flow)
outside_cogging_actuator            outside                         T = 1.5 x + 0.05 w + 0.3 sg(w)
                                                                    + 0.25 sin(12 x)  (magnet cogging)
asymmetry_travel_friction_damper    asymmetry, travel_friction      F = 4 x + 0.15 v + F+-(s) sg(v), F+ 50 -> 30 N,
                                                                    F- 30 -> 20 N, exp(-s/800 mm)
==================================  ==============================  ==============================================

Lab notebook 2 -- how each was simulated and sampled
====================================================

==================================  ============================  ===========================  =====================
case                                integrator                    sampling                     noise (marginal sd)
==================================  ============================  ===========================  =====================
clean_linear_damper                 closed form                   sines 2-10 mm, 0.5-2 Hz,     white, 0.5 N
                                                                  200 Hz (100-400 /cycle)
clean_pressure_coulomb_damper       closed form                   sines at 4 pressures,        AR(1) 0.7, 0.01 kN
                                                                  500 Hz (167-500 /cycle)
clean_linear_oscillator             exact FOH (matrix exp.),      multisines, sweep, sines,    low-pass (2, 0.3),
                                    grid 4x finer                 500 Hz (36-100 /cycle)       0.005 mm
clean_cubic_oscillator_temperature  RK4, 3 steps/sample           sweeps 4-25 Hz + sine,       white, 2e-5 m
                                                                  400 Hz (16-100 /cycle)
play_linkage_damper                 exact relaxation + contact    sines, 400 Hz                white, 1 N
                                    projection, grid 16x finer    (100-400 /cycle)
play_gap_oscillator                 RK4, 4 steps/sample, kink     sines, 1000 Hz               AR(1) 0.5, 0.01 mm
                                    crossings refined 16x         (40-100 /cycle)
stribeck_rotary_damper              closed form                   slow sines, 50 Hz            white, 0.03 Nm
                                                                  (100-1000 /cycle)
stribeck_oscillator                 RK4, 4 steps/sample           sines, 500 Hz                white, 0.02 mm
                                                                  (167-333 /cycle)
travel_stiffness_damper             running |dx| sum on a 20x     sines, 250 Hz                low-pass (2, 0.3),
                                    grid, closed form             (83-250 /cycle), cycled      1.5 N
travel_friction_damper              running |dx| sum on a 20x     multisines + sines, 100 Hz   low-pass (4, 0.2),
                                    grid, closed form             (50-200 /cycle), new seal    1 N
drift_viscous_damper                RK4, 1 step/sample            sines, 200 Hz, 20 s pauses   white, 0.03 kN
                                                                  (100-200 /cycle)
drift_oscillator                    RK4, 3 steps/sample           sines near resonance,        AR(1) 0.8, 0.02 mm
                                                                  1000 Hz (29-40 /cycle)
asymmetry_damper                    closed form                   sines + sweep, 100 Hz        white, 2 N
                                                                  (50-200 /cycle)
relaxation_damper                   RK4, 2 steps/sample           ramp-hold + sines, 250 Hz    white, 0.5 N
                                                                  (50-1000 /cycle), cycled
hysteretic_jenkins_damper           exact stop operators,         decaying sine (virgin) +     white, 0.5 N
                                    grid 10x finer                sines, 200 Hz, cycled
hysteretic_boucwen_oscillator       RK4, 4 steps/sample           sines, 500 Hz                white, 0.01 mm
                                                                  (62-167 /cycle), virgin
outside_orifice_damper              closed form                   sines, 500 Hz                low-pass (2, 0.25),
                                                                  (167-500 /cycle)             0.01 kN
outside_cogging_actuator            closed form                   sines + multisine, 100 Hz    AR(1) 0.6, 0.02 Nm
                                                                  (100-500 /cycle)
asymmetry_travel_friction_damper    running |dx| sum on a 20x     sines, 200 Hz                white, 1 N
                                    grid, closed form             (100-400 /cycle), run in
==================================  ============================  ===========================  =====================

Each case's ``description`` states the full law, every parameter with units, integrator, sampling, noise, initial
state and the held-out and validation records.
"""

from .core import EFFECT_WORDS, BlindCase
from .dampers import (
    asymmetry_damper,
    asymmetry_travel_friction_damper,
    clean_linear_damper,
    clean_pressure_coulomb_damper,
    drift_viscous_damper,
    hysteretic_jenkins_damper,
    outside_cogging_actuator,
    outside_orifice_damper,
    play_linkage_damper,
    relaxation_damper,
    stribeck_rotary_damper,
    travel_friction_damper,
    travel_stiffness_damper,
)
from .oscillators import (
    clean_cubic_oscillator_temperature,
    clean_linear_oscillator,
    drift_oscillator,
    hysteretic_boucwen_oscillator,
    play_gap_oscillator,
    stribeck_oscillator,
)

CASES = [
    clean_linear_damper,
    clean_pressure_coulomb_damper,
    clean_linear_oscillator,
    clean_cubic_oscillator_temperature,
    play_linkage_damper,
    play_gap_oscillator,
    stribeck_rotary_damper,
    stribeck_oscillator,
    travel_stiffness_damper,
    travel_friction_damper,
    drift_viscous_damper,
    drift_oscillator,
    asymmetry_damper,
    relaxation_damper,
    hysteretic_jenkins_damper,
    hysteretic_boucwen_oscillator,
    outside_orifice_damper,
    outside_cogging_actuator,
    asymmetry_travel_friction_damper,
]
CASE_NAMES = [f.__name__ for f in CASES]
_BY_NAME = dict(zip(CASE_NAMES, CASES))


def case(name: str, noise=True, nominal=False) -> BlindCase:
    """Build the case called `name`."""
    try:
        fn = _BY_NAME[name]
    except KeyError:
        raise KeyError(f"unknown blind2 case {name!r}; known: {', '.join(CASE_NAMES)}") from None
    return fn(noise=noise, nominal=nominal)


__all__ = ["BlindCase", "CASES", "CASE_NAMES", "EFFECT_WORDS", "case", *CASE_NAMES]
