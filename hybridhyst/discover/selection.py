"""Selection that can also remove and swap: after each accepted step, every effect of the model is refitted
without it and in place of it each simpler set of effects it contains as a special case
(``Effect.special_cases``: Stribeck with vs → ∞ is Coulomb, LuGre with Fs = Fc and no damping is Dahl,
Bouc–Wen with n = 1, γ = 0 is Dahl, ...). A greedy loop takes the most flexible element that explains the
residual at one step; once the rest of the model is in place, the simpler element often does as well. Once
the loop has stopped, each added effect is also tried swapped for the finalists it beat on validation when it
was added although the information criterion preferred them (a hardening Bouc–Wen chosen over a cubic spring
while a Dahl element, later replaced, was still there)."""

from __future__ import annotations

import math
from collections.abc import Callable

from ..physics.parameters import Constant
from .candidates import Candidate, effect_candidates, start_candidates
from .fitting import Fit, at, fit_candidate, polish, side_by_side
from .result import Change
from .rule import Acceptance, Judged

__all__ = ["REPLACEMENTS", "combined", "refit_alternatives", "simplify", "ways_to_simplify"]


def combined(candidates: list[Candidate]) -> Candidate:
    """One candidate that adds several effects at once: their builders in turn, their new coordinates and
    bounds together, the i-th start of each together (the shorter lists repeat their last start)."""
    def build(m):
        for c in candidates:
            m = c.build(m)
        return m

    n = max(len(c.starts) for c in candidates)
    starts = [{k: v for c in candidates for k, v in c.starts[min(i, len(c.starts) - 1)].items()} for i in range(n)]
    return Candidate(name="+".join(c.name for c in candidates), kind="effect", build_fn=build,
                     free=[f for c in candidates for f in c.free],
                     bounds={k: v for c in candidates for k, v in c.bounds.items()}, starts=starts,
                     describe="; ".join(c.describe for c in candidates),
                     meta={"effects": [c.name for c in candidates]})


REPLACEMENTS = ("special_case", "rival_swap", "revisit")  # why an effect was replaced: its special case, a runner-up,
# or a special case of it with one more effect (``Loop.revisit``)


def ways_to_simplify(fit: Fit, key: str, scales, rivals: dict[str, list[str]] | None = None, only_rivals=False):
    """``(effects put in its place, model without it, candidate adding them or None, how)`` for each way to
    simplify effect ``key``: removal (``how`` None), then each of its special cases (``"special_case"``), less the
    effects the model already has (those stay and absorb it; a case they cover entirely is the removal), then each
    of its ``rivals`` (``"rival_swap"``: by effect name, the library effects validation compared it with when the
    loop added it; not a special case of it) not in the model; ``only_rivals``: the rivals' swaps alone."""
    effect = fit.model.effects[key]
    reduced = fit.model.with_effects({k: e for k, e in fit.model.effects.items() if k != key})
    special = [tuple(case) for case in type(effect).special_cases]
    if not only_rivals:
        yield (), reduced, None, None
    present = {e.name for e in reduced.effects.values()}
    swaps = [(r,) for r in (rivals or {}).get(effect.name, ()) if r != effect.name and (r,) not in special]
    cases = [(c, "rival_swap") for c in swaps] if only_rivals else \
        [(c, "special_case") for c in special] + [(c, "rival_swap") for c in swaps]
    for case, how in cases:
        new = [n for n in case if n not in present]
        if new:
            yield case, reduced, _with_starts(effect_candidates(reduced, scales, new), reduced, scales, effect), how


def _with_starts(cands: list[Candidate], reduced, scales, replaced) -> Candidate:
    """The effects of ``cands`` added together; where the effect they replace (``replaced``) had a fitted start
    state, with the start states of those that can have one, free too: the records start where they did (a
    clearance whose gap has closed is Dahl, but only with Dahl's own start state can it replace a clearance that
    started away from its centre). Each new start state is tried at the replaced one's fitted value where their
    units match (else 0) with every start of the effects, then at ``start_candidates``' values; a start state the
    user held (``fixed``) is not a fitted one."""
    # a start that follows a condition (a drift's travel carried between records) is no one fitted state
    fitted = {spec.unit: float(replaced.params[name].value.detach()) for name, spec in replaced.start.items()
              if name in replaced.params and isinstance(replaced.params[name], Constant)}
    if not fitted:
        return combined(cands)
    model = reduced
    for c in cands:
        model = c.build(model)
    keys = {c.meta["key"] for c in cands}
    n = max(len(c.starts) for c in cands)
    for s in [c for c in start_candidates(model, scales) if c.meta["key"] in keys]:
        effect = model.effects[s.meta["key"]]
        seeded = {f"{s.meta['key']}.{name}": fitted.get(spec.unit, 0.0) for name, spec in effect.start.items()}
        seeded = {k: min(max(v, s.bounds[k][0]), s.bounds[k][1]) for k, v in seeded.items()}
        # combined() pairs the i-th starts (a shorter list repeats its last): the seeded state with each of the
        # effects' n starts, then the grid with their last
        s.starts = [seeded] * n + [g for g in s.starts if g != seeded]
        cands = cands + [s]
    return combined(cands)


