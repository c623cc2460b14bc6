"""Synthetic data with an undeclared effect, made by the library's own effects and simulator: quick unit
tests of the discovery loop's mechanics (an "inverse crime"; the judge of discovery is the independent
test bed, ``hybridhyst.testbed``). A damper law (in, kip, s) of viscous damping and a linear spring,
plus one library effect with known values, driven by sine tests at several amplitudes and frequencies.
Effects that only exist in a driven oscillator (``OSCILLATOR_CASES``: attenuation, F = ξ|x|u) get a
mass–spring–damper driven by a sine force u [kip] instead, whose response is the displacement [in]."""

from __future__ import annotations

import numpy as np
import torch

from ..data.records import Record, RecordSet
from ..physics.build import build_model
from ..simulate import simulate

__all__ = ["BASE", "CASES", "OSCILLATOR", "OSCILLATOR_CASES", "SPLIT", "TESTS", "base_model", "make_records",
           "split_of", "true_model"]

UNITS = {"x": "in", "F": "kip", "t": "s"}
BASE = {"viscous": {"effect": "viscous", "c": 0.5}, "spring": {"effect": "linear_stiffness", "k": 2.0}}
# (amplitude [in], frequency [Hz]) of the sine tests; 1.5 in is held out, the 0.75 in test validates
TESTS = [(0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (0.75, 1.5), (1.5, 1.0), (1.5, 2.0)]
SPLIT = {"held_out": {"amplitude_in": [1.5]}, "val": {"amplitude_in": [0.75]}}

# effect -> (its true parameters, the parameter whose recovery is checked). "viscous" and
# "linear_stiffness" are tested on a base without themselves.
CASES = {
    "coulomb": ({"Fc": 0.6, "v_s": 0.05}, "Fc"),
    "asymmetric_coulomb": ({"Fc": 0.5, "dF": 0.25, "v_s": 0.05}, "dF"),
    "stribeck": ({"dFs": 0.6, "vs": 0.6, "v_s": 0.05}, "dFs"),
    "cubic_stiffness": ({"k3": 1.2}, "k3"),
    "dahl": ({"sigma0": 20.0, "Fc": 0.6}, "Fc"),
    "lugre": ({"sigma0": 40.0, "sigma1": 0.0, "sigma2": 0.0, "Fc": 0.5, "Fs": 0.8, "vs": 0.5}, "Fc"),
    "bouc_wen": ({"alpha": 0.0, "k": 2.0, "k1": 0.0, "D": 1.0, "A": 1.0, "beta": 3.0, "gamma": 1.0, "n": 1.0},
                 "k"),
    "backlash": ({"r": 0.08}, "r"),
    "inertia": ({"m": 0.01}, "m"),
    "time_delay": ({"tau": 0.02}, "tau"),
    "travel_drift": ({"dF": 0.08, "v_s": 0.05}, "dF"),
    "viscous": ({"c": 0.5}, "c"),
    "linear_stiffness": ({"k": 2.0}, "k"),
    "attenuation": ({"xi": 0.8}, "xi"),
}
# The oscillator base: m ẍ + c ẋ + k x = u (natural frequency 3.2 Hz, 10 % damping: the 1–2 Hz tests are
# below resonance); attenuation ξ|x|u removes up to about 40 % of the drive at the largest stroke.
OSCILLATOR = {"mass": 0.005, "effects": {"viscous": {"effect": "viscous", "c": 0.02},
                                         "spring": {"effect": "linear_stiffness", "k": 2.0}}}
OSCILLATOR_CASES = {"attenuation"}
OSCILLATOR_SPLIT = {"held_out": {"amplitude_kip": [1.5]}, "val": {"amplitude_kip": [0.75]}}
OSCILLATOR_UNITS = {"x": "in", "F": "kip", "u": "kip", "t": "s"}


def split_of(extra: str | None) -> dict:
    """The split of ``make_records(extra)``: by drive amplitude (1.5 held out, 0.75 validates)."""
    return OSCILLATOR_SPLIT if extra in OSCILLATOR_CASES else SPLIT


def _build(extra: str | None, with_extra: bool):
    if extra in OSCILLATOR_CASES:
        effects = {k: dict(v) for k, v in OSCILLATOR["effects"].items()}
        if with_extra:
            effects[extra] = {"effect": extra, **CASES[extra][0]}
        return build_model("oscillator", effects, units=OSCILLATOR_UNITS, name=f"oscillator+{extra}" if with_extra
                           else "oscillator", mass=OSCILLATOR["mass"], fixed=["drive_gain"]).double()
    if with_extra:
        return build_model("constitutive", _effects(extra), units=UNITS, name=f"base+{extra}").double()
    effects = {k: dict(v) for k, v in BASE.items() if v["effect"] != extra}
    return build_model("constitutive", effects, units=UNITS, name="base").double()


def _effects(extra: str | None) -> dict:
    effects = {k: dict(v) for k, v in BASE.items() if v["effect"] != extra}
    if extra is not None:
        values, _ = CASES[extra]
        entry = {"effect": extra, **values}
        if extra == "bouc_wen":  # a purely hysteretic element (alpha = 0), as discovery adds it: alpha fixed
            entry["fixed"] = ["alpha"]
        effects = {extra: entry, **effects} if extra == "backlash" else {**effects, extra: entry}
    return effects


def base_model(extra: str | None = None):
    """The nominal the loop starts from: the base law (without ``extra`` if it is one of its terms), or the
    linear oscillator for an oscillator-only effect."""
    return _build(extra, with_extra=False)


def true_model(extra: str | None):
    """The law that generated the data: the base plus ``extra`` (None: the base alone)."""
    return _build(extra, with_extra=extra is not None)


def make_records(extra: str | None, noise_sd: float = 0.02, samples_per_cycle: int = 100, cycles: float = 2.0,
                 seed: int = 0) -> RecordSet:
    """Sine tests (``TESTS``) of ``true_model(extra)`` with Gaussian noise; conditions amplitude_in (or
    amplitude_kip for an oscillator, whose sine is the drive force and whose response is the motion),
    frequency_hz. Substeps keep the stiff states accurate."""
    model = true_model(extra)
    oscillator = extra in OSCILLATOR_CASES
    units = {"x": "kip", "y": "in"} if oscillator else {"x": "in", "y": "kip"}
    amplitude = "amplitude_kip" if oscillator else "amplitude_in"
    rng = np.random.default_rng(seed)
    out = []
    for amp, f in TESTS:
        t = np.arange(int(cycles * samples_per_cycle) + 1) / (f * samples_per_cycle)
        x = amp * np.sin(2 * np.pi * f * t)
        with torch.no_grad():
            y = simulate(model, torch.as_tensor(x)[None], t=torch.as_tensor(t), substeps=8)[0, :, 0].numpy()
        out.append(Record(name=f"sine_{amp:g}{units['x']}_{f:g}Hz", t=t, x=x, y=y,
                          conditions={amplitude: amp, "frequency_hz": f}, units=units).with_noise(noise_sd, rng))
    return RecordSet(out, f"synthetic base+{extra}")
