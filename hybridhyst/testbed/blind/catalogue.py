"""The public blind case functions (one per case, ``case_fn(noise=True, nominal=False) -> BlindCase``),
``CASES`` in catalogue order, ``CASE_NAMES`` and ``case(name)``."""

from .building import BlindCase, _make_case_fn
from .clean_cases import (
    _spec_clean_duffing_oscillator,
    _spec_clean_linear_oscillator,
    _spec_clean_pressure_cubic_damper,
    _spec_clean_symmetric_damper,
)
from .drift_asymmetry_cases import (
    _spec_asymmetric_friction_drift_damper,
    _spec_asymmetric_viscous_damper,
    _spec_thermal_drift_viscous_damper,
)
from .friction_cases import (
    _spec_play_friction_damper,
    _spec_play_stribeck_rotary_damper,
    _spec_stribeck_friction_damper,
    _spec_stribeck_oscillator,
)
from .hysteretic_cases import _spec_dahl_friction_damper, _spec_mr_bouc_wen_damper
from .outside_cases import _spec_cogging_rotary_damper, _spec_endstop_contact_oscillator
from .relaxation_cases import _spec_air_spring_relaxation_oscillator, _spec_maxwell_relaxation_damper
from .travel_cases import _spec_travel_friction_damper, _spec_travel_softening_damper

clean_symmetric_damper = _make_case_fn("clean_symmetric_damper", _spec_clean_symmetric_damper, ())
clean_pressure_cubic_damper = _make_case_fn("clean_pressure_cubic_damper", _spec_clean_pressure_cubic_damper, ())
clean_linear_oscillator = _make_case_fn("clean_linear_oscillator", _spec_clean_linear_oscillator, ())
clean_duffing_oscillator = _make_case_fn("clean_duffing_oscillator", _spec_clean_duffing_oscillator, ())
play_friction_damper = _make_case_fn("play_friction_damper", _spec_play_friction_damper, ("play",))
play_stribeck_rotary_damper = _make_case_fn(
    "play_stribeck_rotary_damper", _spec_play_stribeck_rotary_damper, ("play", "stribeck")
)
stribeck_friction_damper = _make_case_fn("stribeck_friction_damper", _spec_stribeck_friction_damper, ("stribeck",))
stribeck_oscillator = _make_case_fn("stribeck_oscillator", _spec_stribeck_oscillator, ("stribeck",))
travel_softening_damper = _make_case_fn("travel_softening_damper", _spec_travel_softening_damper, ("travel_stiffness",))
travel_friction_damper = _make_case_fn("travel_friction_damper", _spec_travel_friction_damper, ("travel_friction",))
thermal_drift_viscous_damper = _make_case_fn(
    "thermal_drift_viscous_damper", _spec_thermal_drift_viscous_damper, ("drift",)
)
asymmetric_friction_drift_damper = _make_case_fn(
    "asymmetric_friction_drift_damper", _spec_asymmetric_friction_drift_damper, ("asymmetry", "drift")
)
maxwell_relaxation_damper = _make_case_fn("maxwell_relaxation_damper", _spec_maxwell_relaxation_damper, ("relaxation",))
air_spring_relaxation_oscillator = _make_case_fn(
    "air_spring_relaxation_oscillator", _spec_air_spring_relaxation_oscillator, ("relaxation",)
)
dahl_friction_damper = _make_case_fn("dahl_friction_damper", _spec_dahl_friction_damper, ("hysteretic",))
mr_bouc_wen_damper = _make_case_fn("mr_bouc_wen_damper", _spec_mr_bouc_wen_damper, ("hysteretic",))
asymmetric_viscous_damper = _make_case_fn("asymmetric_viscous_damper", _spec_asymmetric_viscous_damper, ("asymmetry",))
cogging_rotary_damper = _make_case_fn("cogging_rotary_damper", _spec_cogging_rotary_damper, ("outside",))
endstop_contact_oscillator = _make_case_fn("endstop_contact_oscillator", _spec_endstop_contact_oscillator, ("outside",))

CASES = [
    clean_symmetric_damper,
    clean_pressure_cubic_damper,
    clean_linear_oscillator,
    clean_duffing_oscillator,
    play_friction_damper,
    play_stribeck_rotary_damper,
    stribeck_friction_damper,
    stribeck_oscillator,
    travel_softening_damper,
    travel_friction_damper,
    thermal_drift_viscous_damper,
    asymmetric_friction_drift_damper,
    maxwell_relaxation_damper,
    air_spring_relaxation_oscillator,
    dahl_friction_damper,
    mr_bouc_wen_damper,
    asymmetric_viscous_damper,
    cogging_rotary_damper,
    endstop_contact_oscillator,
]

CASE_NAMES = [fn.__name__ for fn in CASES]


def case(name: str, noise: bool = True, nominal=False) -> BlindCase:
    """Build the case called ``name``."""
    for fn in CASES:
        if fn.__name__ == name:
            return fn(noise=noise, nominal=nominal)
    raise KeyError(f"unknown blind case {name!r}; known: {', '.join(CASE_NAMES)}")
