"""Dependence of a model's parameters on an operating condition, chosen in one step.

Instead of making one parameter at a time a function of the condition (each competing with the effects for
a step), every constant parameter is first identified per condition level (``PerCondition``, one joint fit),
then each parameter's values across the levels choose their own trend — constant, linear or one of seed 002's
exponential forms — by the corrected AIC over the levels, and the model with those trends is refitted. The loop
offers this step before the effects (every constant parameter) and again after them, for the parameters of the
effects it added (``effects``).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..analysis.loops import fit_trend
from ..physics.parameters import Constant, ExpDecay, ExpGrowth, ExpRise, Linear, ParameterSpec, PerCondition
from ..simulate import SimulationSettings
from .fitting import Fit, polish

__all__ = ["choose_trend", "fit_trends"]

# AICc over the levels can prefer a k-coefficient trend only where n − k − 1 > 0: a line from four levels on,
# seed 002's three-coefficient exponentials from five. A condition with fewer training levels is offered one
# parameter at a time instead (a linear function judged on every sample, like an effect).
MIN_LEVELS = 4
MIN_LEVELS_EXPONENTIAL = 5


def _aicc(rss: float, n: int, k: int) -> float:
    """Small-sample corrected AIC: over 7–9 levels BIC takes a trend in pure scatter a third of the time,
    AICc about one in seven (``tests/test_discover.py``)."""
    return n * math.log(max(rss, 1e-300) / n) + 2 * k + 2 * k * (k + 1) / max(n - k - 1, 1e-9)


EXPONENTIAL = {"exp_growth": ExpGrowth, "exp_rise": ExpRise, "exp_decay": ExpDecay}


def choose_trend(c: np.ndarray, y: np.ndarray, spec: ParameterSpec | None = None) -> tuple[str, dict]:
    """The trend of values ``y`` at levels ``c`` with the lowest AICc over the levels: ``("constant",
    {"value"})``, ``("linear", {"slope", "intercept"})`` (from four levels on) or, from five levels on, one
    of seed 002's exponential forms (``analysis.fit_trend``: ``"exp_growth"``, ``"exp_rise"``, ``"exp_decay"`` with
    ``{"y0", "a", "b"}``). With the parameter's ``spec``, only trends whose values at the levels its domain admits
    (``ParameterSpec.admits``: a line through a level rising from zero can dip below it at the lowest): a start
    outside the domain simulates nothing, and no refit could move it (the mean of admitted values always is)."""
    c, y = np.asarray(c, float), np.asarray(y, float)
    n = len(c)
    fits = {"constant": ({"value": float(y.mean())}, float(np.sum((y - y.mean()) ** 2)), 1)}
    at = {"constant": np.full_like(c, y.mean())}
    slope, intercept = np.polyfit(c, y, 1)
    fits["linear"] = ({"slope": float(slope), "intercept": float(intercept)},
                      float(np.sum((y - (intercept + slope * c)) ** 2)), 2)
    at["linear"] = intercept + slope * c
    for kind in EXPONENTIAL if n >= MIN_LEVELS_EXPONENTIAL else ():
        try:
            tf = fit_trend(c, y, kind)
        except ValueError:  # did not converge
            continue
        fits[kind] = ({"y0": tf.y0, "a": tf.a, "b": tf.b}, float(np.sum((y - tf(c)) ** 2)), 3)
        at[kind] = tf(c)
    if spec is not None:
        fits = {k: f for k, f in fits.items() if k == "constant" or bool(spec.admits(torch.as_tensor(at[k])).all())}
    scale = float(np.mean(y**2)) or 1.0
    name = min(fits, key=lambda k: _aicc(fits[k][1] + 1e-12 * scale * n, n, fits[k][2]))
    return name, fits[name][0]


def _free_constants(model):
    """The constant parameters (not a start state: one for every record of a protocol, ``Effect.start``)."""
    return [(key, pname) for key, effect in model.effects.items() for pname, fn in effect.params.items()
            if isinstance(fn, Constant) and pname not in effect.start]


def fit_trends(fit: Fit, train, sim: SimulationSettings, condition: str, lm_steps: int, box_factor: float,
               effects: set[str] | None = None):
    """Per-condition identification of every constant parameter (of the effects keyed in ``effects`` only, less
    their sign-smoothing widths, when given), then a trend per parameter; returns ``(Fit of the model with
    trends, {"effect.param": trend})``, ``(None, {...})`` when every parameter's levels are best described by a
    constant (nothing to refit), or None (fewer than ``MIN_LEVELS`` levels, or no constant parameter)."""
    values = [float(r.conditions[condition]) for r in train]
    levels = sorted(set(values))
    params = [(key, pname) for key, pname in _free_constants(fit.model)
              if effects is None or (key in effects and not fit.model.effects[key].param_specs[pname].smoothing)]
    if len(levels) < MIN_LEVELS or not params:
        return None
    per = fit.model.with_effects(dict(fit.model.effects.items()))
    for key, pname in params:
        effect = per.effects[key]
        value = float(effect.params[pname].value.detach())
        effect.params[pname] = PerCondition(levels, value, condition, effect.param_specs[pname]).to(
            effect.params[pname].value.dtype)
    per_fit = polish(per, train, sim.at(fit.substeps), lm_steps, box_factor)
    trended = fit.model.with_effects(dict(fit.model.effects.items()))
    chosen = {}
    for key, pname in params:
        y = per_fit.model.effects[key].params[pname].values.detach().numpy()
        kind, coef = choose_trend(np.asarray(levels), y, per_fit.model.effects[key].param_specs[pname])
        chosen[f"{key}.{pname}"] = kind
        effect = trended.effects[key]
        dtype = effect.params[pname].value.dtype
        if kind == "linear":
            effect.params[pname] = Linear(coef["slope"], coef["intercept"], condition).to(dtype)
        elif kind in EXPONENTIAL:
            effect.params[pname] = EXPONENTIAL[kind](coef["y0"], coef["a"], coef["b"], condition).to(dtype)
        else:
            effect.params[pname] = Constant(coef["value"], effect.param_specs[pname]).to(dtype)
    if all(kind == "constant" for kind in chosen.values()):
        return None, chosen
    return polish(trended, train, sim.at(per_fit.substeps), lm_steps, box_factor), chosen
