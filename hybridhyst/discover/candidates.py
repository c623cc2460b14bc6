"""Candidate augmentations of a nominal model: every library effect, any parameter as a function of a
condition, and the state a record starts from (``Effect.start``). A candidate knows how to build the augmented
model, which coordinates are new, and where the search for them starts (from the data's scales and the
parameters' unit templates)."""

from __future__ import annotations

import copy
import numbers
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.records import TRAVEL_BEFORE
from ..identify.space import trend_scale
from ..physics.effects import EFFECTS, Effect
from ..physics.effects.travel_drift import TravelEffect
from ..physics.models import DrivenOscillator
from ..physics.parameters import Constant, Linear

__all__ = ["Candidate", "Scales", "condition_candidates", "control_candidates", "effect_candidates",
           "library_candidates", "start_candidates"]


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes of the data, in its units: response F, excitation x, velocity v, input u, time t."""

    F: float
    x: float
    v: float
    u: float
    # the records are a sequence (each carries the condition ``data.records.TRAVEL_BEFORE``): the largest travel
    # before a record, which scales the travel a drift with travel carries into each (None: not a sequence)
    travel: float | None = None

    @property
    def t(self) -> float:
        return self.x / self.v

    @classmethod
    def of(cls, records, oscillator: bool = False) -> Scales:
        """Scales from records: for a damper law the excitation is x and the response F; for an oscillator
        driven by a force the response is the motion x and the input u sets the force scale."""
        y = np.concatenate([np.asarray(r.y, float) for r in records])
        u = np.concatenate([np.asarray(r.x, float) for r in records])
        motion = [r.y if oscillator else r.x for r in records]
        v = np.concatenate([np.gradient(np.asarray(m, float), np.asarray(r.t, float)) for m, r in zip(motion, records)])
        pos = lambda a: float(np.std(a)) or float(np.max(np.abs(a))) or 1.0  # noqa: E731
        if oscillator:
            return cls(F=pos(u), x=pos(y), v=pos(v), u=pos(u))
        before = [r.conditions.get(TRAVEL_BEFORE) for r in records]
        numeric = all(isinstance(b, numbers.Real) and not isinstance(b, bool) for b in before)
        travel = (float(max(before)) or None) if numeric else None
        return cls(F=pos(y), x=pos(u), v=pos(v), u=pos(u), travel=travel)

    def of_unit(self, template: str) -> float | None:
        """The scale of a unit template such as ``"F*t/x"`` or ``"F/(x*u)"``; None for dimensionless."""
        if template in ("-", "", "1"):
            return None
        expr = re.sub(r"\^", "**", template)
        if not re.fullmatch(r"[Fxtu0-9*/().^ ]+", template):
            return None
        return float(eval(expr, {"__builtins__": {}}, {"F": self.F, "x": self.x, "t": self.t, "u": self.u}))


@dataclass
class Candidate:
    """One augmentation: ``build(model)`` returns the augmented copy; ``free`` its new coordinates with
    ``bounds`` and ``starts`` (a few initial values each, tried as restarts in one batch)."""

    name: str
    kind: str  # "effect", "condition" or "start"
    build_fn: object
    free: list[str]
    bounds: dict[str, tuple[float, float]]
    starts: list[dict[str, float]]
    describe: str = ""
    meta: dict = field(default_factory=dict)

    def build(self, model):
        return self.build_fn(model)


def _placed(model, key: str, effect: Effect):
    """Input operators (effects that transform the kinematics, e.g. backlash) go first; others last."""
    effects = dict(model.effects.items())
    if effect.transforms:
        return model.with_effects({key: effect, **effects})
    return model.with_effects({**effects, key: effect})


# A smoothing width (``ParameterSpec.smoothing``) is searched up to this fraction of the data's scale of its
# unit: a sign smoothed by tanh(v / v_s) then reaches its level (tanh 10 ≈ 1) at the data's typical speed.
# Wider, the "sign" is a linear or |v|-like term over the data, which is not the effect the element names.
SMOOTHING_MAX = 0.1


def _interval(spec, scale, start: float) -> tuple[float, float]:
    lo, hi = spec.bounds
    if scale is None:
        span = 100.0 * max(abs(start), 1.0)
        return max(lo, start - span), min(hi, start + span)
    if spec.smoothing:
        return max(lo, scale * 1e-3), min(hi, scale * SMOOTHING_MAX)
    if spec.constraint == "positive":
        return max(lo, scale * 1e-3), min(hi, scale * 1e3)
    if spec.constraint == "nonnegative" or lo >= 0:
        return max(lo, 0.0), min(hi, scale * 1e2)
    return max(lo, -scale * 1e2), min(hi, scale * 1e2)


def effect_candidates(model, scales: Scales, names: Sequence[str] | None = None) -> list[Candidate]:
    """One candidate per library effect not yet in ``model`` (by library name), started from the data scales.

    Amplitude-like parameters (those with a neutral value, and forces [F]) start small (0.05 and 0.3 of
    their scale); shape parameters at their scale (or default when dimensionless) and 10× that. An effect
    declares what the loop reads on its class (``Effect.discovery_candidate``, ``discovery_units``,
    ``discovery_fixed``, ``needs_drive``). Effects with neutral values also start at them: the fitted model
    itself.
    """
    present = {e.name for e in model.effects.values()}
    out = []
    for name in names if names is not None else sorted(EFFECTS):
        cls = EFFECTS[name]
        if name in present or (names is None and not cls.discovery_candidate):
            continue
        if not cls.specs:
            raise ValueError(f"effect {name!r} has no physical parameters to identify; it cannot be a candidate")
        if cls.needs_drive and not isinstance(model, DrivenOscillator):
            continue
        key = name if name not in model.effects else f"{name}_added"
        bounds, low, high, amplitudes = {}, {}, {}, set()
        hints = cls.discovery_units
        held = dict(cls.discovery_fixed)
        free = {p: spec for p, spec in cls.specs.items() if p not in held}
        for pname, spec in free.items():
            scale = scales.of_unit(hints.get(pname, spec.unit))
            if spec.neutral is not None or spec.unit == "F":
                amplitudes.add(pname)
            if scale is None:
                a = b = float(spec.default)
            elif pname in amplitudes:
                a, b = 0.05 * scale, 0.3 * scale
            else:
                a, b = scale, 10.0 * scale
            lo, hi = _interval(spec, scale, a)
            a, b = min(max(a, lo), hi), min(max(b, lo), hi)
            bounds[f"{key}.{pname}"], low[pname], high[pname] = (lo, hi), a, b

        def start(values, key=key, bounds=bounds):  # {parameter: value} -> {coordinate: value in its bounds}
            return {f"{key}.{p}": min(max(float(v), bounds[f"{key}.{p}"][0]), bounds[f"{key}.{p}"][1])
                    for p, v in values.items()}

        mixed = {p: high[p] if p in amplitudes else low[p] for p in free}
        # shape parameters also well below their scale (a sign smoothing width, a Stribeck speed): an exact sign
        # in the data needs a width far below the velocity scale, a basin the scale-sized starts do not reach
        sharp = {p: high[p] if p in amplitudes else 0.01 * low[p] for p in free}
        starts = [start(low), start(high), start(mixed), start(sharp)]
        neutral = {p: spec.neutral for p, spec in free.items() if spec.neutral is not None}
        if neutral:  # the fitted model itself: a candidate's refit can only improve on it
            starts.append(start({p: neutral.get(p, low[p]) for p in free}))
        starts = [s for i, s in enumerate(starts) if s not in starts[:i]]  # a start clipped onto another

        carried = scales.travel is not None and issubclass(cls, TravelEffect)
        if carried:  # the travel before each record, T0 + b · travel_before, from every start with b 0 and 1
            c0, c1 = f"{key}.s0.c0", f"{key}.s0.c1"
            bounds[c0], bounds[c1] = (0.0, 100.0 * scales.travel), (0.0, 10.0)
            starts = [{**s, c0: 0.0, c1: b} for b in (0.0, 1.0) for s in starts]

        def build(m, key=key, cls=cls, start=starts[0], held=held, carried=carried):
            values = {k.split(".", 1)[1]: v for k, v in start.items() if k.count(".") == 1}
            if carried:
                values["s0"] = {"kind": "linear", "slope": 0.0, "intercept": 0.0, "condition": TRAVEL_BEFORE,
                               "nonnegative": True}  # a travel, growing with the travel before: no fit can make it fall
            return _placed(m, key, cls(**values, **held, fixed=sorted(held)))

        doc = (cls.__doc__ or name).strip().splitlines()[0]
        out.append(Candidate(name=name, kind="effect", build_fn=build, free=list(bounds), bounds=bounds,
                             starts=starts, describe=doc, meta={"key": key, "effect": name}))
    return out


def condition_candidates(model, conditions: Mapping[str, Sequence[float]]) -> list[Candidate]:
    """One candidate per (constant, free parameter) × (numeric condition with at least two training values):
    the parameter becomes ``intercept + slope · condition``, starting at slope 0 (the fitted model). Its
    search box is identification's rule for a trend not yet known (``identify.space.trend_scale``); a
    parameter at exactly 0 has no size to scale it by and gets no candidate."""
    out = []
    for cond, values in conditions.items():
        values = sorted({float(v) for v in values})
        if len(values) < 2:
            continue
        mid = 0.5 * (values[0] + values[-1])
        for key, effect in model.effects.items():
            for pname, fn in effect.params.items():
                if not isinstance(fn, Constant) or pname in effect.start:  # a start state is the protocol's
                    continue
                v = float(fn.value.detach())
                slope = trend_scale(v, 1, values[0], values[-1])
                if slope is None:  # a parameter at 0 has no size to scale a trend by
                    continue
                name = f"{key}.{pname}~{cond}"

                def build(m, key=key, pname=pname, cond=cond, v=v):
                    new = m.with_effects(dict(m.effects.items()))
                    new.effects[key].params[pname] = Linear(slope=0.0, intercept=v, condition=cond).to(
                        next(new.parameters()).dtype)
                    return new

                c0, c1 = f"{key}.{pname}.c0", f"{key}.{pname}.c1"
                # start with the value at the centre of the training conditions unchanged
                starts = [{c0: v - s * slope * mid, c1: s * slope} for s in (-0.3, 0.3)]
                out.append(Candidate(name=name, kind="condition", build_fn=build, free=[c0, c1], bounds={},
                                     starts=starts, describe=f"{key}.{pname} as a linear function of {cond}.",
                                     meta={"key": key, "param": pname, "condition": cond, "centre": mid}))
    return out


def start_candidates(model, scales: Scales) -> list[Candidate]:
    """One candidate per effect of ``model`` whose state may start a record away from rest (``Effect.start``: a
    gap's position, a presliding deflection) and that still starts at 0: every record then starts from one
    fitted state, shared by all (the records of one test protocol start after the same kind of motion). It
    starts at 0 (the fitted model itself) and at ± 0.05 and ± 0.3 of the data's scale of the state's unit; its
    box is the general one for a real coordinate (``_interval``)."""
    out = []
    for key, effect in model.effects.items():
        if not effect.start or not effect.start_candidate or any(name in effect.params for name in effect.start):
            continue
        bounds, starts = {}, [{}]
        for pname, spec in effect.start.items():
            scale = scales.of_unit(spec.unit) or 1.0
            coord = f"{key}.{pname}"
            bounds[coord] = _interval(spec, scale, 0.0)
            starts = [{**s, coord: f * scale} for s in starts for f in (0.0, -0.05, 0.05, -0.3, 0.3)]

        def build(m, key=key):
            effect = copy.deepcopy(m.effects[key])
            for pname, spec in effect.start.items():
                effect.add_parameter(pname, 0.0, spec)
            return m.with_effects({**dict(m.effects.items()), key: effect.to(next(m.parameters()).dtype)})

        names = ", ".join(effect.start)
        out.append(Candidate(name=f"{key}.start", kind="start", build_fn=build, free=list(bounds), bounds=bounds,
                             starts=starts, describe=f"every record starts with {key}'s state at a fitted value "
                             f"({names}) instead of at rest.", meta={"key": key, "effect": effect.name}))
    return out


def control_candidates(model, scales: Scales, controls: Sequence[str]) -> list[Candidate]:
    """One ``control_lag`` per control channel a parameter of ``model`` follows and no lag acts on yet: the control
    reaches the parameters through a first-order lag (a coil's current behind its voltage). It starts at time
    constants of 0.01, 0.1 and 1 times the data's time scale (``Scales.t``) and is searched from 1e-4 to 10 times
    it; a lag much faster than the data is the model without it."""
    from ..physics.effects import ControlLag
    from ..physics.models import conditions_used

    read = set(conditions_used(model))
    lagged = {e.control for e in model.effects.values() if isinstance(e, ControlLag)}
    out = []
    for control in controls:
        if control not in read or control in lagged:
            continue
        key = f"lag_{control}"
        coord = f"{key}.eta"
        bounds = {coord: (0.1 / scales.t, 1e4 / scales.t)}
        starts = [{coord: f / scales.t} for f in (1.0, 10.0, 100.0)]

        def build(m, key=key, control=control):
            return _placed(m, key, ControlLag(control=control, eta=10.0 / scales.t).to(next(m.parameters()).dtype))

        out.append(Candidate(name=f"control_lag~{control}", kind="effect", build_fn=build, free=[coord],
                             bounds=bounds, starts=starts, describe=f"{control} reaches the parameters that follow "
                             f"it through a first-order lag (du/dt = -eta (u - {control})).",
                             meta={"key": key, "effect": "control_lag", "control": control}))
    return out


def library_candidates(model, scales: Scales, conditions: Mapping[str, Sequence[float]] | None = None,
                       effects: Sequence[str] | None = None, start_states: bool = True,
                       controls: Sequence[str] = ()) -> list[Candidate]:
    """Every effect candidate (or those named in ``effects``), every condition candidate, (``start_states``)
    every start-state candidate, and a lag of each of the ``controls`` a parameter follows."""
    out = effect_candidates(model, scales, effects)
    if conditions:
        out += condition_candidates(model, conditions)
    out += control_candidates(model, scales, controls) if effects is None else []
    return out + (start_candidates(model, scales) if start_states else [])

