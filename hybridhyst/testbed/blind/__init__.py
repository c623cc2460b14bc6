"""Independent "blind" data generators for testing hysteresis-model discovery.

These generators were written without reading the discovery tool's code.  Every
law, parameter value and numerical method below is this module's own choice.
The module depends only on numpy, scipy and the Python standard library
(math, dataclasses, typing).

Each case is a function ``case_fn(noise=True, nominal=False) -> BlindCase``.
``noise=False`` returns the noise-free truth (same inputs, same records).
``nominal=True`` returns the same experiment with all listed effects switched
off (effect parameters at their neutral values, documented per case as
"Nominal variant"); ``nominal="play"`` (an effect name, or an iterable of
names) switches off only those.  The nominal variants are for diagnostics only
(e.g. measuring the size of an effect); they are not blind data.
Every case is deterministic (fixed numpy seeds).  The noise-free simulation of a
case is computed once per process and cached; callers always receive copies.

Kinds
-----
* ``damper``: input ``x`` = imposed displacement, output ``y`` = force.
* ``oscillator``: input ``x`` = drive force on a mass, output ``y`` = the mass's
  displacement.  Oscillators always start at rest (x = 0, v = 0).

Sine tests on dampers start from rest at -A: ``x = -A cos(2 pi f t)``, whole
cycles, endpoint included.  "cos-sum" inputs ``x = -sum a_i cos(2 pi f_i t)``
also start from rest at ``-sum a_i``.  Tapered multisines use a raised-cosine
fade-in/out so they start and end at rest at zero.

Noise models: white Gaussian; AR(1) ``e_k = phi e_{k-1} + sd sqrt(1-phi^2) w_k``
started from its stationary law; low-pass noise = white noise through a
Butterworth filter (causal, 4000-sample burn-in), scaled with the filter's
exact noise gain so that the *marginal* sd is ``noise_sd``.  Noise is added to
``y`` only; ``x`` is exact.

Cases
-----

Laws (the nominal/base law a user would declare is in each case's ``base_law``):

================================  ================  ===============================================================
name                              effects           law (truth; x' = v; the base law is this minus the effects)
================================  ================  ===============================================================
clean_symmetric_damper            -                 F = k x + c v + Fc sgn(v)
clean_pressure_cubic_damper       -                 F = k(p) x + c(p) v + k3(p) x^3 (k, k3 linear, c exp in p)
clean_linear_oscillator           -                 m x'' + c x' + k x = u
clean_duffing_oscillator          -                 m x'' + c x' + k x + k3 x^3 = u
play_friction_damper              play              F = k x + c z' + Fc sgn(z'), z = play_r[x]
play_stribeck_rotary_damper       play, stribeck    T = k th + c z' + S(z') z'/sqrt(z'^2+d^2), z = play_r[th]
stribeck_friction_damper          stribeck          F = k x + c v + [Fc + (Fs-Fc) exp(-(v/vs)^2)] sgn(v)
stribeck_oscillator               stribeck          m x'' + c x' + k x + [Fc + (Fs-Fc) exp(-(v/vs)^2)] erf(v/d) = u
travel_softening_damper           travel_stiffness  F = k(s) x + c v, k(s) exponential in travel s
travel_friction_damper            travel_friction   F = k x + c v + Fc(s) (2/pi) atan(v/d)
thermal_drift_viscous_damper      drift             F = k x + c0 exp(-b th) v, th' = c v^2/C - th/tau
asymmetric_friction_drift_damper  asymmetry, drift  F = k x + c v + Fdir(v) exp(-b th) s(v), th' = P/C - th/tau
maxwell_relaxation_damper         relaxation        F = k x + Fm, Fm' = km x' - Fm/tau
air_spring_relaxation_oscillator  relaxation        m x'' + c x' + k(p) x + Fm = u, Fm' = km(p) x' - Fm/tau
dahl_friction_damper              hysteretic        F = k x + c v + Fd, dFd/dx = sigma (1 - Fd/Fc sgn(x'))
mr_bouc_wen_damper                hysteretic        F = k x + c(I) v + alpha(I) z, own Bouc-Wen z
asymmetric_viscous_damper         asymmetry         F = k x + [cbar + dc v/sqrt(v^2+d^2)] v
cogging_rotary_damper             outside           T = k th + c w + Tc erf(w/d) + Tcog sin(2 pi th/p + ph)
endstop_contact_oscillator        outside           m x'' + c x' + k x + kc max(|x| - g, 0) sgn(x) = u
================================  ================  ===============================================================

Numerics, sampling and noise:

================================  ===============================  =================  =================
name                              integrator (grid / sample grid)  sampling           noise (model, sd)
================================  ===============================  =================  =================
clean_symmetric_damper            closed form, exact sign          200/cycle          white, 0.08 kip
clean_pressure_cubic_damper       closed form                      100 Hz multisine   AR(1) .7, 6 N
clean_linear_oscillator           exact FOH (expm), 16x            100/cycle, 200 Hz  low-pass, 0.4 mm
clean_duffing_oscillator          own implicit midpoint, 20x       80/cycle, 150 Hz   white, 0.25 mm
play_friction_damper              exact clamp recursion, 4x        500/cycle          AR(1) .3, 3 N
play_stribeck_rotary_damper       exact clamp recursion, 10x       100 Hz cos-sums    white, 0.15 Nm
stribeck_friction_damper          closed form, exact sign          1000/cycle         low-pass, .05 kip
stribeck_oscillator               solve_ivp LSODA 1e-9             100/cycle          AR(1) .5, 0.4 mm
travel_softening_damper           exact travel sum, 5x             400/cycle          AR(1) .5, 6 N
travel_friction_damper            exact travel sum, 10x            150/cycle, 100 Hz  white, .04 kip
thermal_drift_viscous_damper      solve_ivp DOP853 1e-10           25/cycle           white, 5 N
asymmetric_friction_drift_damper  own Crank-Nicolson, 20x          120/cycle          low-pass, .04 kip
maxwell_relaxation_damper         exact exponential, 10x           100/cycle, 200 Hz  AR(1) .8, 1.5 N
air_spring_relaxation_oscillator  exact FOH (expm), 8x             250 Hz multisine   AR(1) .6, 0.1 mm
dahl_friction_damper              exact Dahl recursion, 10x        400/cycle          low-pass, 1.5 N
mr_bouc_wen_damper                solve_ivp DOP853 1e-10           400 Hz cos-sum     white, 3 N
asymmetric_viscous_damper         closed form                      80/cycle           AR(1) .9, 4 N
cogging_rotary_damper             closed form                      250/cycle          white, 0.08 Nm
endstop_contact_oscillator        solve_ivp DOP853 1e-10           60/cycle           AR(1) .4, 0.3 mm
================================  ===============================  =================  =================

The exact parameter values, units, initial states, record lists and noise
levels of each case are in its ``description``.  Cases whose base-law
parameters vary with an operating condition: clean_pressure_cubic_damper
(``pressure_kpa``), air_spring_relaxation_oscillator (``pressure_kpa``),
mr_bouc_wen_damper (``current_a``).  All others use conditions ``amplitude``
and ``frequency_hz``.

Layout (one module per part; every name is importable from ``blind`` itself):

* ``operators``: elementary operators (signs, play, travel, Dahl, Maxwell, first-order hold) and ``TWO_PI``;
* ``integrators``: the ODE integrations (``solve_ivp`` and own fixed-step schemes);
* ``inputs``: sines, cos-sums, tapered multisines; ``noise``: white, AR(1), low-pass noise;
* ``building``: ``BlindCase``, the cache and how a case's spec becomes a case (noise, nominal variants);
* the cases by family: ``clean_cases`` (1-4), ``friction_cases`` (5-8, play and Stribeck), ``travel_cases``
  (9-10), ``drift_asymmetry_cases`` (11, 12, 17), ``relaxation_cases`` (13-14), ``hysteretic_cases`` (15-16),
  ``outside_cases`` (18-19);
* ``catalogue``: the public case functions, ``CASES``, ``CASE_NAMES`` and ``case(name)``.

The oscillators' and ODE cases' parameter sets (``_LIN_OSC``, ``_DUFF``, ``_STRIB_OSC``, ``_THERM``,
``_ASYMDRIFT``, ``_AIR``, ``_BW``, ``_ENDSTOP``), which the tests use, are importable from here as well.
"""

