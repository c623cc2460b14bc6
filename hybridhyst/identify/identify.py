"""``identify``: batched global search, gradient refinement and identifiability analysis on records.

One cost evaluation simulates population × records in one ``simulate(..., values=..., backend="fast")``
call per time grid: member n at record r is batch row n·R + r, with its parameter functions evaluated at
record r's conditions. So a model whose parameters are functions of a condition (e.g. linear in
``pressure_mpa``) is fitted to all pressure levels at once by one search over the function coefficients.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import torch
from torch import nn

from ..data.decimate import decimate_all
from ..data.records import Record, RecordSet
from ..settings import intra_op_threads
from ..simulate import SimulationSettings, resolved_substeps
from .fisher import FisherReport, fisher_analysis, output_jacobian
from .problem import RecordsProblem, culprits
from .refine import levenberg_marquardt
from .refine import refine as refine_rows
from .search import cma_es, differential_evolution, grid_search, monte_carlo
from .settings import IdentifySettings
from .space import SearchSpace, condition_ranges

__all__ = ["IdentificationResult", "identify"]


@dataclass
class IdentificationResult:
    """Outcome of ``identify``.

    Attributes
    ----------
    model : the model (fitted in place); x : best coordinates ``{name: value}``.
    parameters : ``{effect: {parameter: {"value", "unit", "fixed"}}}`` (functions as text, with units).
    rmse : pooled response RMSE; per_record : ``{record name: RMSE}``; cost : best MSE.
    fisher : identifiability analysis (None when skipped); identifiable : its identifiable combinations;
    uncertainty : standard deviation of each coordinate ``{name: sd}``.
    history : ``{"search": best cost per search generation, "refine": the refinement's cost per step}``; with
    ``resolve``, the searches and refinements at finer steps are appended in the order they ran, and with
    ``recentre`` those of the re-centred passes.
    wall_s : wall time [s]; evaluations : simulated population rows (× records); search : method name.
    at_bounds : ``{name: "lower" | "upper"}``, coordinates that ended at an edge of the search box (within
    0.1 % of its width, on the log scale where it searches one): the box, not the data, set them.
    substeps : sub-steps per sample the result was simulated with (chosen by step doubling with ``resolve``).
    recentred : how many times the search was run again around values it left at an edge (``recentre``).
    resolution : relative RMS change of the identified model's response under halved steps at ``substeps``
    (``nan`` without ``resolve``; above ``simulate.api.RESOLVED`` where ``max_substeps`` did not resolve it).
    """

    model: nn.Module
    x: dict[str, float]
    parameters: dict
    rmse: float
    per_record: dict[str, float]
    cost: float
    fisher: FisherReport | None = None
    identifiable: list[str] = field(default_factory=list)
    uncertainty: dict[str, float] = field(default_factory=dict)
    history: dict[str, list[float]] = field(default_factory=dict)
    wall_s: float = 0.0
    evaluations: int = 0
    search: str = ""
    at_bounds: dict[str, str] = field(default_factory=dict)
    substeps: int = 1
    resolution: float = math.nan
    recentred: int = 0


def _records(records) -> list[Record]:
    if isinstance(records, Record):
        return [records]
    records = list(records.records if isinstance(records, RecordSet) else records)
    if not records:
        raise ValueError("identify got no records; check the data selection")
    return records


def _global(problem, method, pop, generations, seed, target, progress, init=None):
    if method == "de":
        return differential_evolution(problem.cost, problem.space, pop=pop, generations=generations, seed=seed,
                                      target=target, init=init, progress=progress)
    if method == "cma":
        init = None if init is None else init[:1]
        return cma_es(problem.cost, problem.space, pop=pop, generations=generations, seed=seed, target=target,
                      init=init, progress=progress)
    budget = int(pop or 32)
    if method == "mc":  # the same budget as pop × generations, one batch per "generation"
        return monte_carlo(problem.cost, problem.space, samples=budget * generations, batch=budget, seed=seed,
                           target=target, init=init, progress=progress)
    if method == "grid":  # the finest even grid within pop × generations points (the same in every round)
        points = max(2, int((budget * generations) ** (1.0 / problem.space.dim) + 1e-9))
        return grid_search(problem.cost, problem.space, points=points, batch=budget, target=target,
                           progress=progress)
    raise ValueError(f"unknown search {method!r}; choose 'de', 'cma', 'mc' or 'grid'")


def _local(problem, mode, found, opts, target, progress, also=None):
    """Refine the best finite members of a search in one batch (and the rows ``also``); returns (result or None,
    rows simulated)."""
    starts = found.population[torch.isfinite(found.costs)][: max(1, int(opts["restarts"]))]
    if also is not None:
        starts = torch.cat([also.to(starts), starts])
    if mode == "none" or len(starts) == 0:
        return None, 0
    R = len(problem.records)
    if mode == "lm":
        ref = levenberg_marquardt(problem.residuals, problem.space, starts, iters=opts["lm_steps"], target=target,
                                  jacobian_rows=problem.jacobian_rows,
                                  progress=progress)
        return ref, ref.evaluations * R
    ref = refine_rows(problem.cost, problem.space, starts, adam_steps=opts["adam_steps"],
                      lbfgs_steps=opts["lbfgs_steps"], lr=opts["lr"], target=target, progress=progress)
    return ref, ref.evaluations * len(starts) * R


def _rounds(problem, coarse, method, pop, generations, rounds, seed, target, mode, opts, progress, init=None):
    """Global search (on ``coarse``, the decimated problem) then batched refinement (on ``problem``),
    repeated (search resumed with the refined points) until the target is met or ``rounds`` are done; the first
    search starts at ``init``'s rows (default the box centre), which its refinement starts from too. Returns (x,
    cost, history, rows simulated)."""
    x, cost, evals = None, math.inf, 0
    history: dict[str, list[float]] = {"search": [], "refine": []}
    for k in range(max(1, int(rounds))):
        found = _global(coarse, method, pop, generations, seed + k, target, progress, init)
        history["search"] += found.history
        evals += found.evaluations * len(problem.records)
        if coarse is not problem:  # the coarse grid's cost is an estimate: score the best on the full grid
            with torch.no_grad():
                found_cost = float(problem.cost(found.x[None])[0])
            found.cost = found_cost if math.isfinite(found_cost) else math.inf
        if x is None or found.cost < cost:
            x, cost = found.x, found.cost
        ref, n = _local(problem, mode, found, opts, target, progress, init if k == 0 else None)
        evals += n
        if ref is not None:
            history["refine"] += ref.history
            if ref.cost < cost:
                x, cost = ref.x, ref.cost
        if target is None or cost <= target or not math.isfinite(cost):
            break
        init = found.population if ref is None else torch.cat([ref.X, found.population])
    return x, cost, history, evals


def _fisher(problem, x, mse, noise_sd, jacobian) -> FisherReport:
    D = problem.space.dim
    sigma = noise_sd if noise_sd else math.sqrt(mse * problem.n_samples / max(problem.n_samples - D, 1))
    exact = problem.jacobian_rows
    if jacobian == "auto":
        jacobian = "exact" if exact else "autograd" if problem.n_samples * len(problem.records) <= 512 else "fd"
    if jacobian == "exact":
        if exact is None:
            raise ValueError("jacobian='exact' needs the fast backend and a model without networks")
        J = exact(x[None], torch.ones(D, dtype=torch.bool))[1][0]
    else:
        J = output_jacobian(problem.predict, x, method=jacobian)
    return fisher_analysis(J, x, problem.space.names, max(sigma, 1e-300), log=problem.space.log)


def identify(model: nn.Module, records, settings: IdentifySettings | None = None,
             **options) -> IdentificationResult:
    """Identify a nominal model's free parameters from records: global search, refinement, identifiability.

    Parameters
    ----------
    model : nominal model; its current values centre the default search box and it is fitted in place.
    records : a ``Record``, ``RecordSet`` or list of records (different conditions are fitted jointly).
    settings : ``IdentifySettings`` (the search, the refinement, the Fisher analysis, the simulation); default its
        defaults. ``options``: any of its fields laid over it, e.g. ``identify(model, records, search="de",
        pop=16, simulation=SimulationSettings(substeps=2))``; a name it lacks is a ``TypeError`` naming the
        field meant.

    Raises
    ------
    ValueError
        When the best fit is not finite, naming the parameters whose values drove the divergence.
    """
    settings = (settings or IdentifySettings()).replace(**options)
    records = _records(records)  # a list: the re-centred passes read the records again
    with intra_op_threads(settings.torch_threads):
        result = _identify(model, records, settings)
        return _recentred(model, records, settings, result) if int(settings.recentre) else result


def _target(o: IdentifySettings) -> float | None:
    """The cost the search stops at: ``target``, else (1.01 ``noise_sd``)² where a noise level is given."""
    if o.target is not None:
        return o.target
    return (1.01 * o.noise_sd) ** 2 if o.noise_sd else None


def _boxes(space) -> dict[str, tuple[float, float]]:
    return {c.name: (c.lower, c.upper) for c in space.coordinates}


RECENTRE_GAIN = 0.99  # a pass that lowers the cost by less than 1 % ends the re-centring (and is undone if it
# leaves a value it followed at the same edge again)
RECENTRED = {"pop": 8, "generations": 1, "rounds": 1}  # the search of a re-centred pass


def _recentred(model, records, o: IdentifySettings, result: IdentificationResult) -> IdentificationResult:
    """Up to ``o.recentre`` passes after the first fit ``result``: while constants (a trend's coefficients keep
    their own rule) end at an edge of a default box the user set no bounds for, the search again, started at the
    values found, with the constants' default boxes centred on them and the user's and the trends' boxes as they
    were (a short search, and the refinement from its best and from the values found: the first search found the
    basin, the box stopped it). A pass is kept if it lowers the cost by at least 1 %, or lowers it without leaving a
    value it followed at the same edge again; one that does, for less, is undone (the value runs off towards a
    limit the data do not fix). The passes end at the target, at a pass that gains
    less than 1 % or is undone or fails, or where no box can move (a domain's own limit, such as a share's 1, is
    an edge of every box)."""
    ranges = condition_ranges(records)
    space = SearchSpace(model, o.bounds, factor=o.box_factor, condition_ranges=ranges)
    boxes = _boxes(space)
    constants = {c.name for c in space.coordinates if c.name == f"{c.effect}.{c.param}"}
    target = _target(o)
    last = None  # the settings of the last pass kept
    for k in range(int(o.recentre)):
        if target is not None and result.cost <= target:
            break
        follow = [n for n in result.at_bounds if n in constants and n not in o.bounds]
        # every constant's box about its value now (one at an edge often drags another near its own: a stiffness
        # and a cubic term), the user's and the trends' boxes as they were
        held = {n: b for n, b in boxes.items() if n not in constants or n in o.bounds}
        space = SearchSpace(model, held, factor=o.box_factor, condition_ranges=ranges)
        if not any(n not in at_bounds(space, space.initial()) for n in follow):
            break
        step = o.replace(bounds=held, seed=o.seed + 1000 * (k + 1), fisher=False,
                         simulation=o.simulation.at(result.substeps), **RECENTRED)
        kept = copy.deepcopy(model.state_dict())
        try:
            again = _identify(model, records, step, from_values=True)
        except ValueError:  # every member of the pass diverged: the fit before it stands
            model.load_state_dict(kept)
            break
        again.wall_s += result.wall_s
        again.evaluations += result.evaluations
        again.history = {key: result.history.get(key, []) + again.history.get(key, [])
                         for key in dict.fromkeys([*result.history, *again.history])}
        gain = again.cost < RECENTRE_GAIN * result.cost
        # a value followed that ends at the same edge again runs off towards a limit; one inside its box, or at the
        # other edge (back towards where the first search started), does not
        runs_off = any(again.at_bounds.get(n) == result.at_bounds[n] for n in follow)
        if again.cost < result.cost and (gain or not runs_off):
            again.recentred = k + 1
            result, last = again, step
            boxes = _boxes(space)
        else:  # at the same edge for (next to) nothing: the value runs off towards a limit the data do not fix;
            # followed, it would only move the boxes later fits start from (a stiffness the control-blind first fit
            # of an MR damper pushes a decade down for 0.02 % no longer reaches its value once the voltage's trends
            # are in). The fit before it, with the time the pass cost
            model.load_state_dict(kept)
            result.wall_s, result.evaluations, result.history = again.wall_s, again.evaluations, again.history
            break
        if not gain:
            break
    if last is not None and o.fisher:  # the identifiability analysis once, at the point kept
        space = SearchSpace(model, last.bounds, factor=o.box_factor, condition_ranges=ranges)
        problem = _problem(space, records, o.input_channels, o.simulation.at(result.substeps))
        report = _fisher(problem, space.initial(), result.cost, o.noise_sd, o.jacobian)
        result.fisher, result.identifiable, result.uncertainty = report, report.identifiable, report.sd
    return result


def _problem(space, records, input_channels, sim: SimulationSettings, decimate: int = 1) -> RecordsProblem:
    """``records`` (for a search: every ``decimate``-th sample of each) simulated with ``sim``."""
    if int(decimate) != 1:
        records = decimate_all(records, int(decimate), "identification")
    return RecordsProblem(space, records, input_channels, sim)


def _identify(model, records, o: IdentifySettings, from_values: bool = False) -> IdentificationResult:
    """One identification (``identify`` without the re-centring); ``from_values``: the search starts at the
    model's values rather than at the box centre (they differ on a signed coordinate's box)."""
    start = time.perf_counter()
    records = _records(records)
    space = SearchSpace(model, o.bounds, factor=o.box_factor, condition_ranges=condition_ranges(records))
    channels, sim = o.input_channels, o.simulation
    problem = _problem(space, records, channels, sim)
    decimate = int(o.search_decimate)
    coarse = _problem(space, records, channels, sim, decimate) if decimate != 1 else problem
    target = _target(o)
    mode = {True: "lm", False: "none", None: "none"}.get(o.refine, o.refine)
    opts = {"restarts": o.restarts, "lm_steps": o.lm_steps, "adam_steps": o.adam_steps,
            "lbfgs_steps": o.lbfgs_steps, "lr": o.lr}
    search = (o.search, o.pop, o.generations, o.rounds)
    x, cost, history, evals = _rounds(problem, coarse, *search, o.seed, target, mode, opts, o.progress,
                                      space.initial()[None] if from_values else None)

    state = {"problem": problem, "x": x, "cost": cost, "evals": evals}

    def go_on(s: int) -> None:  # Levenberg–Marquardt on from the current point at s sub-steps per sample
        if s != state["problem"].sim.substeps:
            state["problem"] = _problem(space, records, channels, sim.at(s))
        p, x = state["problem"], state["x"]
        with torch.no_grad():
            cost = float(p.cost(x[None])[0])  # the same point on this problem
        ref = levenberg_marquardt(p.residuals, space, x[None], iters=int(o.lm_steps), progress=o.progress,
                                  jacobian_rows=p.jacobian_rows)
        history["refine"] += ref.history
        state["evals"] += ref.evaluations * len(p.records)
        if ref.cost < cost or not math.isfinite(cost):
            x, cost = ref.x, ref.cost
        space.to_model(x)
        state.update(x=x, cost=cost)

    def check(s: int) -> float:  # step doubling from s sub-steps, going on (go_on) wherever it doubles
        space.to_model(state["x"])
        return resolved_substeps(space.model, records, settings=sim, substeps=s, max_substeps=int(o.max_substeps),
                                 refit=go_on, input_channels=tuple(channels))[1]

    def search_again(s: int, k: int) -> bool:  # the search at s sub-steps; its fit replaces the current if better
        grid = state["problem"] if decimate == 1 else _problem(  # the same step on the decimated grid
            space, records, channels, sim.at(s * decimate), decimate)
        x2, cost2, more, n = _rounds(state["problem"], grid, *search, o.seed + k * max(1, int(o.rounds)), target,
                                     mode, opts, o.progress)
        state["evals"] += n
        for key, values in more.items():
            history[key] += values
        better = cost2 < state["cost"]
        if better:
            state.update(x=x2, cost=cost2)
        return better

    resolution, searched = math.nan, problem.sim.substeps
    if o.resolve and math.isfinite(cost):
        resolution = check(searched)
        # The refit at a finer step starts in the basin of the fit at the coarser one, whose optimum the
        # integrator's error shaped: search again at the finer step, keep the better and check it again
        while state["problem"].sim.substeps != searched and not (target is not None and state["cost"] <= target):
            searched = state["problem"].sim.substeps
            if search_again(searched, int(math.log2(searched))):
                resolution = check(searched)
    if o.fisher and target is not None and state["cost"] <= target and mode != "none":
        # the search stopped at the target, short of the least-squares minimum (as may a refit at a finer step,
        # lm_steps from a coarser fit); the Fisher standard deviations describe the minimum's scatter, so go on to
        # it (the early-stopped point scatters more than they say)
        go_on(state["problem"].sim.substeps)
    problem, x, cost, evals = state["problem"], state["x"], state["cost"], state["evals"]
    if not math.isfinite(cost):
        names = culprits(problem, x)
        raise ValueError(f"identification ended non-finite: every simulation diverged; parameters driving it: "
                         f"{names}; narrow their bounds, add substeps or a finer time grid")
    space.to_model(x)
    result = _result(problem, x, cost, o.noise_sd, o.fisher, o.jacobian, history, evals, o.search, start)
    result.substeps, result.resolution = problem.sim.substeps, resolution
    return result


def _result(problem, x, cost, noise_sd, fisher, jacobian, history, evals, method, start) -> IdentificationResult:
    space = problem.space
    with torch.no_grad():
        mse = problem.record_mse(x[None])[0]
    per_record = {r.name: math.sqrt(float(m)) for r, m in zip(problem.records, mse)}
    report = _fisher(problem, x, cost, noise_sd, jacobian) if fisher else None
    return IdentificationResult(
        model=space.model, x=dict(zip(space.names, x.tolist())), parameters=space.model.parameter_table(),
        rmse=math.sqrt(cost), per_record=per_record, cost=cost, fisher=report,
        identifiable=report.identifiable if report else [], uncertainty=report.sd if report else {},
        history=history, wall_s=time.perf_counter() - start, evaluations=evals, search=method,
        at_bounds=at_bounds(space, x))


def at_bounds(space, x, tol: float = 1e-3) -> dict[str, str]:
    """``{name: "lower" | "upper"}`` for the coordinates ``x`` that lie within ``tol`` of an edge of ``space``'s
    box, measured in its unit cube (log scale for positive coordinates)."""
    u = space.to_unit(torch.as_tensor(x, dtype=torch.float64).reshape(1, -1))[0].tolist()
    return {n: ("lower" if v <= tol else "upper") for n, v in zip(space.names, u) if v <= tol or v >= 1 - tol}
