"""The loop's last phase: the chosen structure refitted on training and validation records, the structure left
measured, and the result assembled (``DiscoveryResult``, whose ``report`` is discovery.json's content)."""

from __future__ import annotations

import time

from .diagnose import diagnose
from .fitting import at as _at
from .fitting import refit_on
from .leftover import neural_leftover, residual_network, structure_flagged
from .result import DiscoveryResult, parameter_values
from .validation import parts

__all__ = ["finish"]


def finish(loop) -> DiscoveryResult:
    """Refit the chosen structure of ``loop`` (a ``loop.Loop`` after its phases), measure what is left and assemble
    the result: the models before and after, their errors on every split, the steps, and ``discovery.json``'s
    content (``DiscoveryResult.report``)."""
    o = loop.options
    model, final_sim = loop.fit.model, _at(loop.sim, loop.fit)
    initial, initial_sim = loop.initial, loop.initial_sim
    preds_before, before = loop.preds_before, loop.before
    preds_after, after = loop.evaluate(model, final_sim)
    refitted = None
    trained_model, trained_sim = model, final_sim  # the chosen structure fitted on the training records alone
    if o.refit and loop.val:  # the structure is chosen: its parameters (and the nominal's) use every non-test
        chosen = {"before": (initial, before), "after": (model, after)}
        initial, initial_sim = refit_on(initial, loop.train + loop.val, initial_sim, o.lm_steps, o.box_factor)
        model, final_sim = refit_on(model, loop.train + loop.val, final_sim, o.lm_steps, o.box_factor)
        preds_before, before = loop.evaluate(initial, initial_sim)
        preds_after, after = loop.evaluate(model, final_sim)
        refitted = {"records": [r.name for r in loop.train + loop.val]}
        for side, now in (("before", before), ("after", after)):
            m, was = chosen[side]
            refitted[side] = {"val_rmse_in_sample": now["val"].get("rmse"),
                              "test_rmse_without_refit": was["test"].get("rmse"),
                              "train_rmse_without_refit": was["train"]["rmse"],
                              "parameters_without_refit": parameter_values(m)}
            now["val"] = was["val"]  # the validation error stays out of sample
    diag_after = diagnose(loop.train, preds_after["train"], o.noise_sd)
    if o.leftover == "dynamics":
        # on the training-only fit, so that the validation records are out of sample for the physics too
        network = neural_leftover(trained_model, loop.train, loop.val or None, sim=trained_sim,
                                  conditions=loop.trend_values, progress=o.progress)
    else:
        network = residual_network(loop.train, preds_after["train"], loop.val or None,
                                   preds_after["val"] or None)
    nominal_effects = {e.name for e in initial.effects.values()}
    final_effects = [e.name for e in model.effects.values()]
    splits = loop.splits
    report = {
        "before": {"test_rmse": before["test"].get("rmse"), "train_rmse": before["train"]["rmse"],
                   "val_rmse": before["val"].get("rmse"), "per_condition": before["test"].get("per_condition", {}),
                   "parameters": parameter_values(initial), "diagnostics": loop.diag_before,
                   "first_fit": loop.first_fit},
        "after": {"test_rmse": after["test"].get("rmse"), "train_rmse": after["train"]["rmse"],
                  "val_rmse": after["val"].get("rmse"), "per_condition": after["test"].get("per_condition", {}),
                  "parameters": parameter_values(model), "diagnostics": diag_after},
        "steps": [s.as_json() for s in loop.steps], "rejected": [s.as_json() for s in loop.rejected],
        "removed": [c.as_json() for c in loop.removed], "stopped": loop.stopped,
        "effects": {"nominal": sorted(nominal_effects), "final": final_effects,
                    "keys": {key: e.name for key, e in model.effects.items()},  # each key's library name
                    "added": [e for e in final_effects if e not in nominal_effects],
                    "dropped": sorted(nominal_effects - set(final_effects))},
        "unexplained": {"train_rmse": after["train"]["rmse"], "noise_sd": o.noise_sd,
                        "dependence": diag_after["dependence"], "scale": diag_after["scale"],
                        "whiteness": diag_after["whiteness"],
                        "where": diag_after["where"], "residual_network": network,
                        "structure_flagged": structure_flagged(network, after["train"]["rmse"], o.noise_sd)},
        "settings": {"margin": o.margin, "criterion": o.criterion, "max_steps": o.max_steps, "top": o.top,
                     "further": o.further, "lm_steps": o.lm_steps,
                     "candidates": list(o.candidates) if o.candidates else "library",
                     "conditions": o.conditions if isinstance(o.conditions, bool) else list(o.conditions),
                     "backend": loop.sim.backend, "method": loop.sim.method, "substeps": loop.sim.substeps,
                     "substeps_final": final_sim.substeps,
                     "substeps_scored": {s: after[s]["substeps"] for s in splits if splits[s]},
                     "leftover": o.leftover, "validation": o.validation, "cross_check": o.cross_check,
                     "start_states": o.start_states,
                     "carried_travel": loop.scales.travel is not None,
                     "refit": bool(o.refit and loop.val)},
        "validation": {"kind": o.validation, "on": loop.score.scored, "rmse_before": loop.val0,
                       "rmse_after": loop.now.val, **parts(before=loop.val0, after=loop.now.val)},
        "refit": refitted,
        "noise": {**loop.noise, "floor_share": loop.rule.share, "sd_at_the_end": loop.rule.noise},
        "records": {s: [r.name for r in rs] for s, rs in splits.items()},
        "wall_s": time.perf_counter() - loop.start_time,
    }
    return DiscoveryResult(model=model, report=report, predictions={"before": preds_before, "after": preds_after},
                           splits=splits, initial_model=initial, steps=list(loop.steps),
                           rejected=list(loop.rejected), removed=list(loop.removed))
