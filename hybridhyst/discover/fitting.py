"""Fits inside the discovery loop: a candidate's refit (global search over its new coordinates, re-balance,
joint Levenberg–Marquardt until converged, a fitted constant followed past the edge of its box), the polish of
the current model, and the step-doubling check that the simulator resolves a fitted model at the sample rate of
the data.
"""

from __future__ import annotations

import copy
import math
import multiprocessing
import os
import signal
import sys
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.reduction import ForkingPickler

import numpy as np
import torch

from ..identify.identify import at_bounds
from ..identify.problem import RecordsProblem
from ..identify.refine import levenberg_marquardt
from ..identify.space import SearchSpace, condition_ranges
from ..physics.build import STRUCTURES, model_config, rebuilt_model
from ..simulate import SimulationSettings, coarsest_substeps, resolved_substeps
from ..simulate.fast import prebuild_models

__all__ = ["Fit", "at", "fit_candidate", "fit_candidates", "polish", "prebuild", "refit_on", "search_points",
           "side_by_side", "sse_at"]

MAX_SUBSTEPS = 16  # the step-doubling check stops here
EDGE_PASSES = 3  # a fitted constant a candidate's fit leaves at an edge of its box is followed at most this often
EDGE_GAIN = 0.99  # ... and only while a pass lowers the cost by at least 1 % within its first EDGE_PROBE iterations
EDGE_PROBE = 5
LM_RTOL = 1e-6  # a row whose Gauss–Newton step gains less than this (relative) is converged and simulated no more
SCREEN_SAMPLES = 8192  # a candidate's many-row phases see at most about this many samples (``screened``) ...
SCREEN_RANGE = 0.9  # ... where that part of each record spans this share of its range in every channel


@dataclass
class Fit:
    """A fitted model: its training SSE, number of free coordinates, coordinates and sub-steps per sample."""

    model: object
    sse: float
    k: int
    coords: dict = field(default_factory=dict)
    substeps: int = 1


def side_by_side(fn: Callable, items: Sequence, workers: int, bar: Callable | None = None) -> list:
    """``[fn(item) for item in items]`` with ``workers`` items at a time, each in a forked process of its own on
    Linux, else in a thread. A forked worker holds everything the caller held, so ``fn`` may be a closure; only
    its results cross back (a model as its config and state dict, ``_send_model``), and an item whose result
    cannot be sent back gives None (what both callers' ``fn`` give for a fit that failed). Processes, because a
    fit spends about half its time in small PyTorch operations around the compiled loops, which threads take
    turns at under the GIL (``scripts/bench_build.py --workers``). ``fn`` must not change what the caller reads
    afterwards (a worker's changes stay in the worker): each fit works on its own copy. Each fit is
    deterministic, so the results are the same for any number of workers and either kind
    (``HYBRIDHYST_WORKERS=threads`` in the environment takes threads). ``bar(iterable, total)`` wraps the results
    as they come (a progress bar). An interruption (SIGTERM, Ctrl-C) waits for the items already running or
    handed to a worker (the workers ignore both signals; their parent stops handing them items)."""
    items = list(items)
    if workers <= 1 or len(items) < 2:
        return [fn(item) for item in (bar(items, len(items)) if bar else items)]
    global _JOB
    forks = (sys.platform == "linux" and not multiprocessing.current_process().daemon
             and os.environ.get("HYBRIDHYST_WORKERS", "processes") != "threads" and _autograd_forks())
    if forks and _JOB is None:  # not from inside a worker's own item
        _JOB = (fn, items)
        pool = ProcessPoolExecutor(max_workers=min(workers, len(items)), initializer=_worker_setup,
                                   mp_context=multiprocessing.get_context("fork"))
        try:
            interrupts = {signal.SIGINT, signal.SIGTERM}
            held = signal.pthread_sigmask(signal.SIG_BLOCK, interrupts)  # the workers fork without the run's handler
            try:
                with warnings.catch_warnings():  # Python ≥ 3.12 warns of a fork beside threads; the workers take
                    warnings.filterwarnings("ignore", ".*fork", DeprecationWarning)  # no lock those threads hold
                    results = pool.map(_job_item, range(len(items)))
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, held)
            return list(bar(results, len(items)) if bar else results)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
            _JOB = None
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        results = pool.map(fn, items)
        return list(bar(results, len(items)) if bar else results)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


_JOB: tuple[Callable, list] | None = None  # side_by_side's (fn, items) while its forked workers run


