"""The closed loop: fit the nominal, diagnose the residual, rank candidate effects, add the best, refit,
accept by one rule, repeat; then say what is left.

The loop is a ``Loop`` that holds its state (the current fit and how the rule sees it, the steps taken,
rejected and undone) and runs one method per phase, in this order (``discover``):

1. ``nominal``: identify the nominal on the training records and converge its fit (the "before");
2. ``trends``: every constant parameter as a function of each condition with enough levels;
3. ``effects``: the greedy steps. Each candidate (a library effect, a one-parameter trend for a condition
   with few levels, a start state) is refitted with every coordinate free (its starting values as restarts of
   one batched Levenberg–Marquardt, the other coordinates from their fitted values, first re-balanced against
   each start; LM continued until converged), ranked by the share of the training residual it removes; of the
   best ``top`` the rule picks one on validation error and information criterion, and accepts it or stops;
4. ``removals`` after every accepted change: each effect removed, or replaced by a special case (``selection``);
5. ``swaps``: each added effect against the rivals it beat when it was added, on the final model;
   ``revisit`` (an option): where the model stopped short of the noise, each added effect replaced by a special
   case of it together with one more effect;
6. ``trends_of_added``: the parameters of effects a swap put in, as functions of the conditions (an effect a
   step accepts has them offered at once, by the same method);
7. ``refit``: the chosen structure (and the nominal) refitted on training and validation records;
8. ``leftover``: how much structure the residual still holds.

Every change is judged by ``rule.Acceptance``; the result is typed (``Step``, ``Change``) and turned into the
``discovery.json`` content only in ``DiscoveryResult.report``.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace

from ..analysis.noise import noise_sd
from ..data.records import TRAVEL_BEFORE, RecordSet, with_travel_before
from ..data.splits import Split, check_conditions
from ..identify import identify
from ..identify.space import outside_domain
from ..physics.models import DrivenOscillator, conditions_used
from ..progress import progress as progress_bar
from ..settings import intra_op_threads
from ..simulate import SimulationSettings
from .candidates import Scales, library_candidates, start_candidates
from .conditions import as_records, control_ranges, trend_conditions
from .diagnose import diagnose
from .finish import finish
from .fitting import Fit, fit_candidate, fit_candidates, polish, prebuild, sse_at
from .fitting import at as _at
from .result import AFTER_ADDED, Change, DiscoveryResult, Step, parameter_values
from .rule import Acceptance, Judged, information_criterion
from .selection import simplify, ways_to_simplify
from .settings import DiscoverSettings
from .trends import MIN_LEVELS, fit_trends
from .validation import Validation, condition_groups, errors, improves, parts, record_metrics, rmse_on, simulated

__all__ = ["Change", "DiscoverSettings", "DiscoveryResult", "Step", "discover", "information_criterion"]


def discover(records, nominal, candidates: Sequence[str] | None = None, split: Mapping | None = None, *,
             settings: DiscoverSettings | None = None, **options) -> DiscoveryResult:
    """Find, name and add the effects a nominal model lacks; report the error before and after.

    Parameters
    ----------
    records : a ``RecordSet`` (or list of records) with operating conditions.
    nominal : the starting ``NominalModel`` (fitted in place and then augmented copies of it).
    candidates, split : as ``DiscoverSettings`` (given here too for the common call).
    settings : ``DiscoverSettings`` (default its defaults); ``options``: any of its fields laid over it.

    Raises
    ------
    ValueError
        Unknown candidate names, a split leaving no training records, records too short to identify.
    """
    given = {k: v for k, v in (("candidates", candidates), ("split", split)) if v is not None}
    settings = (settings or DiscoverSettings()).replace(**given, **options)
    with intra_op_threads(settings.torch_threads):
        loop = Loop(records, nominal, settings)
        loop.nominal()
        loop.trends()
        loop.effects()
        loop.swaps()
        loop.revisit()
        loop.trends_of_added()
        return loop.result()


class Loop:
    """The loop's data, settings and state; one method per phase (module docstring)."""

    def __init__(self, records, nominal, options: DiscoverSettings):
        self.start_time = time.perf_counter()
        self.options = o = options
        records = records if isinstance(records, RecordSet) else RecordSet(as_records(records))
        if o.carried_travel and len(records) > 1 and not isinstance(nominal, DrivenOscillator):
            records = RecordSet(with_travel_before(records), records.name)  # before the split: every record's
        split = dict(o.split or {})
        parts_ = records.split(held_out=split.get("held_out"), val=split.get("val"))
        self.train, self.val, self.test = (as_records(p) for p in parts_)
        if not self.train:
            raise ValueError(f"the split {split} leaves no training record; hold out fewer conditions")
        self.splits = {"train": self.train, "val": self.val, "test": self.test}
        cond_values = trend_conditions(o.conditions, Split(self.train, self.val, self.test))
        if isinstance(o.conditions, bool):  # the travel before a record is for the drifts with travel alone
            cond_values.pop(TRAVEL_BEFORE, None)
        self.trend_values = dict(cond_values)  # the conditions a parameter may depend on (a leftover network's too)
        check_conditions(Split(self.train, self.val, self.test), conditions_used(nominal),
                         "the nominal model (a parameter as a function of a condition)")
        self.n_train = sum(len(r) - r.warmup for r in self.train)  # the scored samples the fits' SSE covers
        for r in self.train:
            r.require_samples(16, "discovery (identifying a candidate effect)")
        self.score = Validation(o.validation, self.train, self.val, lm_steps=o.lm_steps,
                                box_factor=o.box_factor, workers=int(o.workers))  # refuses a bad kind
        # the noise level the rule judges "within the noise" by: the user's, else estimated from the data
        self.noise = {"sd": o.noise_sd, "source": "given"} if o.noise_sd else {
            "sd": noise_sd([r.y for r in self.train]),
            "source": "estimated from the training responses' differences (analysis.noise), capped by the current "
                      "model's training RMSE"}
        self.base_rule = Acceptance(o.margin, o.criterion, self.n_train, noise=self.noise["sd"])
        self.sim = o.simulation
        self.model = nominal
        self.first_fit = None  # the nominal's identification (``nominal``): its box re-centred, edges left
        self.scales = Scales.of(self.train, oscillator=isinstance(nominal, DrivenOscillator))
        if not o.carried_travel:  # records that carry travel_before of their own do not carry it over either
            self.scales = replace(self.scales, travel=None)
        # conditions with enough levels get their trends in one step (every constant parameter at once), before
        # the effects and again after them for the parameters the effects brought; the others keep the
        # one-parameter-at-a-time candidates
        self.trend_conditions = [c for c in cond_values if len(set(cond_values[c])) >= MIN_LEVELS]
        self.single_conditions = {c: v for c, v in cond_values.items() if c not in self.trend_conditions}
        # control channels (data.controls): a parameter may follow one (judged on every sample, like an effect),
        # and the control may lag (``control_lag``, offered once a parameter follows it)
        self.controls = control_ranges(o.conditions, self.train)
        self.single_conditions.update(self.controls)
        self.steps: list[Step] = []
        self.rejected: list[Step] = []
        self.removed: list[Change] = []
        self.tried: set[str] = set()  # effects not offered again (added, removed or replaced)
        self.rivals: dict[str, list[str]] = {}  # effect added -> the close calls of its step (tried at the end)
        self.stopped = "rule"  # the best candidate was not accepted, or none was left
        self.fit: Fit | None = None
        self.now: Judged | None = None
        self.trended: set[str] = set()  # keys of added effects whose parameters were offered trends
        self.cross = self._cross_score()
        self._cross_cache: tuple[Fit, float] | None = None

    # -- helpers ---------------------------------------------------------------------------------------------

    @property
    def rule(self) -> Acceptance:
        """The acceptance rule for the current model. An estimated noise level is capped by the current model's
        training RMSE: a model that already leaves less than the estimate shows it too high (a response whose
        own shape shows in its differences); a noise level the user gave is kept."""
        rule = self.base_rule
        if self.noise["source"] != "given" and self.fit is not None and rule.noise is not None:
            rmse = math.sqrt(self.fit.sse / self.n_train)
            if rmse < rule.noise:
                return replace(rule, noise=rmse)
        return rule

    def _bar(self, items, what: str, total: int | None = None):
        return progress_bar(items, what, total=total, enabled=self.options.progress)

    def judge(self, fit: Fit) -> Judged:
        """How the rule sees a fitted model."""
        return Judged(self.score(fit.model, _at(self.sim, fit)), self.rule.ic(fit))

    def _test_rmse(self, fit: Fit) -> float | None:
        return rmse_on(fit.model, self.test, _at(self.sim, fit)) if self.test else None

    def _step(self, name: str, kind: str, description: str, fit: Fit, judged: Judged, before: Judged,
              accepted: bool, **details) -> Step:
        evidence = details.pop("evidence", {})
        return Step(effect=name, kind=kind, description=description, accepted=accepted, val_before=before.val,
                    val_after=judged.val, ic_before=before.ic, ic_after=judged.ic, criterion=self.rule.criterion,
                    parameters=parameter_values(fit.model), train_rmse=math.sqrt(fit.sse / self.n_train),
                    val_rmse=judged.val if self.score.out_of_sample else None, test_rmse=self._test_rmse(fit),
                    details=details, evidence_details=evidence)

    def evaluate(self, model, sim: SimulationSettings) -> tuple[dict, dict]:
        """Predictions of every split (simulated once), their metrics and sub-steps: the training records at the
        fit's own sub-steps, the others at those they need."""
        runs = {s: simulated(model, rs, sim, resolve=s != "train") for s, rs in self.splits.items()}
        preds = {s: run[0] for s, run in runs.items()}
        return preds, {s: {**record_metrics(self.splits[s], preds[s], self.options.label_conditions),
                           "substeps": runs[s][1]} for s in self.splits}

    def _cross_score(self):
        """``(kind, score)``: the out-of-sample error the rule does not judge (``cross_check``), or None."""
        o = self.options
        if o.cross_check == "off" or o.validation == "both":
            return None
        if o.validation == "records" and len(self.score.groups or condition_groups(self.train)) >= 2:
            return "loco", Validation("loco", self.train, [], lm_steps=o.lm_steps, box_factor=o.box_factor,
                                      workers=int(o.workers))
        if o.validation == "loco" and self.val:
            return "records", Validation("records", self.train, self.val, lm_steps=o.lm_steps,
                                         box_factor=o.box_factor)
        return None

    def _cross(self, fit: Fit) -> float:
        if self._cross_cache is not None and self._cross_cache[0] is fit:
            return self._cross_cache[1]
        value = float(self.cross[1](fit.model, _at(self.sim, fit)))
        self._cross_cache = (fit, value)
        return value

    def _confirmed(self, step: Step, new: Fit) -> bool:
        """Cross-check a step the rule accepted: the other error before and after it (``step.details
        ["cross_check"]``), and whether it disagrees (it did not fall by the margin, while the judged one did).
        False when it disagrees and ``cross_check`` is "confirm": the step is then refused. A cross-check that
        cannot be evaluated (a refit without one operating point that does not simulate) decides nothing."""
        if self.cross is None:
            return True
        before, after = self._cross(self.fit), self._cross(new)
        determined = math.isfinite(before) and math.isfinite(after)
        disagrees = determined and not improves(after, before, self.options.margin)
        step.details["cross_check"] = {"kind": self.cross[0], "before": before if math.isfinite(before) else None,
                                       "after": after if math.isfinite(after) else None, "disagrees": disagrees,
                                       "determined": determined, "refused": disagrees and self.refuses}
        return not (disagrees and self.refuses)

    @property
    def refuses(self) -> bool:
        return self.options.cross_check == "confirm"

    # -- phases ----------------------------------------------------------------------------------------------

    def nominal(self) -> None:
        """Identify the nominal on the training records (unless told not to) and converge its fit: "before"."""
        o = self.options
        if o.fit_nominal:
            settings = o.first_fit()
            first = identify(self.model, self.train, settings)
            self.first_fit = {"rmse": first.rmse, "recentred": first.recentred, "recentre": settings.recentre,
                              "at_bounds": dict(first.at_bounds)}
        outside = outside_domain(self.model, self.train)
        if outside:
            raise ValueError(f"the nominal model's parameter {outside[0]}: outside its domain on a training record "
                             "(a trend that crosses zero between the data's levels); give values or a trend that "
                             "stay inside it" + ("" if o.fit_nominal else ", or let the loop identify the nominal "
                                                 "first (fit_nominal)"))
        self.fit = polish(self.model, self.train, self.sim, o.lm_steps, o.box_factor)
        self.initial, self.initial_sim = copy.deepcopy(self.fit.model), _at(self.sim, self.fit)
        self.preds_before, self.before = self.evaluate(self.initial, self.initial_sim)
        self.now = self.judge(self.fit)
        self.val0 = self.now.val
        self.diag_before = diagnose(self.train, self.preds_before["train"], o.noise_sd)

    def removals(self, rivals: dict | None = None, settled: bool = False) -> None:
        """Remove or simplify effects while the rule prefers the simpler model (``selection.simplify``)."""
        o = self.options
        self.fit, self.now, gone = simplify(
            self.fit, self.now, self.train, self.sim, self.scales, self.rule, self.score,
            {"lm_steps": o.lm_steps, "box_factor": o.box_factor, "workers": int(o.workers)},
            (lambda items, what: self._bar(items, what)), rivals, settled=settled)
        for g in gone:
            g.after_step = len(self.steps)
            if not settled:
                self.tried.add(g.effect)  # a removed or replaced effect is not offered again
        self.removed += gone

    def trends(self) -> None:
        """Offer every constant parameter as a function of each condition with enough levels, one condition at a
        time."""
        for cond in self.trend_conditions:
            self._trend(cond, "before effects", None)

    def trends_of_added(self, before: set[str] = frozenset()) -> None:
        """The trends of the parameters of effects added since the model had effects ``before`` (and not offered
        them yet): right after an effect is accepted (with any the removals that followed put in), a level that
        rises with the condition is given its trend before the next step, or the next step would add an element
        to stand in for it; once more after the swaps, for the effects they put in."""
        added = set(self.fit.model.effects) - before - set(self.initial.effects) - self.trended
        if not added:
            return
        self.trended |= added
        for cond in self.trend_conditions:
            self._trend(cond, "after effects", added & set(self.fit.model.effects))

    def _trend(self, cond: str, when: str, effects: set[str] | None) -> None:
        o = self.options
        res = fit_trends(self.fit, self.train, self.sim, cond, o.lm_steps, o.box_factor, effects)
        if res is None:
            return
        t_fit, chosen = res
        description = f"parameters as functions of {cond}" + (" (those of the effects added)"
                                                              if when == "after effects" else "")
        if t_fit is None:  # every parameter's levels are best described by a constant: said, not hidden
            self.rejected.append(self._step(f"trends~{cond}", "trend", description + ": every parameter kept "
                                            "constant (a constant described each one's per-level values best)",
                                            self.fit, self.now, self.now, False, when=when, trends=chosen,
                                            outcome="constant"))
            return
        judged = self.judge(t_fit)
        accepted = self.rule.adds(judged, self.now)
        step = self._step(f"trends~{cond}", "trend", description, t_fit, judged, self.now, accepted, when=when,
                          trends=chosen, **({} if accepted else {"refused_by": self.rule.refusal(judged, self.now)}))
        if accepted:
            step.accepted = accepted = self._confirmed(step, t_fit)
        (self.steps if accepted else self.rejected).append(step)
        if accepted:  # an element that stood in for the trends may have nothing left to do (as after any change)
            self.fit, self.now = t_fit, judged
            self.removals()

    def effects(self) -> None:
        """The greedy steps: rank the candidates, let the rule pick one and accept it, or stop."""
        o = self.options
        for _ in range(int(o.max_steps)):
            cands = [c for c in library_candidates(self.fit.model, self.scales, self.single_conditions, o.candidates,
                                                   o.start_states, self.controls) if c.name not in self.tried]
            if not cands or not self._effect_step(cands):
                return
        self.stopped = "max_steps"  # every step accepted an effect: the cap ended the loop, not the rule

    def _rank(self, cands, fit: Fit) -> list:
        """``[(candidate, Fit or None)]``: each of ``cands`` fitted on ``fit``'s model, lowest training error first."""
        o = self.options
        if self.sim.backend == "fast":  # every candidate's compiled loops built side by side, before they are fitted
            prebuild(cands, fit.model, tuple(sorted(self.controls)))
        ranking = fit_candidates(cands, fit.model, self.train, _at(self.sim, fit), o.lm_steps, o.box_factor,
                                 int(o.workers), self._bar)
        return sorted(ranking, key=lambda item: item[1].sse if item[1] is not None else math.inf)

    def _effect_step(self, cands, when: str | None = None) -> bool:
        """One step over ``cands``; whether a candidate was accepted. ``when``: said in the step's record (a step
        offered outside the greedy ranking: ``AFTER_ADDED``)."""
        o, fit = self.options, self.fit
        ranking = self._rank(cands, fit)
        # the current model at each candidate's sub-steps (one that needed finer steps is compared there), never
        # below its own (a candidate that gave a stiff element up may need fewer than the current model does)
        ref = {s: sse_at(fit, self.train, self.sim, max(s, fit.substeps))
               for s in {f.substeps for _, f in ranking if f is not None}}
        evidence = {c.name: (1 - f.sse / ref[f.substeps] if f is not None and ref[f.substeps] > 0 else None)
                    for c, f in ranking}
        fitted = [(cand, f) for cand, f in ranking if f is not None]
        finals = [(cand, f, self.judge(f)) for cand, f in fitted[: int(o.top)]]
        if not finals:
            return False
        def ic_ref(f: Fit) -> float:
            # the current model at the candidate's resolution, too: one that needed finer steps must beat it there
            return min(self.now.ic, information_criterion(ref[f.substeps], self.n_train, fit.k, self.rule.criterion))

        def adds(i: int) -> bool:
            _, f, j = finals[i]
            return self.rule.adds(j, Judged(self.now.val, ic_ref(f)))

        def more() -> list[Judged]:  # the candidates ranked below the top, judged only when none of it passes
            first = len(finals)
            finals.extend((cand, f, self.judge(f)) for cand, f in fitted[first: first + int(o.further)])
            return [j for _, _, j in finals[first:]]

        index, accepted = self.rule.choose([j for _, _, j in finals], adds, more if o.further > 0 else None)
        cand, c_fit, judged = finals[index]
        reference = Judged(self.now.val, ic_ref(c_fit))  # what the candidate was judged against
        step = self._step(cand.name, cand.kind, cand.describe, c_fit, judged, reference, accepted, evidence={
            "explained_share": evidence[cand.name], "ranking": evidence, "refitted": [f[0].name for f in finals],
            "compared": _compared(finals)},
            new_coordinates={n: c_fit.coords.get(n) for n in cand.free}, substeps=c_fit.substeps,
            **({"when": when} if when else {}),
            **({} if accepted else {"refused_by": self.rule.refusal(judged, reference)}))
        if accepted:
            polished = polish(c_fit.model, self.train, _at(self.sim, c_fit), o.lm_steps, o.box_factor)
            step.accepted = accepted = self._confirmed(step, polished)
        if not accepted:
            self.rejected.append(step)
            return False
        self.steps.append(step)
        self.tried.add(cand.name)
        # the close calls: finalists validation turned down where the information criterion preferred them
        self.rivals[cand.name] = [f[0].name for f in finals
                                  if f[0] is not cand and f[0].kind == "effect" and f[2].ic < judged.ic]
        keys = set(fit.model.effects)
        self.fit = polished
        self.now = self.judge(self.fit)
        self.removals()
        self.trends_of_added(keys)
        self.starts_of_added(keys)
        return True

    def starts_of_added(self, before: set[str]) -> None:
        """The start state of each effect added since the model had effects ``before`` (``candidates.
        start_candidates``: its state at a fitted value when every record starts), offered at once as a step of its
        own, as its trends are: a record that starts away from the element's rest leaves a transient, and until the
        start state is fitted an element stands in for it (kept, or added by the next step), fitted with the whole
        ranking of the next step. Refused here, it stays a candidate of the later steps."""
        if not self.options.start_states:
            return
        for key in [k for k in self.fit.model.effects if k not in before]:
            # against the model as it is now: an accepted offer's removals may have taken another added effect out
            for cand in start_candidates(self.fit.model, self.scales):
                if cand.meta["key"] == key and cand.name not in self.tried:
                    self._effect_step([cand], when=AFTER_ADDED)

    def swaps(self) -> None:
        """Each added effect against the close calls of its step, on the final model (once; the model has been
        through the removals and special cases after its last step: those are not tried again until a swap)."""
        rivals = {name: [r for r in names if r not in self.tried] for name, names in self.rivals.items()}
        if any(rivals.values()):
            self.removals(rivals, settled=True)

    def _room(self) -> bool:
        """Whether a model at the noise level would pass the rule as a step over the current one (the loop
        stopped short of the noise)."""
        rule = self.rule
        return bool(rule.noise) and all(e > rule.noise * (1 + self.options.margin)
                                        and e * e - rule.noise**2 > rule.floor for e in errors(self.now.val))

    def revisit(self) -> None:
        """A first step can take a flexible element that stands in for two effects (Dahl's presliding lag for
        Coulomb friction and a delay); once it is in, neither simpler effect alone passes. Where the loop stopped
        short of the noise (``options.revisit``), each effect it added is refitted replaced by each of its special
        cases, one greedy step is taken from there (the ``top`` best-ranked library effects, judged), and the
        best of them the rule would accept as a step over the final model, which the cross-check confirms,
        replaces it; every one tried is a step of the record, accepted or refused. Once one is accepted, its
        removals, trends and start states follow as after any step, and the revisits end."""
        o = self.options
        if not o.revisit or not self._room():
            return
        final, final_judged = self.fit, self.now
        for key in [k for k in final.model.effects if k not in self.initial.effects]:
            effect = final.model.effects[key]
            for case, reduced, cand, how in ways_to_simplify(final, key, self.scales):
                if how != "special_case" or cand is None:
                    continue
                try:
                    base = fit_candidate(cand, reduced, self.train, _at(self.sim, final), o.lm_steps, o.box_factor)
                except (ValueError, RuntimeError):
                    base = None
                if base is None:
                    continue
                present = {e.name for e in base.model.effects.values()} | {effect.name}
                cands = [c for c in library_candidates(base.model, self.scales, self.single_conditions, o.candidates,
                                                       o.start_states, self.controls)
                         if c.kind == "effect" and c.meta.get("effect") not in present]
                fitted = [(c, f) for c, f in self._rank(cands, base) if f is not None]
                finals = [(c, f, self.judge(f)) for c, f in fitted[: int(o.top)]]
                if not finals:
                    continue
                index, accepted = self.rule.choose([j for _, _, j in finals],
                                                   lambda i, finals=finals: self.rule.adds(finals[i][2], final_judged))
                c, c_fit, judged = finals[index]
                by = [*case, c.meta.get("effect", c.name)]
                step = self._step(
                    "+".join(by), "effect", f"{effect.name} replaced by {' + '.join(case)} (a special case of it) "
                    f"with {c.name} ({c.describe.rstrip('.')}).", c_fit, judged, final_judged, accepted,
                    when="revisit", replaces=effect.name, substeps=c_fit.substeps,
                    new_coordinates={n: c_fit.coords.get(n) for n in [*cand.free, *c.free]},
                    evidence={"explained_share": 1 - c_fit.sse / final.sse if final.sse > 0 else None,
                              "compared": _compared(finals)},
                    **({} if accepted else {"refused_by": self.rule.refusal(judged, final_judged)}))
                if accepted:
                    polished = polish(c_fit.model, self.train, _at(self.sim, c_fit), o.lm_steps, o.box_factor)
                    step.accepted = self._confirmed(step, polished)
                if not step.accepted:
                    self.rejected.append(step)
                    continue
                self.steps.append(step)
                self.tried |= {effect.name, c.name}
                self.removed.append(Change(effect=effect.name, key=key, kind="replaced", by=by, replacement="revisit",
                                           val_before=final_judged.val, val_after=judged.val,
                                           train_rmse=math.sqrt(polished.sse / self.n_train),
                                           after_step=len(self.steps)))
                self.fit, self.now = polished, self.judge(polished)
                self.removals()
                self.trends_of_added(set(final.model.effects))  # the special case's and the new effect's
                self.starts_of_added(set(final.model.effects))
                return

    def result(self) -> DiscoveryResult:
        """Refit the chosen structure, measure what is left and assemble the result (``finish.finish``)."""
        return finish(self)


def _compared(finals: list) -> dict:
    """The evidence of a step's finalists ``[(candidate, Fit, Judged)]``: each one's judged error and criterion."""
    return {c.name: {"val_rmse": j.val, "criterion": j.ic, **parts(val=j.val)} for c, _, j in finals}