from .building import BlindCase
from .catalogue import (
    CASE_NAMES,
    CASES,
    air_spring_relaxation_oscillator,
    asymmetric_friction_drift_damper,
    asymmetric_viscous_damper,
    case,
    clean_duffing_oscillator,
    clean_linear_oscillator,
    clean_pressure_cubic_damper,
    clean_symmetric_damper,
    cogging_rotary_damper,
    dahl_friction_damper,
    endstop_contact_oscillator,
    maxwell_relaxation_damper,
    mr_bouc_wen_damper,
    play_friction_damper,
    play_stribeck_rotary_damper,
    stribeck_friction_damper,
    stribeck_oscillator,
    thermal_drift_viscous_damper,
    travel_friction_damper,
    travel_softening_damper,
)
from .clean_cases import _DUFF as _DUFF
from .clean_cases import _LIN_OSC as _LIN_OSC
from .clean_cases import linear_oscillator_matrices
from .drift_asymmetry_cases import _ASYMDRIFT as _ASYMDRIFT
from .drift_asymmetry_cases import _THERM as _THERM
from .friction_cases import _STRIB_OSC as _STRIB_OSC
from .hysteretic_cases import _BW as _BW
from .inputs import cos_sum, sine_input, tapered_multisine
from .integrators import (
    duffing_midpoint,
    simulate_bouc_wen,
    simulate_endstop_oscillator,
    simulate_stribeck_oscillator,
    simulate_thermal_viscous,
    thermal_friction_cn,
)
from .noise import ar1_noise, lowpass_noise, make_noise
from .operators import (
    TWO_PI,
    cumulative_travel,
    dahl_operator,
    foh_discretize,
    lti_foh_response,
    maxwell_force,
    play_operator,
    play_velocity,
    sign_algebraic,
    sign_arctan,
    sign_erf,
    sign_exact,
)
from .outside_cases import _ENDSTOP as _ENDSTOP
from .relaxation_cases import _AIR as _AIR
from .relaxation_cases import sls_oscillator_matrices