def _autograd_forks() -> bool:
    """Whether a forked worker may run autograd (the fits' exact Jacobians take reverse-mode derivatives): not where
    torch sees a CUDA device, since once the parent has run a backward pass (identification does) torch refuses
    autograd in a forked child there (its device threads do not survive a fork); the workers are threads then."""
    return not torch.cuda.is_available()


def _worker_setup() -> None:
    """A forked worker: one thread for torch and for its compiled loops' rows (the workers share the cores), and
    the signals that interrupt a run left to its parent."""
    os.environ["HYBRIDHYST_FAST_THREADS"] = "1"
    torch.set_num_threads(1)
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})


def _job_item(i: int):
    fn, items = _JOB
    result = fn(items[i])
    try:  # what the parent will read: a result it could not rebuild would break the whole pool there
        ForkingPickler.loads(ForkingPickler.dumps(result))
    except Exception:  # noqa: BLE001 - any failure to send it back is a failed item
        return None
    return result


def _send_model(model):
    """How a model crosses between processes: its config and state dict (torch's parametrized modules, which the
    constraints are, pickle no other way). For multiprocessing's pickler only; ``copy.deepcopy`` is unchanged."""
    return rebuilt_model, (model_config(model), model.state_dict())


for _structure in STRUCTURES.values():
    ForkingPickler.register(_structure, _send_model)


def at(sim: SimulationSettings, fit: Fit) -> SimulationSettings:
    """Simulator settings for a fitted model (its own sub-steps per sample)."""
    return sim.at(fit.substeps)


def _problem(space, train, sim, substeps):
    return RecordsProblem(space, train, settings=sim.at(substeps))


def _space(model, train, **options) -> SearchSpace:
    """The search space of ``model`` with trend boxes sized by the training records' conditions; fitted trends
    get the boxes of a local refit (``SearchSpace``'s ``refit_trends``)."""
    return SearchSpace(model, condition_ranges=condition_ranges(train), refit_trends=True, **options)


def screened(train, samples: int | None = None):
    """The records a candidate's many-row phases fit on (the global search, the re-balance and the first round of
    joint LM, which pick the ``keep`` starts that go on): ``train`` itself while it holds at most ``samples``
    (default ``SCREEN_SAMPLES``) samples, else the leading part of each record, each cut to its share of
    ``samples`` (its warm-up kept), provided every part spans ``SCREEN_RANGE`` of its record's range (1st to 99th
    percentile) in the input, its rate, the response and every control channel; else ``train`` itself. The starts
    are told apart by their basins, which a part shows when it holds the amplitudes and speeds of the whole (a full
    period of a multisine, steady cycles, a drift); a part of an amplitude ramp or a frequency sweep does not (a
    LuGre basin chosen on the small, slow start of a ramp was the wrong one), and such records are fitted whole.
    The training records of every test bed case and of BRFD hold fewer samples (8004 at most), so their fits are as
    before; the Bouc–Wen benchmark's five times as many (five periods of its multisine)."""
    samples = SCREEN_SAMPLES if samples is None else int(samples)
    total = sum(len(r) for r in train)
    if total <= samples:
        return train
    parts = [r.slice(0, max(r.warmup + 2, math.ceil(len(r) * samples / total))) for r in train]
    return parts if all(_spans(p, r) for p, r in zip(parts, train)) else train


def _spans(part, record) -> bool:
    """Whether ``part`` (a leading slice of ``record``) spans ``SCREEN_RANGE`` of the record's range in every
    channel a fit reads or scores."""
    def channels(r):
        return [r.x, np.gradient(r.x, r.t), r.y, *r.controls.values()]

    def span(a):
        lo, hi = np.percentile(a, [1, 99])
        return hi - lo

    return all(span(a) >= SCREEN_RANGE * span(b) for a, b in zip(channels(part), channels(record)))


def _sse(problem: RecordsProblem, X: torch.Tensor) -> torch.Tensor:
    """SSE of each row of ``X (N, D)`` (inf where the simulation is not finite)."""
    with torch.no_grad():
        c = problem.cost(X)
    return torch.where(torch.isfinite(c), c * problem.n_samples, torch.full_like(c, math.inf))


def sse_at(fit: Fit, train, sim: SimulationSettings, substeps: int) -> float:
    """The training SSE of a fitted model simulated with ``substeps`` sub-steps (no refit): a candidate that
    needed finer steps is compared with the current model at the same resolution (the loop never asks for fewer
    than the model's own)."""
    if substeps == fit.substeps:
        return fit.sse
    space = _space(fit.model, train)
    x0 = space.initial().clamp(space.lower, space.upper)
    return float(_sse(_problem(space, train, sim, substeps), x0[None])[0])


