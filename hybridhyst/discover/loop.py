"""The closed loop: fit the nominal, diagnose the residual, rank candidate effects, add the best, refit,
accept on validation error and an information criterion, repeat; then say what is left.

Ranking: the model augmented by each candidate is refitted with every coordinate free (the candidate's few
starting values as restarts of one batched Levenberg–Marquardt, the other coordinates from their fitted
values, first re-balanced against each start; LM continued until converged), and the share of the training
residual's sum of squares that disappears is the candidate's evidence. Of the best ``top`` candidates the one
with the lowest validation RMSE is chosen (among those within ``margin`` of it, the one with the lowest
information criterion: validation cannot tell them apart, so the more parsimonious wins) and accepted if its
validation RMSE falls by more than ``margin`` (relative) and the information criterion (BIC by default)
improves.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import torch

from ..data.records import Record, RecordSet
from ..data.splits import Split, check_conditions
from ..identify import identify
from ..identify.space import outside_domain
from ..physics.models import conditions_used
from ..progress import progress as progress_bar
from ..settings import intra_op_threads
from ..simulate.fast import prebuild_models
from .candidates import Scales, library_candidates
from .diagnose import diagnose
from .fitting import at as _at
from .fitting import fit_candidate, polish, side_by_side, sse_at
from .leftover import LEFTOVER, neural_leftover, residual_network, structure_flagged
from .selection import information_criterion, simplify
from .trends import MIN_LEVELS, fit_trends
from .validation import Validation, improves, parts, record_metrics, rmse_on, simulated, within

__all__ = ["DiscoveryResult", "discover", "information_criterion"]


@dataclass
class DiscoveryResult:
    """What ``discover`` found. ``model``: the final model; ``report``: the ``discovery.json`` content;
    ``predictions``: ``{"before"|"after": {split: [arrays per record]}}``; ``splits``: the record sets."""

    model: torch.nn.Module
    report: dict
    predictions: dict = field(default_factory=dict)
    splits: dict = field(default_factory=dict)
    initial_model: torch.nn.Module | None = None


def _as_records(records) -> list[Record]:
    return list(records.records if isinstance(records, RecordSet) else records)


def _numeric_conditions(records) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for r in records:
        for k, v in r.conditions.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)):
                out.setdefault(k, []).append(float(v))
    return {k: v for k, v in out.items() if len(v) == len(records)}


def _trend_conditions(conditions, parts: Split) -> dict[str, list[float]]:
    """``{condition: training values}`` the loop may make parameters depend on: those named (each a number in
    every record, training, validation and test, with at least two training values; else a one-line error),
    or with ``True`` every condition that is a number in every record (one that a validation or test record
    lacks could not be evaluated there, so it is not offered)."""
    if not conditions:
        return {}
    train = list(parts.train)
    if isinstance(conditions, bool):
        usable = _numeric_conditions([*train, *parts.val, *parts.test])
        return {k: v for k, v in _numeric_conditions(train).items() if k in usable}
    if isinstance(conditions, str):
        raise ValueError(f"conditions must be true, false or a list of condition names, got {conditions!r}")
    check_conditions(parts, list(conditions), "discover conditions", min_train_values=2)
    values = _numeric_conditions(train)
    return {c: values[c] for c in conditions}


def _parameters(model) -> dict:
    return {f"{e}.{p}": {"value": info["value"], "unit": info["unit"]}
            for e, params in model.parameter_table().items() for p, info in params.items()}


def discover(records, nominal, candidates: Sequence[str] | None = None, split: Mapping | None = None, *,
             conditions: bool | Sequence[str] = True, label_conditions: Sequence[str] | None = None,
             margin: float = 0.02, criterion: str = "bic", max_steps: int = 4,
             top: int = 3, lm_steps: int = 25, box_factor: float = 10.0, noise_sd: float | None = None,
             fit_nominal: bool = True, identify_options: Mapping | None = None, backend: str = "fast",
             method: str = "rk4", substeps: int = 1, refit: bool = True, leftover: str = "static",
             validation: str = "records", start_states: bool = True, progress: bool = True,
             workers: int = 1, torch_threads: int | None = 1) -> DiscoveryResult:
    """Find, name and add the effects a nominal model lacks; report the error before and after.

    Parameters
    ----------
    records : a ``RecordSet`` (or list of records) with operating conditions.
    nominal : the starting ``NominalModel`` (fitted in place and then augmented copies of it).
    candidates : library effect names to consider (default: the whole library, see ``candidates.py``).
    split : ``{"held_out": query, "val": query}`` as ``RecordSet.split``; test = held-out conditions.
    conditions : also try making each constant parameter a linear function of each numeric condition
        (True), of the conditions named (a list), or of none (False). Name only conditions that mean the
        same physical thing on the held-out records (e.g. not a test frequency that is 0 for an earthquake).
    label_conditions : conditions shown in per-condition labels (default: all).
    margin : relative fall of the validation RMSE (training RMSE without validation records) required.
    validation : what that RMSE is (``validation.py``): "records", the validation records' error (the training
        records' without any); "loco", leave one operating condition out: each group of training records
        that share their conditions predicted by the model refitted on the others, pooled with the
        validation records' error (a refit per training operating point for every model scored); or "both",
        the validation records' error and the training groups' leave-one-out error, each of which must fall
        by the margin (``validation.Score``; the report gives both as ``parts_*``).
    start_states : also try starting every record from one fitted state of an element the motion before a record
        may leave away from rest (``Effect.start``: a gap's position, a presliding deflection), one candidate
        per such element (``candidates.start_candidates``).
    criterion : "bic" or "aic", which must also fall; max_steps : steps accepted at most (an effect, a
        parameter function of a condition or a start state each).
    top : best-ranked candidates compared on validation error; lm_steps : LM iterations per round of
        a fit (more rounds while the cost still falls by more than 0.1 %, at most 4).
    noise_sd : known noise level (reported beside the residual RMSE; not used by the rule).
    fit_nominal : identify the nominal on the training records first (``hybridhyst.identify``, options in
        ``identify_options``); else start from its current values.
    backend, method, substeps : simulator settings ("fast": compiled, cached per model structure).
    refit : once the structure is chosen, refit every parameter of the final model, and of the nominal it is
        compared with, on the training *and* validation records (as a cross-validated search refits its
        winner on all the data it may use). The validation RMSEs reported stay those of the training-only
        fits, measured before the refit (out of sample); test and training errors, parameters and
        predictions are the refitted models'. ``report["refit"]`` keeps the numbers without the refit.
    leftover : how the structure left is measured (``leftover.py``): "static", a small network of the
        kinematics fitted to the final residual point by point (seconds); "dynamics", a network with a latent
        state fitted *inside* the final model's equations through the simulator (a memory a pointwise
        correction cannot have; tens of seconds on the bundled BRFD, more on long records), on the
        training-only fit (before the refit) so that the validation records are out of sample for the physics
        too. Either's share of the residual recovered on validation records is reported and sets the flag when
        no noise level is known.
    workers : candidates fitted at once, each in a thread of its own (the compiled loops release the GIL; each
        fit's rows then run in its own thread). The fits and the result are the same for any number.
    torch_threads : torch intra-op threads during the run (restored after; None leaves them), as ``identify``.

    Raises
    ------
    ValueError
        Unknown candidate names, a split leaving no training records, records too short to identify.
    """
    settings = {k: v for k, v in locals().items() if k not in ("records", "nominal", "torch_threads")}
    with intra_op_threads(torch_threads):
        return _discover(records, nominal, **settings)


def _discover(records, nominal, candidates, split, *, conditions, label_conditions, margin, criterion, max_steps,
              top, lm_steps, box_factor, noise_sd, fit_nominal, identify_options, backend, method, substeps, refit,
              leftover, validation, start_states, progress, workers) -> DiscoveryResult:
    start = time.perf_counter()
    if criterion not in ("bic", "aic"):
        raise ValueError(f"unknown information criterion {criterion!r}; choose 'bic' or 'aic'")
    if leftover not in LEFTOVER:
        raise ValueError(f"unknown leftover measure {leftover!r}; choose one of {list(LEFTOVER)}")
    records = records if isinstance(records, RecordSet) else RecordSet(_as_records(records))
    from ..physics.effects import EFFECTS

    unknown = [c for c in (candidates or []) if c not in EFFECTS]
    if unknown:
        raise ValueError(f"unknown candidate effect(s) {unknown}; the library has {sorted(EFFECTS)}")
    split = dict(split or {})
    train_set, val_set, test_set = records.split(held_out=split.get("held_out"), val=split.get("val"))
    train, val, test = _as_records(train_set), _as_records(val_set), _as_records(test_set)
    sim = {"backend": backend, "method": method, "substeps": int(substeps)}
    if not train:
        raise ValueError(f"the split {split} leaves no training record; hold out fewer conditions")
    cond_values = _trend_conditions(conditions, Split(train, val, test))
    trend_values = dict(cond_values)  # the conditions a parameter may depend on: a leftover network reads them too
    check_conditions(Split(train, val, test), conditions_used(nominal),
                     "the nominal model (a parameter as a function of a condition)")
    n_train = sum(len(r) for r in train)
    for r in train:
        r.require_samples(16, "discovery (identifying a candidate effect)")
    score = Validation(validation, train, val, lm_steps=lm_steps, box_factor=box_factor)  # refuses a bad kind
    model = nominal
    if fit_nominal:
        opts = {"method": "cma", "pop": 24, "generations": 30, "restarts": 4, **dict(identify_options or {})}
        identify(model, train, fisher=False, progress=progress, backend=backend, ode_method=method,
                 substeps=substeps, **opts)
    splits = {"train": train, "val": val, "test": test}

    def evaluate(m, at):  # predictions of every split (simulated once), their metrics and sub-steps; the training
        runs = {s: simulated(m, rs, at, resolve=s != "train") for s, rs in splits.items()}  # split at the fit's own
        preds = {s: run[0] for s, run in runs.items()}
        return preds, {s: {**record_metrics(splits[s], preds[s], label_conditions),
                           "substeps": runs[s][1]} for s in splits}

    opts = {"lm_steps": lm_steps, "box_factor": box_factor, "margin": margin, "criterion": criterion,
            "workers": int(workers)}
    outside = outside_domain(model, train)
    if outside:
        raise ValueError(f"the nominal model's parameter {outside[0]}: outside its domain on a training record "
                         "(a trend that crosses zero between the data's levels); give values or a trend that stay "
                         "inside it" + ("" if fit_nominal else ", or let the loop identify the nominal first "
                                        "(fit_nominal)"))
    fit = polish(model, train, sim, lm_steps, box_factor)
    initial, initial_sim = copy.deepcopy(fit.model), _at(sim, fit)  # "before": the nominal as fitted
    preds_before, before = evaluate(initial, initial_sim)
    ic = information_criterion(fit.sse, n_train, fit.k, criterion)
    val_rmse = val_rmse0 = score(initial, initial_sim)
    diag_before = diagnose(train, preds_before["train"], noise_sd)
    steps, rejected, removed = [], [], []
    tried = set()
    from ..physics.models import DrivenOscillator

    scales = Scales.of(train, oscillator=isinstance(model, DrivenOscillator))
    # conditions with enough levels get their trends in one step (every constant parameter at once), before the
    # effects and again after them for the parameters the effects brought; the others keep the
    # one-parameter-at-a-time candidates
    trend_conditions = [c for c in cond_values if len(set(cond_values[c])) >= MIN_LEVELS]
    for cond in trend_conditions:
        cond_values.pop(cond)

    def tidy() -> None:  # the removals and special cases tried after every accepted change
        nonlocal fit, ic, val_rmse, removed
        fit, ic, val_rmse, gone = simplify(fit, train, sim, scales, n_train, opts, ic, val_rmse, score,
                                           (lambda items, what: progress_bar(items, what, enabled=progress)))
        for g in gone:
            g["after_step"] = len(steps)
            tried.add(g["effect"])  # a removed or replaced effect is not offered again
        removed += gone

    def try_trends(cond: str, when: str, effects: set[str] | None = None) -> None:
        """Offer the trends of ``cond`` (of ``effects``' parameters, or all); once accepted, ``tidy``: an element
        that stood in for them may have nothing left to do (as after any change)."""
        nonlocal fit, ic, val_rmse
        res = fit_trends(fit, train, sim, cond, lm_steps, box_factor, effects)
        if res is None:
            return
        t_fit, chosen = res
        t_val, t_ic = score(t_fit.model, _at(sim, t_fit)), information_criterion(
            t_fit.sse, n_train, t_fit.k, criterion)
        accepted = improves(t_val, val_rmse, margin) and t_ic < ic
        entry = {"effect": f"trends~{cond}", "kind": "trend", "when": when,
                 "description": f"parameters as functions of {cond}" + (
                     " (those of the effects added)" if when == "after effects" else ""),
                 "trends": chosen, "evidence": {"val_rmse_before": val_rmse, "val_rmse_after": t_val,
                                                **parts(before=val_rmse, after=t_val),
                                                f"{criterion}_before": ic, f"{criterion}_after": t_ic},
                 "parameters": _parameters(t_fit.model), "train_rmse": math.sqrt(t_fit.sse / n_train),
                 "val_rmse": t_val if score.out_of_sample else None, "accepted": accepted,
                 "test_rmse": rmse_on(t_fit.model, test, _at(sim, t_fit)) if test else None}
        (steps if accepted else rejected).append(entry)
        if accepted:
            fit, ic, val_rmse = t_fit, t_ic, t_val
            tidy()

    for cond in trend_conditions:
        try_trends(cond, "before effects")
    stopped = "rule"  # the best candidate was not accepted, or none was left
    rivals: dict[str, list[str]] = {}  # effect added -> the close calls of its step (tried again at the end)
    for _step in range(int(max_steps)):
        cands = [c for c in library_candidates(fit.model, scales, cond_values, candidates, start_states)
                 if c.name not in tried]
        if not cands:
            break
        if backend == "fast":  # every candidate's compiled loops built side by side, before they are fitted in turn
            _prebuild(cands, fit.model)
        ranking = _fit_candidates(cands, fit.model, train, _at(sim, fit), lm_steps, box_factor, int(workers),
                                  progress)
        ranking.sort(key=lambda item: item[1].sse if item[1] is not None else math.inf)
        ref = {s_: sse_at(fit, train, sim, s_) for s_ in {f.substeps for _, f in ranking if f is not None}}
        evidence = {c.name: (1 - f.sse / ref[f.substeps] if f is not None and ref[f.substeps] > 0 else None)
                    for c, f in ranking}
        finals = [(cand, f, score(f.model, _at(sim, f)))
                  for cand, f in ranking[: int(top)] if f is not None]
        if not finals:
            break
        # the lowest validation error; among candidates validation cannot tell apart (within the margin),
        # the lowest information criterion (the most parsimonious explanation)
        best_val = min((f[2] for f in finals), key=lambda v: v.key)
        close = [f for f in finals if within(f[2], best_val, margin)]
        cand, c_fit, f_val = min(close, key=lambda f: information_criterion(f[1].sse, n_train, f[1].k, criterion))
        f_ic = information_criterion(c_fit.sse, n_train, c_fit.k, criterion)
        ic_ref = information_criterion(ref[c_fit.substeps], n_train, fit.k, criterion)  # at the same resolution
        accepted = improves(f_val, val_rmse, margin) and f_ic < min(ic, ic_ref)
        entry = {"effect": cand.name, "kind": cand.kind, "description": cand.describe,
                 "evidence": {"explained_share": evidence[cand.name], "ranking": evidence,
                              "val_rmse_before": val_rmse, "val_rmse_after": f_val,
                              **parts(before=val_rmse, after=f_val),
                              f"{criterion}_before": ic, f"{criterion}_after": f_ic,
                              "refitted": [f[0].name for f in finals],
                              "compared": {f[0].name: {"val_rmse": f[2], "criterion": information_criterion(
                                  f[1].sse, n_train, f[1].k, criterion), **parts(val=f[2])} for f in finals}},
                 "parameters": _parameters(c_fit.model),
                 "new_coordinates": {n: c_fit.coords.get(n) for n in cand.free},
                 "train_rmse": math.sqrt(c_fit.sse / n_train), "substeps": c_fit.substeps,
                 "val_rmse": f_val if score.out_of_sample else None,
                 "test_rmse": rmse_on(c_fit.model, test, _at(sim, c_fit)) if test else None, "accepted": accepted}
        if not accepted:
            rejected.append(entry)
            break
        steps.append(entry)
        tried.add(cand.name)
        # the close calls: finalists validation turned down where the information criterion preferred them
        rivals[cand.name] = [f[0].name for f in finals if f[0] is not cand and f[0].kind == "effect"
                             and information_criterion(f[1].sse, n_train, f[1].k, criterion) < f_ic]
        fit = polish(c_fit.model, train, _at(sim, c_fit), lm_steps, box_factor)
        ic, val_rmse = information_criterion(fit.sse, n_train, fit.k, criterion), score(fit.model, _at(sim, fit))
        tidy()
    else:  # every step accepted an effect: the cap ended the loop, not the rule
        stopped = "max_steps"
    # each added effect against the close calls of its step, on the final model (once; the model has been
    # through the removals and special cases after its last step: those are not tried again until a swap)
    rivals = {name: [r for r in names if r not in tried] for name, names in rivals.items()}
    if any(rivals.values()):
        fit, ic, val_rmse, gone = simplify(fit, train, sim, scales, n_train, opts, ic, val_rmse, score,
                                           (lambda items, what: progress_bar(items, what, enabled=progress)), rivals,
                                           settled=True)
        for g in gone:
            g["after_step"] = len(steps)
        removed += gone
    added_keys = set(fit.model.effects) - set(initial.effects)
    if added_keys:  # the added effects' own parameters may depend on the condition (the nominal's had their turn)
        for cond in trend_conditions:
            try_trends(cond, "after effects", added_keys)
    model, final_sim = fit.model, _at(sim, fit)
    preds_after, after = evaluate(model, final_sim)
    refitted = None
    trained_model, trained_sim = model, final_sim  # the chosen structure fitted on the training records alone
    if refit and val:  # the structure is chosen: its parameters (and the nominal's) use every non-test record
        chosen = {"before": (initial, before), "after": (model, after)}
        initial, initial_sim = _refit_on(initial, train + val, initial_sim, lm_steps, box_factor)
        model, final_sim = _refit_on(model, train + val, final_sim, lm_steps, box_factor)
        preds_before, before = evaluate(initial, initial_sim)
        preds_after, after = evaluate(model, final_sim)
        refitted = {"records": [r.name for r in train + val]}
        for side, now in (("before", before), ("after", after)):
            m, was = chosen[side]
            refitted[side] = {"val_rmse_in_sample": now["val"].get("rmse"),
                              "test_rmse_without_refit": was["test"].get("rmse"),
                              "train_rmse_without_refit": was["train"]["rmse"],
                              "parameters_without_refit": _parameters(m)}
            now["val"] = was["val"]  # the validation error stays out of sample
    diag_after = diagnose(train, preds_after["train"], noise_sd)
    if leftover == "dynamics":
        # on the training-only fit, so that the validation records are out of sample for the physics too
        network = neural_leftover(trained_model, train, val or None, sim=trained_sim, conditions=trend_values,
                                  progress=progress)
    else:
        network = residual_network(train, preds_after["train"], val or None, preds_after["val"] or None)
    nominal_effects = {e.name for e in initial.effects.values()}
    final_effects = [e.name for e in model.effects.values()]
    report = {
        "before": {"test_rmse": before["test"].get("rmse"), "train_rmse": before["train"]["rmse"],
                   "val_rmse": before["val"].get("rmse"), "per_condition": before["test"].get("per_condition", {}),
                   "parameters": _parameters(initial), "diagnostics": diag_before},
        "after": {"test_rmse": after["test"].get("rmse"), "train_rmse": after["train"]["rmse"],
                  "val_rmse": after["val"].get("rmse"), "per_condition": after["test"].get("per_condition", {}),
                  "parameters": _parameters(model), "diagnostics": diag_after},
        "steps": steps, "rejected": rejected, "removed": removed, "stopped": stopped,
        "effects": {"nominal": sorted(nominal_effects), "final": final_effects,
                    "added": [e for e in final_effects if e not in nominal_effects],
                    "dropped": sorted(nominal_effects - set(final_effects))},
        "unexplained": {"train_rmse": after["train"]["rmse"], "noise_sd": noise_sd,
                        "dependence": diag_after["dependence"], "scale": diag_after["scale"],
                        "whiteness": diag_after["whiteness"],
                        "where": diag_after["where"], "residual_network": network,
                        "structure_flagged": structure_flagged(network, after["train"]["rmse"], noise_sd)},
        "settings": {"margin": margin, "criterion": criterion, "max_steps": max_steps, "top": top,
                     "lm_steps": lm_steps, "candidates": list(candidates) if candidates else "library",
                     "conditions": conditions if isinstance(conditions, bool) else list(conditions),
                     "backend": backend, "method": method, "substeps": substeps,
                     "substeps_final": final_sim["substeps"],
                     "substeps_scored": {s: after[s]["substeps"] for s in splits if splits[s]},
                     "leftover": leftover, "validation": validation,
                     "refit": bool(refit and val)},
        "validation": {"kind": validation, "on": score.scored, "rmse_before": val_rmse0, "rmse_after": val_rmse,
                       **parts(before=val_rmse0, after=val_rmse)},
        "refit": refitted,
        "records": {"train": [r.name for r in train], "val": [r.name for r in val], "test": [r.name for r in test]},
        "wall_s": time.perf_counter() - start,
    }
    return DiscoveryResult(model=model, report=report, predictions={"before": preds_before, "after": preds_after},
                           splits=splits, initial_model=initial)


def _fit_candidates(cands, model, train, sim, lm_steps, box_factor, workers: int, progress: bool) -> list:
    """``[(candidate, Fit or None)]`` in the candidates' order: each fitted (``fit_candidate``), ``workers`` at a
    time; a candidate that cannot be simulated gets None."""
    def one(cand):
        try:
            return fit_candidate(cand, model, train, sim, lm_steps, box_factor)
        except (ValueError, RuntimeError):  # a candidate that cannot be simulated is skipped
            return None

    fits = side_by_side(one, cands, workers,
                        lambda items, n: progress_bar(items, "rank candidates", total=n, enabled=progress))
    return list(zip(cands, fits))


def _prebuild(cands, model) -> None:
    """Build the candidates' compiled loops at once (one compiler per core); a candidate that cannot be built is
    left to its own fit, which skips it."""
    built = []
    for cand in cands:
        try:
            built.append(cand.build(model))
        except (ValueError, RuntimeError):
            continue
    try:
        prebuild_models(built)
    except (ValueError, RuntimeError):
        pass


def _refit_on(model, records, sim: dict, lm_steps: int, box_factor: float):
    """A copy of ``model`` with every coordinate refitted on ``records`` (LM from its values); its settings."""
    f = polish(copy.deepcopy(model), records, sim, lm_steps, box_factor)
    return f.model, _at(sim, f)
