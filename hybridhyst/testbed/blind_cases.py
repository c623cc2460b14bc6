"""The blind test beds: the cases of ``blind`` and ``blind2`` (generators written, from a list of physical effects
in words, by someone who had not read the library; two authors, one after the other) as test-bed ``Case``s.

Nothing here looks at a case's truth beyond what a user knows of their own device: the effect words decide
only how the case is scored, and the nominal is the base law the generator's author declared (``base_law``),
with one-significant-digit starting values read from the data's scales (an oscillator's mass rounded to one
significant digit: a user weighs it). The loop runs on it with the one user setting of every case.

Scoring (the effect words mapped to library families; ``FAMILIES``):

* an effect whose family the library has: ``single`` (one effect) or ``pair`` (two), scored as in the first bed;
* an effect the library has no family for (direction-dependent damping, cogging, end stops): ``out_of_library``:
  nothing may be named, and the structure should be flagged (a stiffness that changes with travel and a drifting
  viscous damping were such effects until the library gained ``travel_stiffness`` and ``travel_damping``);
* no effect: ``clean``.

These cases are not used for tuning: run them once, with the loop final (``scripts/discovery_testbed.py
--bed blind`` or ``--bed blind2``). ``blind2`` was written after the loop had been tuned with ``blind``'s results in
view (two of its failures led to changes), so that its results are blind evidence again.
"""

from __future__ import annotations

import functools
import importlib
import math

import numpy as np

from . import blind
from .cases import Case

__all__ = ["BEDS", "BLIND_CASES", "BLIND_CASE_BY_NAME", "FAMILIES", "bed_cases", "blind_case", "family"]

HYSTERETIC = frozenset({"dahl", "lugre", "bouc_wen", "bouc_wen_normalised"})
# effect word -> the library effects that name it (None: the library has no such family)
FAMILIES: dict[str, frozenset[str] | None] = {
    "play": frozenset({"backlash", "relaxing_backlash", "clearance"}),
    "stribeck": frozenset({"stribeck"}),
    "travel_friction": frozenset({"travel_drift"}),
    "relaxation": frozenset({"maxwell"}),
    "hysteretic": HYSTERETIC,
    "travel_stiffness": frozenset({"travel_stiffness"}),
    "outside": None,
}


def family(word: str, case: blind.BlindCase) -> frozenset[str] | None:
    """The library effects that name effect ``word`` in ``case`` (None where the library has none): a drift of a
    friction level is the library's travel drift, of a viscous damping its travel damping; an asymmetry of a
    friction level is asymmetric Coulomb, of a damping it has no family."""
    friction = "coulomb" in case.base_law
    if word == "drift":
        return frozenset({"travel_drift"}) if friction else frozenset({"travel_damping"})
    if word == "asymmetry":
        return frozenset({"asymmetric_coulomb"}) if friction else None
    return FAMILIES[word]


def _round1(v: float) -> float:
    """``v`` to one significant digit (a user's round starting value)."""
    if not math.isfinite(v) or v == 0:
        return 1.0
    e = math.floor(math.log10(abs(v)))
    return round(v / 10**e) * 10**e


# an oscillator's mass [kg], rounded to one significant digit (what a user who weighed it would declare): the
# first blind bed's, by case; the second's cases declare it (``mass_kg``)
MASS_KG = {"clean_linear_oscillator": 2.0, "clean_duffing_oscillator": 0.5, "stribeck_oscillator": 2.0,
           "air_spring_relaxation_oscillator": 4.0, "endstop_contact_oscillator": 1.0}
# the library's force per (displacement unit / s²) of one kg, for the blind oscillators' N and mm
KG = {("N", "mm"): 1e-3, ("N", "m"): 1.0}