def refit_alternatives(refit: Callable, alternatives: list, workers: int, bar: Callable | None = None) -> list:
    """``[refit(alt) for alt in alternatives]`` for ``simplify``'s ``(key, by, reduced, candidate, how)``, side by
    side as if one after another: a removal's refit polishes its reduced model, and the effect's swaps, which share
    that model, start from the polished one. So the removals first, then the swaps from what they gave (a swap whose
    removal failed, or was not tried, from the reduced model as it is)."""
    first = [i for i, alt in enumerate(alternatives) if alt[3] is None]
    out = dict(zip(first, side_by_side(refit, [alternatives[i] for i in first], workers, bar)))
    polished = {id(alternatives[i][2]): f.model for i, f in out.items() if f is not None}
    rest = [i for i in range(len(alternatives)) if i not in out]
    swaps = [(key, by, polished.get(id(reduced), reduced), cand, how)
             for key, by, reduced, cand, how in (alternatives[i] for i in rest)]
    out.update(zip(rest, side_by_side(refit, swaps, workers, bar)))
    return [out[i] for i in range(len(alternatives))]


def simplify(fit: Fit, now: Judged, train, sim, scales, rule: Acceptance, score, opts: dict, progress=None,
             rivals=None, settled=False) -> tuple[Fit, Judged, list[Change]]:
    """Remove or swap effects while the rule prefers the simpler model (``Acceptance.simpler``: a lower
    information criterion, the out-of-sample error ``score(model, sim)`` raised by less than half the margin or
    within the noise; the rule as it stood for the model ``simplify`` started from):
    each round takes the qualifying alternative with the lowest criterion, until none qualifies. ``now``: how
    the rule sees ``fit``; ``opts``: ``lm_steps``, ``box_factor``, ``workers``. ``rivals`` (``{effect name:
    [library effect names]}``) adds swaps for another effect of the library (the loop passes each added effect's
    close calls once it has stopped: a choice made on the model of that step may no longer hold on the final
    one). ``settled``: ``fit`` has already been through this without rivals (none of those alternatives
    qualified), so the first round tries the rivals' swaps alone. Returns (fit, how the rule sees it, one
    ``Change`` per change: ``kind`` "removed" or "replaced", ``by`` the effects put in its place, ``replacement``
    why: "special_case" (a simpler set it contains as a special case) or "rival_swap" (a runner-up it beat when
    it was added: a swap, not a special case); None for a removal)."""
    changes: list[Change] = []
    while len(fit.model.effects) > 1:
        best = None
        only_rivals = settled and not changes
        alternatives = [(key, *alt) for key in fit.model.effects
                        for alt in ways_to_simplify(fit, key, scales, rivals, only_rivals)]

        def refit(alt, fit=fit):
            _, _, reduced, cand, _ = alt
            try:
                return (polish(reduced, train, at(sim, fit), opts["lm_steps"], opts["box_factor"]) if cand is None
                        else fit_candidate(cand, reduced, train, at(sim, fit), opts["lm_steps"], opts["box_factor"]))
            except (ValueError, RuntimeError):
                return None

        # every alternative refitted (side by side), then judged in order: the same choice for any number of workers
        refits = refit_alternatives(refit, alternatives, int(opts.get("workers", 1)),
                                    (lambda items, n: progress(items, "simplify")) if progress else None)
        for (key, by, _, _, how), f in zip(alternatives, refits):
            if f is None:
                continue
            f_ic = rule.ic(f)
            if not f_ic < now.ic or (best is not None and f_ic >= best[2].ic):
                continue  # scored only when it could be chosen (a score may cost a refit per operating point)
            judged = Judged(score(f.model, at(sim, f)), f_ic)
            if rule.simpler(judged, now):
                best = (key, by, judged, f, how)
        if best is None:
            break
        key, by, judged, f, how = best
        changes.append(Change(effect=fit.model.effects[key].name, key=key, kind="replaced" if by else "removed",
                              by=list(by), replacement=how, val_before=now.val, val_after=judged.val,
                              train_rmse=math.sqrt(f.sse / rule.n)))
        fit, now = f, judged
    return fit, now, changes
