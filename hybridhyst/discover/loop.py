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
from dataclasses import dataclass, replace

from ..analysis.noise import noise_sd
from ..data.records import Record, RecordSet
from ..data.splits import Split, check_conditions
from ..identify import identify
from ..identify.space import condition_ranges, outside_domain
from ..physics.models import DrivenOscillator, conditions_used
from ..progress import progress as progress_bar
from ..settings import intra_op_threads
from ..simulate.fast import prebuild_models
from .candidates import Scales, library_candidates
from .diagnose import diagnose
from .fitting import Fit, fit_candidate, polish, side_by_side, sse_at
from .fitting import at as _at
from .leftover import LEFTOVER, neural_leftover, residual_network, structure_flagged
from .result import Change, DiscoveryResult, Step
from .rule import Acceptance, Judged, check_criterion, information_criterion
from .selection import simplify
from .trends import MIN_LEVELS, fit_trends
from .validation import Validation, condition_groups, improves, parts, record_metrics, rmse_on, simulated

__all__ = ["Change", "DiscoveryResult", "Step", "discover", "information_criterion"]


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
    return {c: values[c] for c in conditions if c in values}  # (the others are control channels: _controls)


def _controls(conditions, train) -> dict[str, list[float]]:
    """``{control: [lowest, highest]}`` over the training records of the control channels a parameter may follow:
    every control the records carry (``conditions`` true) or those named; none with ``conditions`` false."""
    if not conditions:
        return {}
    names = {c for c in train[0].controls if all(c in r.controls for r in train)}
    if not isinstance(conditions, bool):
        names &= set(conditions)
    return {c: list(span) for c, span in condition_ranges(train).items() if c in names}


def _parameters(model) -> dict:
    return {f"{e}.{p}": {"value": info["value"], "unit": info["unit"]}
            for e, params in model.parameter_table().items() for p, info in params.items()}


CROSS_CHECK = ("confirm", "report", "off")


@dataclass(frozen=True)
class Options:
    """``discover``'s settings (its docstring says what each means)."""

    candidates: Sequence[str] | None = None
    split: Mapping | None = None
    conditions: bool | Sequence[str] = True
    label_conditions: Sequence[str] | None = None
    margin: float = 0.02
    criterion: str = "bic"
    max_steps: int = 4
    top: int = 3
    lm_steps: int = 25
    box_factor: float = 10.0
    noise_sd: float | None = None
    fit_nominal: bool = True
    identify_options: Mapping | None = None
    backend: str = "fast"
    method: str = "rk4"
    substeps: int = 1
    refit: bool = True
    leftover: str = "static"
    validation: str = "records"
    start_states: bool = True
    progress: bool = True
    workers: int = 1
    cross_check: str = "confirm"

    def check(self) -> None:
        from ..physics.effects import EFFECTS

        check_criterion(self.criterion)
        if self.cross_check not in CROSS_CHECK:
            raise ValueError(f"unknown cross_check {self.cross_check!r}; choose one of {list(CROSS_CHECK)}")
        if self.leftover not in LEFTOVER:
            raise ValueError(f"unknown leftover measure {self.leftover!r}; choose one of {list(LEFTOVER)}")
        unknown = [c for c in (self.candidates or []) if c not in EFFECTS]
        if unknown:
            raise ValueError(f"unknown candidate effect(s) {unknown}; the library has {sorted(EFFECTS)}")

    @property
    def sim(self) -> dict:
        return {"backend": self.backend, "method": self.method, "substeps": int(self.substeps)}


