"""``IdentifySettings``: every option of ``identify`` as one object (the global search, the refinement, the
identifiability analysis, and how the model is simulated), read from a config block through one typed schema."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

from ..settings import check_fields, from_mapping
from ..simulate import SimulationSettings

__all__ = ["SEARCHES", "IdentifySettings"]

SEARCHES = ("cma", "de", "mc", "grid")


@dataclass(frozen=True)
class IdentifySettings:
    """How ``identify`` fits a nominal model's free parameters.

    Parameters
    ----------
    search : the global search: ``"cma"`` (CMA-ES, default: the more reliable on Bouc–Wen fits), ``"de"``
        (differential evolution), ``"mc"`` (Monte Carlo: uniform samples of the box, seed 002) or ``"grid"``
        (an even grid, seed 004), the last two with a budget of pop × generations points;
        pop, generations : population size (None: the search's default) and generations per round.
    rounds : search + refinement rounds at most; a round after the first resumes the search from the
        refined points and the last population (new seed), and runs only while ``target`` is not met.
    refine : local refinement of the best ``restarts`` members, all in one batch: ``"lm"`` (default, also
        ``True``: batched Levenberg–Marquardt, ``lm_steps`` iterations), ``"gradient"`` (Adam ``adam_steps``
        then L-BFGS ``lbfgs_steps`` through the exact adjoint, Adam step ``lr``) or ``"none"``.
    bounds, box_factor : search-box overrides ``{coordinate: (low, high)}`` and default width (``SearchSpace``).
    noise_sd : response noise standard deviation for the Fisher analysis (default: the residual RMSE);
        also the default early-stop target of the search, cost ≤ (1.01 noise_sd)². With ``fisher``, a search
        stopped at the target is refined on (``lm_steps`` more Levenberg–Marquardt iterations) to the
        least-squares minimum, whose scatter the standard deviations describe.
    target : stop the search at this cost (MSE); seed : random seed (same seed, same result).
    fisher : run the identifiability analysis; jacobian : ``"exact"`` (forward sensitivities, one pass),
        ``"autograd"`` (exact, M simulated rows for M samples), ``"fd"`` (central differences, 2 D rows) or
        ``"auto"`` (exact where it covers the model, else autograd up to 512 samples × records, else fd).
    progress : progress bars.
    input_channels : the record channels that drive the model.
    simulation : how the model is integrated (``SimulationSettings``; default the compiled backend, RK4, one
        sub-step per sample).
    search_decimate : run the global search on every ``search_decimate``-th sample of each record (the
        refinement and every reported cost use all samples).
    resolve, max_substeps : step doubling (``simulate.resolved_substeps``): once identified, the fewest sub-steps
        per sample (from ``simulation.substeps`` up to ``max_substeps``) at which halving the step changes the
        response by at most 0.1 %; where more, the refinement goes on at the finer step and the search runs again
        there (the coarse fit's basin is the integrator's error's); the better of the two is kept.
    recentre : when constants end at an edge of their default search box (``IdentificationResult.at_bounds``;
        not those the user gave ``bounds`` for; a trend's coefficients keep their own rule), search again,
        started at the values found, with those boxes centred on them and every other box as it was (a short
        search, one generation of 8, and the refinement: the first search found the basin, the box stopped it),
        up to ``recentre`` times: a declared value more than ``box_factor`` from the data's optimum is followed
        there. A pass is kept if it lowers the cost by at least 1 %, or lowers it without leaving a value it
        followed at the same edge again (``recentred`` counts them; one that does, for less, is undone: the value
        runs off towards a limit the data do not fix); the passes end at the target, at a pass that gains less
        than 1 %, is undone or fails, or where no box can move (a domain's own limit).
        0 (default): the edge is reported only.
    torch_threads : torch intra-op threads during the run (restored after; None leaves them). The compiled
        simulator already runs rows in parallel; torch's threads competing with it made identification of the
        seed 001 loop about 5x slower on a 2-core machine.
    """

    search: str = "cma"
    pop: int | None = 32
    generations: int = 30
    rounds: int = 3
    refine: bool | str = "lm"
    restarts: int = 8
    lm_steps: int = 40
    adam_steps: int = 40
    lbfgs_steps: int = 60
    lr: float = 0.05
    bounds: Mapping | None = None
    box_factor: float = 10.0
    noise_sd: float | None = None
    target: float | None = None
    seed: int = 0
    fisher: bool = True
    jacobian: str = "auto"
    progress: bool = True
    input_channels: tuple = ("x",)
    simulation: SimulationSettings = field(default_factory=SimulationSettings)
    search_decimate: int = 1
    resolve: bool = False
    max_substeps: int = 16
    recentre: int = 0
    torch_threads: int | None = 1

    def __post_init__(self):
        if self.search not in SEARCHES:
            raise ValueError(f"unknown search {self.search!r}; choose one of {list(SEARCHES)}")
        if self.refine not in (True, False, None, "lm", "gradient", "none"):
            raise ValueError(f"unknown refine mode {self.refine!r}; choose 'lm', 'gradient' or 'none'")
        object.__setattr__(self, "bounds", {k: tuple(v) for k, v in (self.bounds or {}).items()})
        object.__setattr__(self, "input_channels", tuple(self.input_channels))

    def replace(self, **changes) -> IdentifySettings:
        """These settings with ``changes`` (field names; a misspelt one is a one-line error)."""
        check_fields(IdentifySettings, changes, "identify", RENAMED)
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_config(cls, block, where: str = "identify", **given) -> IdentifySettings:
        """From a config block (conf/identify.yaml's ``identify:``; ``simulation:`` a nested block): unknown keys
        and wrong types are one-line errors naming the key."""
        return from_mapping(cls, block, where, **given)


# the options renamed when the settings became one object: a call with the old name is told the new one
RENAMED = {"method": "search (the ODE scheme is simulation.method)",
           "ode_method": "simulation=SimulationSettings(method=...)",
           "substeps": "simulation=SimulationSettings(substeps=...)",
           "backend": "simulation=SimulationSettings(backend=...)"}