__all__ = [
    "CASES",
    "CASE_NAMES",
    "TWO_PI",
    "BlindCase",
    "air_spring_relaxation_oscillator",
    "ar1_noise",
    "asymmetric_friction_drift_damper",
    "asymmetric_viscous_damper",
    "case",
    "clean_duffing_oscillator",
    "clean_linear_oscillator",
    "clean_pressure_cubic_damper",
    "clean_symmetric_damper",
    "cogging_rotary_damper",
    "cos_sum",
    "cumulative_travel",
    "dahl_friction_damper",
    "dahl_operator",
    "duffing_midpoint",
    "endstop_contact_oscillator",
    "foh_discretize",
    "linear_oscillator_matrices",
    "lowpass_noise",
    "lti_foh_response",
    "make_noise",
    "maxwell_force",
    "maxwell_relaxation_damper",
    "mr_bouc_wen_damper",
    "play_friction_damper",
    "play_operator",
    "play_stribeck_rotary_damper",
    "play_velocity",
    "sign_algebraic",
    "sign_arctan",
    "sign_erf",
    "sign_exact",
    "simulate_bouc_wen",
    "simulate_endstop_oscillator",
    "simulate_stribeck_oscillator",
    "simulate_thermal_viscous",
    "sine_input",
    "sls_oscillator_matrices",
    "stribeck_friction_damper",
    "stribeck_oscillator",
    "tapered_multisine",
    "thermal_drift_viscous_damper",
    "thermal_friction_cn",
    "travel_friction_damper",
    "travel_softening_damper",
]
