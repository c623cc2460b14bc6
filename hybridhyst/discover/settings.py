"""``DiscoverSettings``: every option of the closed loop (``discover``) as one object, read from a config block through
one typed schema (``hybridhyst.settings.from_mapping``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..identify import IdentifySettings
from ..identify.settings import RENAMED as IDENTIFY_RENAMED
from ..settings import check_fields, from_mapping
from ..simulate import SimulationSettings
from .leftover import LEFTOVER
from .rule import check_criterion
from .validation import VALIDATION

__all__ = ["CROSS_CHECK", "DiscoverSettings"]

CROSS_CHECK = ("confirm", "report", "off")
# options renamed when the simulation settings became one object
RENAMED = {k: v for k, v in IDENTIFY_RENAMED.items() if k != "method"} | {
    "method": "simulation=SimulationSettings(method=...)"}
# the nominal's first fit (``fit_nominal``) before ``identify_options`` are laid over it
FIRST_FIT = IdentifySettings(pop=24, generations=30, restarts=4, fisher=False, recentre=3)


@dataclass(frozen=True)
class DiscoverSettings:
    """How ``discover`` runs.

    Parameters
    ----------
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
    carried_travel : the records are in the order they were measured, so a drift with travel (``travel_drift``,
        ``travel_stiffness``, ``travel_damping``) may carry over from one to the next: each such candidate starts
        every record at the travel before it, T0 + b · ``travel_before`` (the input's travel in the records before
        it, ``data.records.with_travel_before``; T0, the travel before the first, and b ≥ 0 fitted; b = T0 = 0 is
        the drift that starts every record afresh). Not for an oscillator (its motion is a response) nor with one
        record.
    criterion : "bic" or "aic", which must also fall; max_steps : greedy steps accepted at most (an effect, a
        parameter function of a condition or a start state each; the trends and the start state offered right
        after an effect is added do not count).
    top : best-ranked candidates compared on validation error; further : when the rule accepts none of them, the
        next ``further`` candidates of the ranking are judged too, and the one it prefers of those it accepts is
        the step (0: the step is refused); revisit : once the loop has stopped short of the noise, each effect it
        added is tried replaced by each of its special cases together with one more effect chosen from there (a
        first step that took a flexible element standing in for two effects: Dahl for Coulomb and a delay), kept
        where the rule would accept it as a step over the final model; lm_steps : LM iterations per round of
        a fit (more rounds while the cost still falls by more than 0.1 %, at most 4).
    noise_sd : known noise standard deviation of the response. The acceptance rule (``rule.Acceptance``) treats
        models whose mean squared errors differ by at most ``rule.NOISE_SHARE`` σ² as within the noise of each
        other; without it, σ is estimated from the training responses (``analysis.noise``) and capped by the
        current model's training RMSE (both reported).
    fit_nominal : identify the nominal on the training records first (``hybridhyst.identify``: CMA-ES with a
        population of 24 for 30 generations, 4 restarts refined, the box re-centred up to 3 times on values it
        stopped at an edge (``recentre``: a declared value more than ``box_factor`` off is followed), then
        ``identify_options``, any ``IdentifySettings`` fields; the report's ``before.first_fit`` says how it
        ended); else start from its current values.
    simulation : how models are simulated (``SimulationSettings``; "fast": compiled, cached per model structure);
        every fit resolves its own sub-steps from ``simulation.substeps`` by step doubling.
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
    workers : candidates fitted at once, each in a forked process of its own (``fitting.side_by_side``; a thread
        where the platform cannot fork); so are the leave-one-condition-out refits. The fits and the result are the
        same for any number.
    cross_check : "confirm" (default), "report" or "off". For every step the rule accepts, also measure the
        out-of-sample error it did not judge (with ``validation="records"``, leave-one-condition-out over the
        training operating points; with ``"loco"``, the validation records'). When that error did not fall by the
        margin too, the evidence disagrees: "confirm" refuses the step, "report" keeps it; either says so in one
        line (``result.disagreement_line``; report and terminal summary). Why "confirm" is the default:
        ``experiments/discovery_testbed``, "the cross-check: refuse or report". A refit per training operating
        point for each model compared; nothing with ``"both"`` (both errors judged for every candidate).
    progress : progress bars.
    torch_threads : torch intra-op threads during the run (restored after; None leaves them), as ``identify``.
    """

    candidates: Sequence[str] | None = None
    split: Mapping | None = None
    conditions: bool | Sequence[str] = True
    label_conditions: Sequence[str] | None = None
    margin: float = 0.02
    criterion: str = "bic"
    max_steps: int = 4
    top: int = 3
    further: int = 0
    revisit: bool = False
    lm_steps: int = 25
    box_factor: float = 10.0
    noise_sd: float | None = None
    fit_nominal: bool = True
    identify_options: Mapping | None = None
    simulation: SimulationSettings = field(default_factory=SimulationSettings)
    refit: bool = True
    leftover: str = "static"
    validation: str = "records"
    start_states: bool = True
    carried_travel: bool = True
    progress: bool = True
    workers: int = 1
    cross_check: str = "confirm"
    torch_threads: int | None = 1

    def __post_init__(self):
        from ..physics.effects import EFFECTS

        check_criterion(self.criterion)
        if self.cross_check not in CROSS_CHECK:
            raise ValueError(f"unknown cross_check {self.cross_check!r}; choose one of {list(CROSS_CHECK)}")
        if self.leftover not in LEFTOVER:
            raise ValueError(f"unknown leftover measure {self.leftover!r}; choose one of {list(LEFTOVER)}")
        if self.validation not in VALIDATION:
            raise ValueError(f"unknown validation {self.validation!r}; choose one of {list(VALIDATION)}")
        unknown = [c for c in (self.candidates or []) if c not in EFFECTS]
        if unknown:
            raise ValueError(f"unknown candidate effect(s) {unknown}; the library has {sorted(EFFECTS)}")
        self.first_fit()  # a misspelt identify option fails here, before any fitting

    def first_fit(self) -> IdentifySettings:
        """The settings of the nominal's first fit: ``FIRST_FIT`` with ``identify_options`` over it, simulated
        like every other fit of the loop."""
        return FIRST_FIT.replace(**{"progress": self.progress, "simulation": self.simulation,
                                    **dict(self.identify_options or {})})

    def replace(self, **changes) -> DiscoverSettings:
        """These settings with ``changes`` (field names; a misspelt or renamed one is a one-line error)."""
        check_fields(DiscoverSettings, changes, "discover", RENAMED)
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_config(cls, block, where: str = "discover", **given) -> DiscoverSettings:
        """From a config block (conf/discover.yaml's ``discover:``): unknown keys and wrong types are one-line
        errors naming the key."""
        return from_mapping(cls, block, where, **given)