def discover(records, nominal, candidates: Sequence[str] | None = None, split: Mapping | None = None, *,
             conditions: bool | Sequence[str] = True, label_conditions: Sequence[str] | None = None,
             margin: float = 0.02, criterion: str = "bic", max_steps: int = 4,
             top: int = 3, lm_steps: int = 25, box_factor: float = 10.0, noise_sd: float | None = None,
             fit_nominal: bool = True, identify_options: Mapping | None = None, backend: str = "fast",
             method: str = "rk4", substeps: int = 1, refit: bool = True, leftover: str = "static",
             validation: str = "records", start_states: bool = True, progress: bool = True,
             workers: int = 1, cross_check: str = "confirm", torch_threads: int | None = 1) -> DiscoveryResult:
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
    noise_sd : known noise standard deviation of the response. The acceptance rule (``rule.Acceptance``) treats
        models whose mean squared errors differ by at most ``rule.NOISE_SHARE`` σ² as within the noise of each
        other; without it, σ is estimated from the training responses (``analysis.noise``) and capped by the
        current model's training RMSE (both reported).
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
    cross_check : "confirm" (default), "report" or "off". For every step the rule accepts, also measure the
        out-of-sample error it did not judge (with ``validation="records"``, leave-one-condition-out over the
        training operating points; with ``"loco"``, the validation records'). When that error did not fall by the
        margin too, the evidence disagrees: "confirm" refuses the step, "report" keeps it; either says so in one
        line (``result.disagreement_line``; report and terminal summary). Why "confirm" is the default:
        ``experiments/discovery_testbed``, "the cross-check: refuse or report". A refit per training operating
        point for each model compared; nothing with ``"both"`` (both errors judged for every candidate).
    torch_threads : torch intra-op threads during the run (restored after; None leaves them), as ``identify``.

    Raises
    ------
    ValueError
        Unknown candidate names, a split leaving no training records, records too short to identify.
    """
    options = Options(**{k: v for k, v in locals().items() if k not in ("records", "nominal", "torch_threads")})
    options.check()
    with intra_op_threads(torch_threads):
        loop = Loop(records, nominal, options)
        loop.nominal()
        loop.trends()
        loop.effects()
        loop.swaps()
        loop.trends_of_added()
        return loop.result()


class Loop:
    """The loop's data, settings and state; one method per phase (module docstring)."""

    def __init__(self, records, nominal, options: Options):
        self.start_time = time.perf_counter()
        self.options = o = options
        records = records if isinstance(records, RecordSet) else RecordSet(_as_records(records))
        split = dict(o.split or {})
        parts_ = records.split(held_out=split.get("held_out"), val=split.get("val"))
        self.train, self.val, self.test = (_as_records(p) for p in parts_)
        if not self.train:
            raise ValueError(f"the split {split} leaves no training record; hold out fewer conditions")
        self.splits = {"train": self.train, "val": self.val, "test": self.test}
        cond_values = _trend_conditions(o.conditions, Split(self.train, self.val, self.test))
        self.trend_values = dict(cond_values)  # the conditions a parameter may depend on (a leftover network's too)
        check_conditions(Split(self.train, self.val, self.test), conditions_used(nominal),
                         "the nominal model (a parameter as a function of a condition)")
        self.n_train = sum(len(r) for r in self.train)
        for r in self.train:
            r.require_samples(16, "discovery (identifying a candidate effect)")
        self.score = Validation(o.validation, self.train, self.val, lm_steps=o.lm_steps,
                                box_factor=o.box_factor)  # refuses a bad kind
        # the noise level the rule judges "within the noise" by: the user's, else estimated from the data
        self.noise = {"sd": o.noise_sd, "source": "given"} if o.noise_sd else {
            "sd": noise_sd([r.y for r in self.train]),
            "source": "estimated from the training responses' differences (analysis.noise), capped by the current "
                      "model's training RMSE"}
        self.base_rule = Acceptance(o.margin, o.criterion, self.n_train, noise=self.noise["sd"])
        self.sim = o.sim
        self.model = nominal
        self.scales = Scales.of(self.train, oscillator=isinstance(nominal, DrivenOscillator))
        # conditions with enough levels get their trends in one step (every constant parameter at once), before
        # the effects and again after them for the parameters the effects brought; the others keep the
        # one-parameter-at-a-time candidates
        self.trend_conditions = [c for c in cond_values if len(set(cond_values[c])) >= MIN_LEVELS]
        self.single_conditions = {c: v for c, v in cond_values.items() if c not in self.trend_conditions}
        # control channels (data.controls): a parameter may follow one (judged on every sample, like an effect),
        # and the control may lag (``control_lag``, offered once a parameter follows it)
        self.controls = _controls(o.conditions, self.train)
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
                    parameters=_parameters(fit.model), train_rmse=math.sqrt(fit.sse / self.n_train),
                    val_rmse=judged.val if self.score.out_of_sample else None, test_rmse=self._test_rmse(fit),
                    details=details, evidence_details=evidence)

    def evaluate(self, model, sim: dict) -> tuple[dict, dict]:
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
            return "loco", Validation("loco", self.train, [], lm_steps=o.lm_steps, box_factor=o.box_factor)
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
            opts = {"method": "cma", "pop": 24, "generations": 30, "restarts": 4, **dict(o.identify_options or {})}
            identify(self.model, self.train, fisher=False, progress=o.progress, backend=o.backend,
                     ode_method=o.method, substeps=o.substeps, **opts)
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
                          trends=chosen)
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

    def _effect_step(self, cands) -> bool:
        """One step over ``cands``; whether a candidate was accepted."""
        o, fit = self.options, self.fit
        if o.backend == "fast":  # every candidate's compiled loops built side by side, before they are fitted
            _prebuild(cands, fit.model, tuple(sorted(self.controls)))
        ranking = _fit_candidates(cands, fit.model, self.train, _at(self.sim, fit), o.lm_steps, o.box_factor,
                                  int(o.workers), self._bar)
        ranking.sort(key=lambda item: item[1].sse if item[1] is not None else math.inf)
        ref = {s: sse_at(fit, self.train, self.sim, s) for s in {f.substeps for _, f in ranking if f is not None}}
        evidence = {c.name: (1 - f.sse / ref[f.substeps] if f is not None and ref[f.substeps] > 0 else None)
                    for c, f in ranking}
        finals = [(cand, f, self.judge(f)) for cand, f in ranking[: int(o.top)] if f is not None]
        if not finals:
            return False
        def adds(i: int) -> bool:
            # the current model at the candidate's resolution, too: one that needed finer steps must beat it there
            _, f, j = finals[i]
            ic_ref = information_criterion(ref[f.substeps], self.n_train, fit.k, self.rule.criterion)
            return self.rule.adds(j, Judged(self.now.val, min(self.now.ic, ic_ref)))

        index = self.rule.pick([j for _, _, j in finals], adds)
        cand, c_fit, judged = finals[index]
        accepted = adds(index)
        step = self._step(cand.name, cand.kind, cand.describe, c_fit, judged, self.now, accepted, evidence={
            "explained_share": evidence[cand.name], "ranking": evidence, "refitted": [f[0].name for f in finals],
            "compared": {f[0].name: {"val_rmse": f[2].val, "criterion": f[2].ic, **parts(val=f[2].val)}
                         for f in finals}},
            new_coordinates={n: c_fit.coords.get(n) for n in cand.free}, substeps=c_fit.substeps)
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
        return True

    def swaps(self) -> None:
        """Each added effect against the close calls of its step, on the final model (once; the model has been
        through the removals and special cases after its last step: those are not tried again until a swap)."""
        rivals = {name: [r for r in names if r not in self.tried] for name, names in self.rivals.items()}
        if any(rivals.values()):
            self.removals(rivals, settled=True)

    def result(self) -> DiscoveryResult:
        """Refit the chosen structure, measure what is left and assemble the result."""
        o = self.options
        model, final_sim = self.fit.model, _at(self.sim, self.fit)
        initial, initial_sim = self.initial, self.initial_sim
        preds_before, before = self.preds_before, self.before
        preds_after, after = self.evaluate(model, final_sim)
        refitted = None
        trained_model, trained_sim = model, final_sim  # the chosen structure fitted on the training records alone
        if o.refit and self.val:  # the structure is chosen: its parameters (and the nominal's) use every non-test
            chosen = {"before": (initial, before), "after": (model, after)}
            initial, initial_sim = _refit_on(initial, self.train + self.val, initial_sim, o.lm_steps, o.box_factor)
            model, final_sim = _refit_on(model, self.train + self.val, final_sim, o.lm_steps, o.box_factor)
            preds_before, before = self.evaluate(initial, initial_sim)
            preds_after, after = self.evaluate(model, final_sim)
            refitted = {"records": [r.name for r in self.train + self.val]}
            for side, now in (("before", before), ("after", after)):
                m, was = chosen[side]
                refitted[side] = {"val_rmse_in_sample": now["val"].get("rmse"),
                                  "test_rmse_without_refit": was["test"].get("rmse"),
                                  "train_rmse_without_refit": was["train"]["rmse"],
                                  "parameters_without_refit": _parameters(m)}
                now["val"] = was["val"]  # the validation error stays out of sample
        diag_after = diagnose(self.train, preds_after["train"], o.noise_sd)
        if o.leftover == "dynamics":
            # on the training-only fit, so that the validation records are out of sample for the physics too
            network = neural_leftover(trained_model, self.train, self.val or None, sim=trained_sim,
                                      conditions=self.trend_values, progress=o.progress)
        else:
            network = residual_network(self.train, preds_after["train"], self.val or None,
                                       preds_after["val"] or None)
        nominal_effects = {e.name for e in initial.effects.values()}
        final_effects = [e.name for e in model.effects.values()]
        splits = self.splits
        report = {
            "before": {"test_rmse": before["test"].get("rmse"), "train_rmse": before["train"]["rmse"],
                       "val_rmse": before["val"].get("rmse"), "per_condition": before["test"].get("per_condition", {}),
                       "parameters": _parameters(initial), "diagnostics": self.diag_before},
            "after": {"test_rmse": after["test"].get("rmse"), "train_rmse": after["train"]["rmse"],
                      "val_rmse": after["val"].get("rmse"), "per_condition": after["test"].get("per_condition", {}),
                      "parameters": _parameters(model), "diagnostics": diag_after},
            "steps": [s.as_json() for s in self.steps], "rejected": [s.as_json() for s in self.rejected],
            "removed": [c.as_json() for c in self.removed], "stopped": self.stopped,
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
                         "lm_steps": o.lm_steps, "candidates": list(o.candidates) if o.candidates else "library",
                         "conditions": o.conditions if isinstance(o.conditions, bool) else list(o.conditions),
                         "backend": o.backend, "method": o.method, "substeps": o.substeps,
                         "substeps_final": final_sim["substeps"],
                         "substeps_scored": {s: after[s]["substeps"] for s in splits if splits[s]},
                         "leftover": o.leftover, "validation": o.validation, "cross_check": o.cross_check,
                         "refit": bool(o.refit and self.val)},
            "validation": {"kind": o.validation, "on": self.score.scored, "rmse_before": self.val0,
                           "rmse_after": self.now.val, **parts(before=self.val0, after=self.now.val)},
            "refit": refitted,
            "noise": {**self.noise, "floor_share": self.rule.share, "sd_at_the_end": self.rule.noise},
            "records": {s: [r.name for r in rs] for s, rs in splits.items()},
            "wall_s": time.perf_counter() - self.start_time,
        }
        return DiscoveryResult(model=model, report=report, predictions={"before": preds_before, "after": preds_after},
                               splits=splits, initial_model=initial, steps=list(self.steps),
                               rejected=list(self.rejected), removed=list(self.removed))