def converged_lm(problem: RecordsProblem, space: SearchSpace, starts: torch.Tensor, lm_steps: int,
                 rounds: int = 4, rtol: float = 1e-3, free: torch.Tensor | None = None, keep: int = 3,
                 screen: RecordsProblem | None = None):
    """Batched LM in rounds of ``lm_steps`` iterations, continued while the best cost still falls by more
    than ``rtol`` (relative) per round, at most ``rounds`` rounds. A fixed budget can stop a fit halfway
    down a long valley (a new hysteretic state pulling the damping and stiffness with it); the next
    candidate would then get the credit for finishing it. Every start gets the first round; only the
    ``keep`` lowest then continue (the rows are most of the cost: each accepted step costs a Jacobian per
    row). Halving the rows within the first round too was tried and lost the LuGre basin of the independent
    test bed's ``lugre`` case (held-out 1.20 × noise, Fc 1.84 for 0.4). With ``screen`` (the problem on
    ``screened`` records; None or ``problem`` itself: no screen), every start's first round is on it; its rows are
    then simulated once on ``problem`` and the ``keep`` lowest there get a first round on it before the rounds go
    on. A leading part need not hold the whole record's speeds (an amplitude that grows within a record): a row
    fitted there can be cheap on it and unresolved on the rest, so the rows are chosen by their cost on every
    sample, and where none of them can be simulated on every sample the first round starts again there from every
    start, as without a screen."""
    if screen is not None and screen is not problem and starts.shape[0] > keep:
        first = levenberg_marquardt(screen.residuals, space, starts, iters=lm_steps, free=free, progress=False,
                                    jacobian_rows=screen.jacobian_rows, rtol=LM_RTOL)
        sse = _sse(problem, first.X)
        order = torch.argsort(sse)[:keep]
        order = order[torch.isfinite(sse[order])]
        if len(order):
            starts = first.X[order]
    lm = levenberg_marquardt(problem.residuals, space, starts, iters=lm_steps, free=free, progress=False,
                            jacobian_rows=problem.jacobian_rows, rtol=LM_RTOL)
    for _ in range(rounds - 1):
        if not math.isfinite(lm.cost):
            break
        rows = lm.X[torch.argsort(lm.costs)[:keep]]
        more = levenberg_marquardt(problem.residuals, space, rows, iters=lm_steps, free=free, progress=False,
                                  jacobian_rows=problem.jacobian_rows, rtol=LM_RTOL)
        done = more.cost > (1 - rtol) * lm.cost
        lm = more  # each row continues from its own end, so no row gets worse
        if done:
            break
    return lm


def search_points(space: SearchSpace, free: list[str], x0: torch.Tensor, n: int, seed: int = 0) -> torch.Tensor:
    """``n`` scrambled-Sobol points ``(n, D)`` over the box of the ``free`` coordinates, every other coordinate
    at ``x0``. Log scale where the space is, and for amplitudes bounded below by 0 (a gap, a friction excess)
    over the five decades below their upper bound: their size is unknown by orders of magnitude."""
    idx = [space.names.index(f) for f in free]
    X = x0.expand(n, -1).clone()
    if not idx:
        return X
    U = space.to_unit(x0[None]).expand(n, -1).clone()
    S = torch.quasirandom.SobolEngine(len(idx), scramble=True, seed=seed).draw(n).to(torch.float64)
    U[:, idx] = S
    X[:, idx] = space.from_unit(U)[:, idx]
    for j, i in enumerate(idx):
        lo, hi = float(space.lower[i]), float(space.upper[i])
        if lo == 0.0 and hi > 0 and not bool(space.log[i]):
            X[:, i] = hi * torch.pow(10.0, -5.0 * (1 - S[:, j]))
    return X


