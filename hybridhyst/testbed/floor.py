"""How low can a case's held-out error go with the library's structures? Each fitted to the scored records themselves.

A case's held-out RMSE target (``run.RMSE_RATIO`` × noise) is reachable by the discovery loop only where some
library structure reaches it. This module measures what the structures reach on the held-out records when they
are *fitted to those records*: an in-sample error, which no model trained on other records can be expected to
beat. Each held-out record is fitted alone (its parameters its own, so a parameter's dependence on the condition
costs nothing): generous to every structure.

On each held-out record (``record_floor``), with the loop's own machinery and defaults (``discover.loop.Loop``
with that record as its only training record, every other record of the case held out so that the travel carried
into the record is the case's, the case's noise level), each candidate's global search wider than the loop's
(``SEARCH`` points, the loop's 24):

* ``nominal``: the nominal identified and converged as the loop does it (``Loop.nominal``);
* ``effects``: the nominal with each library effect the loop offers, and each the case expects (offered or not),
  fitted as the loop fits a candidate (``discover.fitting.fit_candidate``: search, re-balance, LM, edges followed,
  step doubling);
* ``expected``: the expected structure: for each family of ``Case.expected`` the best member, with its start state
  where the effect has one (``discover.candidates.start_candidates``), the second family's members fitted on top
  of the first's best, both orders of a pair. A clean or out-of-library case expects nothing: its expected
  structure is the nominal;
* ``discovered`` (``case_floor`` with ``loop``): the model the loop ended with on the case's own split, refitted
  to the record from its values.

``case_floor`` pools the records (RMSE over all their samples) and divides by the noise sd. A case whose best
structure stays above the target even so cannot meet it with one library effect (or the expected pair); a case
where a structure reaches it and the loop does not is the loop's miss. Two effects beside the expected ones are
not tried (the floor is of single effects and the expected structure).
"""

from __future__ import annotations

import copy
import itertools
import math
import time
from dataclasses import replace

import torch

from ..discover.candidates import Scales, effect_candidates, start_candidates
from ..discover.fitting import at, fit_candidates, polish, prebuild
from ..discover.loop import Loop
from ..discover.settings import DiscoverSettings
from ..physics.effects import EFFECTS
from .cases import Case
from .run import run_case

__all__ = ["SEARCH", "case_floor", "record_floor"]

SEARCH = 128  # points of each candidate's global search: more than the loop's 24, since a floor is a lower bound


def _loop(case: Case, record: str) -> Loop:
    """The loop's state after its nominal phase, with ``record`` its only training record (every other record of
    the case held out, so that a history carried between records is the one the record has in the case)."""
    settings = DiscoverSettings(split={"held_out": lambda r: r.name != record}, noise_sd=case.noise,
                                progress=False)
    loop = Loop(case.records(), case.nominal(), settings)
    if loop.scales.travel is None and loop.options.carried_travel:  # a first record carries no travel before it;
        # the others of the case do, and the bed's drifts fit an offset T0 scaled by them
        every = [*loop.train, *loop.val, *loop.test]
        loop.scales = replace(loop.scales, travel=Scales.of(every).travel)
    loop.nominal()
    return loop