def _fit_candidates(cands, model, train, sim, lm_steps, box_factor, workers: int, bar) -> list:
    """``[(candidate, Fit or None)]`` in the candidates' order: each fitted (``fit_candidate``), ``workers`` at a
    time; a candidate that cannot be simulated gets None."""
    def one(cand):
        try:
            return fit_candidate(cand, model, train, sim, lm_steps, box_factor)
        except (ValueError, RuntimeError):  # a candidate that cannot be simulated is skipped
            return None

    fits = side_by_side(one, cands, workers, lambda items, n: bar(items, "rank candidates", total=n))
    return list(zip(cands, fits))


def _prebuild(cands, model, controls: tuple[str, ...] = ()) -> None:
    """Build the candidates' compiled loops at once (one compiler per core); a candidate that cannot be built is
    left to its own fit, which skips it."""
    built = []
    for cand in cands:
        try:
            built.append(cand.build(model))
        except (ValueError, RuntimeError):
            continue
    try:
        prebuild_models(built, controls)
    except (ValueError, RuntimeError):
        pass


def _refit_on(model, records, sim: dict, lm_steps: int, box_factor: float):
    """A copy of ``model`` with every coordinate refitted on ``records`` (LM from its values); its settings."""
    f = polish(copy.deepcopy(model), records, sim, lm_steps, box_factor)
    return f.model, _at(sim, f)