def fit_candidate(candidate, model, train, sim, lm_steps: int, box_factor: float, search: int = 24,
                  keep: int = 3) -> Fit | None:
    """Fit the model augmented by ``candidate`` with every coordinate free; None if nothing simulates.

    1. *Global search over the new coordinates*: ``search`` Sobol points over the box of its new coordinates
       (a gap, a Stribeck speed, a drift scale make non-convex costs that a local fit from a wrong start
       misses), the fitted coordinates held, in one batched evaluation; the ``keep`` best join the
       candidate's heuristic starts (and the fitted model itself, for effects with neutral values).
    2. *Re-balance*: from every start, ``lm_steps // 2`` LM iterations move only the fitted
       coordinates (a new element's stiffness is given up by the old spring), so the joint fit starts near
       the fitted response instead of in another basin.
    3. *Joint LM* from those rows, continued until converged.
    On long records (more than ``SCREEN_SAMPLES``) 1., 2. and the first round of 3. fit the leading part of each
    (``screened``): they only choose the ``keep`` rows that go on, which are then fitted on every sample.
    4. *Edges followed*: a fitted constant left at an edge of its box is followed (``_followed``); then the
       step-doubling check (``resolve``).
    """
    aug = candidate.build(model)
    space = _space(aug, train, bounds=candidate.bounds, factor=box_factor)
    problem = _problem(space, train, sim, sim.substeps)
    part = screened(train)
    screen = problem if part is train else _problem(space, part, sim, sim.substeps)
    x0 = space.initial().clamp(space.lower, space.upper)
    current = dict(zip(space.names, x0.tolist()))
    starts = torch.tensor([[s.get(n, current[n]) for n in space.names] for s in candidate.starts],
                          dtype=torch.float64).clamp(space.lower, space.upper)
    if search:  # the heuristic starts stay; the search adds its ``keep`` best points
        points = search_points(space, candidate.free, x0, search)
        costs = _sse(screen, points)
        order = torch.argsort(costs)[:keep]
        starts = torch.cat([starts, points[order[torch.isfinite(costs[order])]]])
    old = torch.tensor([n not in candidate.free for n in space.names])
    if bool(old.any()):  # each start both as it is and re-balanced (a re-balance can also lead astray)
        balanced = levenberg_marquardt(screen.residuals, space, starts, iters=max(lm_steps // 2, 1), free=old,
                                       progress=False, jacobian_rows=screen.jacobian_rows, rtol=LM_RTOL).X
        starts = torch.cat([starts, balanced])
    lm = converged_lm(problem, space, starts, lm_steps, screen=screen)
    if not math.isfinite(lm.cost):
        return None
    space, x = _followed(space, candidate, train, sim, lm, lm_steps, box_factor)
    fit = resolve(space, train, sim, x, lm_steps)
    return fit if fit is not None and math.isfinite(fit.sse) else None


def _followed(space: SearchSpace, candidate, train, sim, lm, lm_steps: int, box_factor: float):
    """``(space, x)`` of a candidate's fit after following the edges of its box. The fitted constants' boxes are
    ``box_factor`` about their values before the candidate: one the nominal pushed to an edge to stand in for the
    missing effect (a damping driven to its floor because friction falls with speed) cannot return to its value
    once that effect is in. While such a constant ends at an edge, the fit continues (LM from its end) in boxes
    centred on the values reached, the candidate's own boxes kept, while a pass lowers the cost by at least 1 %
    (``EDGE_GAIN``) in its first ``EDGE_PROBE`` iterations (then it runs until converged), at most ``EDGE_PASSES``
    passes (identify's ``recentre`` does the same for a first fit)."""
    constants = {c.name for c in space.coordinates if c.name == f"{c.effect}.{c.param}"}
    x, cost = lm.x, lm.cost
    for _ in range(EDGE_PASSES):
        edges = [n for n in at_bounds(space, x) if n in constants and n not in candidate.free]
        if not edges:
            break
        space.to_model(x)
        try:
            wider = _space(space.model, train, bounds=candidate.bounds, factor=box_factor)
            x0 = wider.initial().clamp(wider.lower, wider.upper)
            if set(edges) <= set(at_bounds(wider, x0)):  # a domain's own limit: no box can move past it
                break
            problem = _problem(wider, train, sim, sim.substeps)
            # a few iterations first: most edges are a constant the new element made redundant, running off
            # towards zero for next to nothing, and are left there at the cost of those iterations alone
            probe = levenberg_marquardt(problem.residuals, wider, x0[None], iters=EDGE_PROBE, progress=False,
                                        jacobian_rows=problem.jacobian_rows, rtol=LM_RTOL)
            if not (math.isfinite(probe.cost) and probe.cost < EDGE_GAIN * cost):
                break
            again = converged_lm(problem, wider, probe.X, lm_steps)
        except (ValueError, RuntimeError):  # a box that cannot be built or a pass that cannot be simulated: the
            break  # fit before it stands
        space, x, cost = wider, again.x, again.cost
    space.to_model(x)
    return space, x


def polish(model, train, sim, lm_steps: int, box_factor: float, step_doubling: bool = True) -> Fit:
    """Refit the current model (every coordinate, LM from its values) so that its training error is
    converged the same way each candidate's is: a candidate then gets credit only for what it adds, not
    for finishing the previous fit. The model is updated in place. With ``step_doubling``, the sub-steps are first
    halved while the model at its values stays resolved (``simulate.coarsest_substeps``: a change to the model,
    such as a stiff element removed or given up, may have made ``sim``'s unnecessary, and every later candidate
    is fitted at the current model's), then doubled after the fit while it needs finer ones (``resolve``).
    ``step_doubling=False`` keeps ``sim``'s sub-steps (a refit of an already resolved model on part of its
    records)."""
    if step_doubling and sim.substeps > 1:
        sim = sim.at(coarsest_substeps(model, train, sim.substeps, settings=sim))
    space = _space(model, train, factor=box_factor)
    problem = _problem(space, train, sim, sim.substeps)
    x0 = space.initial().clamp(space.lower, space.upper)
    sse0 = float(_sse(problem, x0[None])[0])
    lm = converged_lm(problem, space, x0[None], lm_steps)
    improved = math.isfinite(lm.cost) and lm.cost * problem.n_samples <= sse0
    x, sse = (lm.x, lm.cost * problem.n_samples) if improved else (x0, sse0)
    if not step_doubling:
        return _fit(space, x, sse, sim.substeps)
    fit = resolve(space, train, sim, x, lm_steps)
    return fit if fit is not None else _fit(space, x0, sse0, sim.substeps)  # else the model as it was


def _fit(space: SearchSpace, x: torch.Tensor, sse: float, substeps: int) -> Fit:
    """The fit at coordinates ``x`` (written into the space's model)."""
    space.to_model(x)
    return Fit(space.model, sse, space.dim, dict(zip(space.names, x.tolist())), substeps)


def resolve(space: SearchSpace, train, sim, x: torch.Tensor, lm_steps: int) -> Fit | None:
    """Step doubling (``simulate.resolved_substeps``, the check every app uses): while halving the step changes
    the fitted response by more than ``simulate.api.RESOLVED``, double the sub-steps per sample (at most
    ``MAX_SUBSTEPS``) and refit from the fitted point. A stiff state (a presliding Dahl or LuGre bristle, a
    sharp Bouc–Wen loop) fitted on a coarse grid is otherwise shaped by the integrator's error, not by the
    data; the user never chooses sub-steps per data set. The doubling starts from the fewest sub-steps that
    resolve the fitted point (``simulate.coarsest_substeps``, halving ``sim``'s): a fit that gave a stiff element
    up (an element replaced by its special case, a level fitted away) leaves the finer steps it was fitted at to
    no later fit."""
    space.to_model(x)

    def refit(substeps: int) -> None:
        nonlocal x
        lm = converged_lm(_problem(space, train, sim, substeps), space, x[None], lm_steps)
        if math.isfinite(lm.cost):
            x = lm.x
        space.to_model(x)

    coarse = coarsest_substeps(space.model, train, sim.substeps, settings=sim)
    substeps, _ = resolved_substeps(space.model, train, settings=sim, substeps=coarse, max_substeps=MAX_SUBSTEPS,
                                    refit=refit)
    sse = float(_sse(_problem(space, train, sim, substeps), x[None])[0])
    return _fit(space, x, sse, substeps) if math.isfinite(sse) else None


def fit_candidates(cands, model, train, sim, lm_steps, box_factor, workers: int = 1, bar: Callable | None = None,
                   search: int = 24, keep: int = 3) -> list:
    """``[(candidate, Fit or None)]`` in the candidates' order: each fitted (``fit_candidate``, with its ``search``
    and ``keep``), ``workers`` at a time; a candidate that cannot be simulated gets None. ``bar(items, what,
    total)``: a progress bar, or None."""
    def one(cand):
        try:
            return fit_candidate(cand, model, train, sim, lm_steps, box_factor, search=search, keep=keep)
        except (ValueError, RuntimeError):  # a candidate that cannot be simulated is skipped
            return None

    fits = side_by_side(one, cands, workers, bar and (lambda items, n: bar(items, "rank candidates", total=n)))
    return list(zip(cands, fits))


def prebuild(cands, model, controls: tuple[str, ...] = ()) -> None:
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


def refit_on(model, records, sim: SimulationSettings, lm_steps: int, box_factor: float):
    """A copy of ``model`` with every coordinate refitted on ``records`` (LM from its values); its settings."""
    f = polish(copy.deepcopy(model), records, sim, lm_steps, box_factor)
    return f.model, at(sim, f)