def _fitted(loop: Loop, cands, fit, search: int) -> dict:
    """``{candidate name: Fit}`` of ``cands`` on ``fit``'s model, fitted as the loop fits its candidates
    (``discover.fitting.fit_candidates``) with ``search`` points of the global search and ``search // 8`` of them
    kept as starts; one that cannot be simulated is left out."""
    o = loop.options
    fits = fit_candidates(cands, fit.model, loop.train, at(loop.sim, fit), o.lm_steps, o.box_factor,
                          search=search, keep=max(search // 8, 3))
    return {c.name: f for c, f in fits if f is not None}


def _with_start(loop: Loop, fit, key: str, search: int):
    """``fit`` or, where it does better, the fit with effect ``key``'s start state fitted too."""
    cands = [c for c in start_candidates(fit.model, loop.scales) if c.meta["key"] == key]
    started = _fitted(loop, cands, fit, search)
    return min([fit, *started.values()], key=lambda f: f.sse)


def _candidates(model, scales, names) -> list:
    """``effect_candidates`` of each name that can be a candidate of ``model`` (one that cannot is left out)."""
    out = []
    for name in names:
        try:
            out += effect_candidates(model, scales, [name])
        except (KeyError, ValueError):
            continue
    return out


def record_floor(case: Case, record: str, search: int = SEARCH, discovered=None) -> dict:
    """SSEs on held-out ``record`` of ``case`` fitted to it: ``{"n", "nominal", "effects": {name: sse},
    "expected": sse, "expected_structure": [names], "discovered": sse or None}`` (module docstring); an effect
    that cannot be fitted is left out. ``search``: points of each candidate's global search (the loop's is 24);
    ``discovered``: the model the loop ended with on the case's own split, refitted to the record from its values
    (every coordinate, LM, step doubling: ``discover.fitting.polish``)."""
    loop = _loop(case, record)
    base = loop.fit
    refitted = None  # also where it cannot be simulated on the record (a trend leaving its domain)
    if discovered is not None:
        o = loop.options
        try:
            sse = polish(copy.deepcopy(discovered), loop.train, loop.sim, o.lm_steps, o.box_factor).sse
            refitted = sse if math.isfinite(sse) else None
        except (ValueError, RuntimeError):
            pass
    wanted = sorted(set().union(*case.expected)) if case.expected else []
    offered = [n for n in sorted(EFFECTS) if EFFECTS[n].discovery_candidate]
    cands = _candidates(base.model, loop.scales, sorted(set(offered) | set(wanted)))
    prebuild(cands, base.model)
    fits = _fitted(loop, cands, base, search)
    keys = {c.name: c.meta["key"] for c in cands}
    best = None
    for order in itertools.permutations(case.expected):  # both orders of a pair: the first fit shapes the second
        structure, current = [], base
        for i, fam in enumerate(order):
            if i == 0:
                members = {n: (fits[n], keys[n]) for n in fam if n in fits}
            else:
                more = _candidates(current.model, loop.scales, sorted(fam))
                found = _fitted(loop, more, current, search)
                members = {c.name: (found[c.name], c.meta["key"]) for c in more if c.name in found}
            started = {n: _with_start(loop, f, key, search) for n, (f, key) in members.items()}
            if not started:
                break
            name = min(started, key=lambda n: started[n].sse)
            structure.append(name)
            current = started[name]
        if best is None or current.sse < best[1].sse:
            best = (structure, current)
    structure, current = best if best is not None else ([], base)
    return {"n": loop.n_train, "nominal": base.sse, "effects": {n: f.sse for n, f in fits.items()},
            "expected": current.sse, "expected_structure": structure, "discovered": refitted}


def case_floor(case: Case, options: dict | None = None) -> dict:
    """The floor of ``case``: each structure's RMSE over its held-out records, fitted to them, over the noise sd
    (``nominal``, ``expected`` with its ``expected_structure``, ``best_effect`` and its ``best_effect_name``, and
    ``effects`` per name), the held-out records, and the wall time; a case that fails gives a row with ``error``.
    ``options``: ``search`` (``record_floor``); ``loop``: True to run the loop on the case first, as the bed does
    (the library defaults), score it (``loop``: ``run.score``'s row) and refit its final model to each held-out
    record (``discovered``)."""
    options = dict(options or {})
    if set(options) - {"search", "loop"}:
        raise ValueError(f"case_floor takes the options 'search' and 'loop' only (given {sorted(options)})")
    torch.set_default_dtype(torch.float64)
    start = time.perf_counter()
    scored = model = None
    if options.pop("loop", False):
        scored = run_case(case, keep_model=True)  # the bed's row, and the loop's final model
        model = scored.pop("model", None)
    try:
        test = case.records().split(**case.split).test
        if not test:
            raise ValueError("the case holds no record out")
        per = [record_floor(case, r.name, discovered=model, **options) for r in test]
    except Exception as exc:  # a failure is a row of the table, not a reason to lose the other cases
        return {"name": case.name, "category": case.category, "expected_families": [sorted(f) for f in case.expected],
                "error": f"{type(exc).__name__}: {exc}", "loop": scored, "brief": "ERROR",
                "wall_s": time.perf_counter() - start}
    n = sum(p["n"] for p in per)

    def ratio(sses) -> float:
        return math.sqrt(sum(sses) / n) / case.noise

    common = set.intersection(*(set(p["effects"]) for p in per)) if per else set()
    effects = {name: ratio(p["effects"][name] for p in per) for name in sorted(common)}
    best = min(effects, key=effects.get) if effects else None
    structures = {tuple(p["expected_structure"]) for p in per}
    row = {"name": case.name, "category": case.category, "noise": case.noise,
           "expected_families": [sorted(f) for f in case.expected], "records": [r.name for r in test], "samples": n,
           "nominal": ratio(p["nominal"] for p in per),
           "expected": ratio(p["expected"] for p in per),
           "expected_structure": [list(s) for s in sorted(structures)],
           "best_effect": effects.get(best) if best else None, "best_effect_name": best,
           "effects": effects, "loop": scored,
           "discovered": (ratio(p["discovered"] for p in per)
                          if model is not None and all(p["discovered"] is not None for p in per) else None),
           "wall_s": time.perf_counter() - start}
    row["brief"] = (f"nominal {row['nominal']:.2f}, expected {row['expected']:.2f} x noise, best effect "
                    f"{best} {row['best_effect'] or math.nan:.2f}")
    return row