def _nominal(case: blind.BlindCase):
    """The base law as a library model with round starting values from the data's scales."""
    from ..physics.build import build_model

    law = case.base_law
    xs = np.concatenate([np.asarray(r["x"]) for r in case.records])
    ys = np.concatenate([np.asarray(r["y"]) for r in case.records])
    vs = np.concatenate([np.gradient(np.asarray(r["x"] if case.kind == "damper" else r["y"]), r["t"])
                         for r in case.records])
    if case.kind == "damper":
        X, Y, V = float(np.max(np.abs(xs))), float(np.max(np.abs(ys))), float(np.max(np.abs(vs)))
        effects = {"spring": {"effect": "linear_stiffness", "k": _round1(0.5 * Y / X)},
                   "viscous": {"effect": "viscous", "c": _round1(0.1 * Y / V)}}
        if "coulomb" in law:
            effects["coulomb"] = {"effect": "coulomb", "Fc": _round1(0.2 * Y), "v_s": _round1(0.01 * V),
                                  "fixed": ["v_s"]}
        if "cubic" in law:
            effects["cubic"] = {"effect": "cubic_stiffness", "k3": _round1(0.1 * Y / X**3)}
        units = {"x": case.units["x"], "F": case.units["y"], "t": "s"}
        return build_model("constitutive", effects, units=units, name=case.name).double()
    # oscillator: x = drive force, y = displacement
    U, X, V = float(np.max(np.abs(xs))), float(np.max(np.abs(ys))), float(np.max(np.abs(vs)))
    mass = (getattr(case, "mass_kg", None) or MASS_KG[case.name]) * KG[(case.units["x"], case.units["y"])]
    k = _round1(U / X)
    effects = {"spring": {"effect": "linear_stiffness", "k": k},
               "viscous": {"effect": "viscous", "c": _round1(0.1 * math.sqrt(k * mass))}}
    if "cubic" in law:
        effects["cubic"] = {"effect": "cubic_stiffness", "k3": _round1(0.1 * U / X**3)}
    if "coulomb" in law:
        effects["coulomb"] = {"effect": "coulomb", "Fc": _round1(0.05 * U), "v_s": _round1(0.01 * V),
                              "fixed": ["v_s"]}
    units = {"x": case.units["y"], "F": case.units["x"], "u": case.units["x"], "t": "s"}
    return build_model("oscillator", effects, units=units, name=case.name, mass=mass,
                       fixed=["drive_gain"]).double()


def _records(case: blind.BlindCase):
    from ..data.records import Record, RecordSet

    units = {"x": case.units["x"], "y": case.units["y"]}
    return RecordSet([Record(name=r["name"], t=np.asarray(r["t"]), x=np.asarray(r["x"]), y=np.asarray(r["y"]),
                             conditions=dict(r["conditions"]), units=units) for r in case.records], case.name)


def _split(case: blind.BlindCase) -> dict:
    """The generator's held-out and validation records as condition queries (each record's own conditions)."""
    by_name = {r["name"]: r["conditions"] for r in case.records}

    def query(names):
        return [{k: [v] for k, v in by_name[n].items()} for n in names]

    return {"held_out": query(case.held_out), "val": query(case.validation) if case.validation else None}


def _case(fn, prefix: str = "") -> Case:
    spec = fn()
    families = [family(w, spec) for w in spec.effects]
    if not spec.effects:
        category, expected = "clean", ()
    elif any(f is None for f in families):
        category, expected = "out_of_library", ()
    else:
        category, expected = ("single" if len(families) == 1 else "pair"), tuple(families)
    rates = sorted({round(1 / float(np.median(np.diff(r["t"])))) for r in spec.records})
    # a clean control whose base law follows a physical condition (a pressure, a coil current: not the test's own
    # amplitude or frequency) has condition trends in its truth
    physical = set(spec.records[0]["conditions"]) - {"amplitude", "frequency_hz"}
    return Case(name=prefix + spec.name, category=category, expected=expected, keys=(), noise=float(spec.noise_sd),
                trends_ok=tuple(sorted(physical)) if category == "clean" else (),
                make_records=lambda: _records(fn()), make_nominal=lambda: _nominal(fn()), split=_split(spec),
                description=f"[{', '.join(spec.effects) or 'clean'}; nominal {spec.base_law}] {spec.description}",
                samples_per_cycle="–".join(f"{r} Hz" for r in (rates[0], rates[-1])) if len(rates) > 1
                else f"{rates[0]} Hz", noise_kind=NOISE_KINDS[spec.noise_model[0]])


NOISE_KINDS = {"white": "white", "ar1": "AR(1)", "lowpass": "low-pass"}


BEDS = ("blind", "blind2")
PREFIX = {"blind": "", "blind2": "b2_"}  # the second bed's case names, told apart from the first's (three are shared)


def _package(bed: str):
    if bed not in BEDS:
        raise ValueError(f"no blind bed {bed!r}; the beds are {BEDS}")
    return importlib.import_module(f".{bed}", __package__)


@functools.cache
def _built(bed: str, name: str) -> Case:
    return _case(getattr(_package(bed), name), PREFIX[bed])  # each bed exports its case functions by name


def bed_cases(bed: str) -> list[Case]:
    """The cases of blind bed ``bed`` (``BEDS``) in its catalogue order (each built once per process)."""
    return [_built(bed, fn.__name__) for fn in _package(bed).CASES]


def blind_case(name: str) -> Case | None:
    """The case of that name (with its bed's ``PREFIX``) in any blind bed (None if none has it); only that case is
    built."""
    for bed in BEDS:
        own = name.removeprefix(PREFIX[bed])
        if name.startswith(PREFIX[bed]) and own in _package(bed).CASE_NAMES:
            return _built(bed, own)
    return None


BLIND_CASES: list[Case] = bed_cases("blind")
BLIND_CASE_BY_NAME: dict[str, Case] = {c.name: c for c in BLIND_CASES}
