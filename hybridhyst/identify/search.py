"""Population-based global search whose whole population is one batched objective call.

``objective(X) -> costs`` takes a population ``X (N, D)`` of coordinates (float64) and returns ``(N,)``
costs; in ``identify`` it is one ``simulate(..., values=..., backend="fast")`` over population × records.
The searches — differential evolution (``scipy.optimize.differential_evolution``, vectorised), CMA-ES (the
``cma`` package's ask/tell with IPOP restarts, samples reflected into the box), Monte Carlo (uniform random
sampling, seed 002) and a systematic grid (seed 004) — work in the unit cube of the search box (log scale
for wide positive coordinates, see ``space.Box``), are reproducible with ``seed`` (a NumPy ``Generator``
drives every random choice), stop early at ``target`` and treat members whose cost is NaN/inf, or whose
evaluation raises, as infinitely bad: they never crash the search. The evolutionary algorithms are the
libraries' reference implementations: a side-by-side run of ``scripts/bench_identify.py`` (section (5),
experiments/performance) found them as good as the hand-written DE and CMA-ES they replaced (git 9e504ee),
or better.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from ..progress import progress as progress_bar
from .space import Box

__all__ = ["SearchResult", "cma_es", "differential_evolution", "grid_search", "monte_carlo", "safe_costs"]

Objective = Callable[[torch.Tensor], torch.Tensor]


@dataclass
class SearchResult:
    """Outcome of a global search.

    Attributes
    ----------
    x : best coordinates ``(D,)``; cost : its cost.
    population, costs : final population ``(N, D)`` (coordinates) and its costs ``(N,)``, best first.
    history : best cost after each generation; evaluations : objective rows evaluated.
    generations : generations run; non_finite : members that got an infinite cost.
    """

    x: torch.Tensor
    cost: float
    population: torch.Tensor
    costs: torch.Tensor
    history: list[float] = field(default_factory=list)
    evaluations: int = 0
    generations: int = 0
    non_finite: int = 0


def safe_costs(objective: Objective, X: torch.Tensor) -> torch.Tensor:
    """``objective(X)`` with NaN/inf → +inf; if the batch call raises, members are scored one by one.

    A member whose own evaluation raises (``ArithmeticError``, ``ValueError``, ``RuntimeError``) gets +inf.
    """
    try:
        with torch.no_grad():
            c = torch.as_tensor(objective(X), dtype=torch.float64).reshape(-1)
    except (ArithmeticError, ValueError, RuntimeError):
        if X.shape[0] == 1:
            return torch.full((1,), math.inf, dtype=torch.float64)
        c = torch.cat([safe_costs(objective, X[i:i + 1]) for i in range(X.shape[0])])
    if c.shape[0] != X.shape[0]:
        raise ValueError(f"objective returned {c.shape[0]} costs for {X.shape[0]} members")
    return torch.where(torch.isfinite(c), c, torch.full_like(c, math.inf))


def _as_box(space) -> Box:
    if isinstance(space, Box):
        return space
    lower, upper = space
    return Box(lower, upper)


def _latin_hypercube(rng: np.random.Generator, n: int, d: int) -> np.ndarray:
    cut = (np.arange(n)[:, None] + rng.random((n, d))) / n
    for j in range(d):
        cut[:, j] = cut[rng.permutation(n), j]
    return cut


def _finish(box: Box, U: np.ndarray, costs: np.ndarray, history, evals, gens, bad) -> SearchResult:
    order = np.argsort(costs, kind="stable")
    X = box.from_unit(torch.as_tensor(U[order]))
    c = torch.as_tensor(costs[order])
    return SearchResult(x=X[0], cost=float(c[0]), population=X, costs=c, history=history, evaluations=evals,
                        generations=gens, non_finite=bad)


class _Scorer:
    """Scores batches through ``safe_costs``, one objective call per batch: unit-cube points ``U (N, D)``
    (``__call__``, the population searches) or coordinates ``X (N, D)`` (``coords``, the sampling searches).

    Counts rows (``evaluations``), batches and non-finite members, keeps the best cost seen (and, for
    unit-cube batches, its point ``best_u``) and the best-so-far ``history`` (one entry per batch), and
    advances the progress bar by one per batch (by one per row with ``rows=True``).
    """

    def __init__(self, objective: Objective, box: Box, bar, rows: bool = False):
        self.objective, self.box, self.bar, self.rows = objective, box, bar, rows
        self.evaluations = self.batches = self.non_finite = 0
        self.best, self.best_u, self.history = math.inf, None, []

    def coords(self, X: torch.Tensor) -> tuple[torch.Tensor, int | None]:
        """Costs ``(N,)`` of coordinates ``X``, and the row that improved on the best so far (None if none)."""
        c = safe_costs(self.objective, X)
        first = self.batches == 0
        self.evaluations, self.batches = self.evaluations + X.shape[0], self.batches + 1
        self.non_finite += int(torch.isinf(c).sum())
        i = int(torch.argmin(c))
        improved = first or float(c[i]) < self.best
        if improved:
            self.best = float(c[i])
        self.history.append(self.best)
        self.bar.update(X.shape[0] if self.rows else 1)
        self.bar.set_postfix(cost=f"{self.best:.4g}")
        return c, (i if improved else None)

    def __call__(self, U: np.ndarray) -> np.ndarray:
        U = np.asarray(U, dtype=np.float64)  # the searches keep members in the box (reflection, scipy, cma)
        costs, i = self.coords(self.box.from_unit(torch.as_tensor(U)))
        if i is not None:
            self.best_u = U[i].copy()
        return costs.numpy()

    def reached(self, target: float | None) -> bool:
        return target is not None and self.best <= target


# scipy.optimize.differential_evolution's mutation strategies (binomial and exponential crossover)
DE_STRATEGIES = ("best1bin", "rand1bin", "randtobest1bin", "currenttobest1bin", "best2bin", "rand2bin",
                 "best1exp", "rand1exp", "randtobest1exp", "currenttobest1exp", "best2exp", "rand2exp")


def differential_evolution(objective: Objective, space, *, pop: int | None = None, generations: int = 200,
                           F: float | tuple[float, float] = (0.5, 1.0), CR: float = 0.9,
                           strategy: str = "best1bin", seed: int = 0, target: float | None = None,
                           init: torch.Tensor | None = None, progress: bool = True) -> SearchResult:
    """Differential evolution (Storn & Price 1997): ``scipy.optimize.differential_evolution`` with the whole
    population as one batched objective call per generation (``vectorized=True, updating='deferred'``).

    scipy works in the unit cube of the box (bounds [0, 1]; a mutant outside is redrawn uniformly there); the
    initial population is a Latin hypercube drawn from ``seed``, with ``init`` placed in it; scipy's local
    polish is off (``identify`` refines the best members itself) and so is its convergence test, so the
    search runs ``generations`` unless it reaches ``target``.

    Parameters
    ----------
    objective : ``X (N, D) -> (N,)`` costs, one call per generation (plus one for the initial population).
    space : a ``SearchSpace``/``Box`` or ``(lower, upper)``.
    pop : population size, at least 5 (default ``max(16, 5 D)``); generations : at most this many.
    F : differential weight, or an interval it is drawn from each generation (dither); CR : crossover rate.
    strategy : one of scipy's ``DE_STRATEGIES``: ``"best1bin"`` (fast on smooth fits), ``"rand1bin"`` (more
        exploratory), ...
    seed : random seed; the same seed gives the same result. target : stop when the best cost ≤ target.
    init : optional members ``(M, D)`` (coordinates) placed in the initial population.

    Returns
    -------
    SearchResult with scipy's final population (best first); ``evaluations`` = pop × (generations run + 1).
    """
    from scipy.optimize import differential_evolution as scipy_de

    if strategy not in DE_STRATEGIES:
        raise ValueError(f"unknown strategy {strategy!r}; choose one of {', '.join(DE_STRATEGIES)}")
    box = _as_box(space)
    rng = np.random.default_rng(seed)
    N = int(pop or max(16, 5 * box.dim))
    if N < 5:
        raise ValueError(f"differential evolution needs a population of at least 5, got {N}")
    U = _latin_hypercube(rng, N, box.dim)
    if init is not None:
        start = box.to_unit(torch.as_tensor(init, dtype=torch.float64).reshape(-1, box.dim)).numpy()
        U[: len(start)] = np.clip(start[:N], 0, 1)
    with progress_bar(total=int(generations) + 1, desc="differential evolution", enabled=progress) as bar:
        score = _Scorer(objective, box, bar)
        first = [score(U)]  # the initial population is scored here, so a target it meets ends the search
        if score.reached(target) or int(generations) < 1:
            return _finish(box, U, first[0], score.history, score.evaluations, 0, score.non_finite)

        def batch(UT: np.ndarray) -> np.ndarray:  # scipy passes the population as (D, S) and wants (S,)
            known = first.pop() if first else None  # scipy's first call is the initial population, scored above
            if known is not None and UT.shape == U.T.shape and np.allclose(UT.T, U, rtol=0.0, atol=1e-12):
                return known
            return score(UT.T)

        def stop(x, convergence=None) -> bool:  # scipy's DE callback; True ends the search
            return score.reached(target)

        # seed= (not rng=, scipy >= 1.15) keeps scipy 1.10 working; a Generator given as seed is used as is
        res = scipy_de(batch, [(0.0, 1.0)] * box.dim, strategy=strategy, maxiter=int(generations), init=U,
                       mutation=F, recombination=CR, seed=rng, tol=0.0, atol=0.0, polish=False,
                       vectorized=True, updating="deferred", callback=stop)
    return _finish(box, res.population, np.asarray(res.population_energies), score.history,
                   score.evaluations, score.batches - 1, score.non_finite)


def _reflect(U) -> np.ndarray:
    """Fold points into the unit cube: reflection at 0 and 1, as often as it takes (period 2)."""
    U = np.abs(np.asarray(U, dtype=np.float64)) % 2.0
    return np.where(U > 1.0, 2.0 - U, U)


def cma_es(objective: Objective, space, *, pop: int | None = None, generations: int = 200, sigma0: float = 0.3,
           restarts: int = 9, boundary: str = "reflect", seed: int = 0, target: float | None = None,
           init: torch.Tensor | None = None, progress: bool = True) -> SearchResult:
    """IPOP-CMA-ES (Hansen & Ostermeier 2001; restarts with a doubled population, Auger & Hansen 2005) on the
    ``cma`` package's ``CMAEvolutionStrategy``, ask/tell, one batched objective call per generation.

    The search runs in the unit cube of the box; every evaluated member lies in the box. The first run starts
    at ``init``'s first row (default the box centre); when a run stops (cma's own criteria: flat fitness, tolx,
    stagnation, ...) the next starts at a uniformly random point with twice the population, until the budget of
    ``pop × generations`` evaluations would be exceeded, ``restarts`` restarts are done or ``target`` is
    reached. cma's console and file output is off.

    Parameters
    ----------
    objective : ``X (N, D) -> (N,)`` costs, one call per generation.
    space : a ``SearchSpace``/``Box`` or ``(lower, upper)``.
    pop : population of the first run (default cma's ``4 + ⌊3 ln D⌋``, at least 8); generations : the budget
        in generations of that population. sigma0 : initial step size in unit-cube coordinates.
    restarts : at most this many restarts.
    boundary : ``"reflect"`` (default): samples are reflected into the cube and cma is told the reflected
        points (cma treats them as repaired solutions); ``"transform"``: cma's own ``BoundTransform``
        (``bounds=[0, 1]``). On the seed 001 Bouc–Wen loop the transform came near the noise floor in 6/10
        (tight box) and 1/10 (wide box) searches against 10/10 and 6/10 reflected (``scripts/bench_identify.py``,
        section (5)); it flattens the cost next to the bounds, where fits of that law often end up.
    seed : random seed (drives cma's sampling through ``randn``; the global NumPy state is not touched).
    target : stop when the best cost ≤ target.
    init : optional start point(s) ``(M, D)`` (coordinates); the first row is the first run's mean.

    Returns
    -------
    SearchResult whose population is the best member of each run and the last generation, best first;
    ``generations`` counts every generation of every run, ``evaluations`` the rows they scored.
    """
    import cma

    box = _as_box(space)
    D = box.dim
    lam = int(pop or max(8, 4 + int(3 * math.log(D))))
    budget = lam * int(generations)
    rng = np.random.default_rng(seed)
    x0 = np.full(D, 0.5) if init is None else \
        np.clip(box.to_unit(torch.as_tensor(init, dtype=torch.float64).reshape(-1, D)).numpy()[0], 0, 1)
    if boundary not in ("reflect", "transform"):
        raise ValueError(f"unknown boundary handling {boundary!r}; choose 'reflect' or 'transform'")
    options = {"verbose": -9, "verb_disp": 0, "verb_log": 0, "seed": np.nan,
               "randn": lambda *shape: rng.standard_normal(shape), "ftarget": -math.inf if target is None else target,
               "bounds": [0.0, 1.0] if boundary == "transform" else [None, None]}
    into_box = _reflect if boundary == "reflect" else np.asarray
    U_keep, c_keep = [], []
    last_U, last_c = np.empty((0, D)), np.empty(0)
    with progress_bar(total=int(generations), desc="CMA-ES", enabled=progress) as bar:
        score = _Scorer(objective, box, bar)
        for run in range(int(restarts) + 1):
            size = lam * 2**run
            if score.evaluations + size > budget or score.reached(target):
                break
            start = x0 if run == 0 else rng.random(D)
            es = cma.CMAEvolutionStrategy(start, float(sigma0), {**options, "popsize": size})
            while not es.stop() and score.evaluations + size <= budget and not score.reached(target):
                last_U = into_box(es.ask())
                last_c = score(last_U)
                es.tell(list(last_U), last_c.tolist())
            if es.result.xbest is not None:
                U_keep.append(np.asarray(es.result.xbest))
                c_keep.append(float(es.result.fbest))
    if score.best_u is None:
        raise ValueError(f"cma_es got a budget of {budget} evaluations, less than one generation of {lam}; "
                         "raise pop or generations")
    if not U_keep:  # no run saw a finite cost
        U_keep, c_keep = [score.best_u], [score.best]
    U_all, c_all = np.vstack([np.stack(U_keep), last_U]), np.concatenate([c_keep, last_c])
    return _finish(box, U_all, c_all, score.history, score.evaluations, score.batches, score.non_finite)


class _Best:
    """The ``keep`` lowest-cost members seen so far (coordinates), for batch-wise searches."""

    def __init__(self, keep: int, dim: int):
        self.keep = int(keep)
        self.X, self.c = torch.empty(0, dim, dtype=torch.float64), torch.empty(0, dtype=torch.float64)

    def add(self, X: torch.Tensor, c: torch.Tensor) -> None:
        X, c = torch.cat([self.X, X.to(torch.float64)]), torch.cat([self.c, c])
        order = torch.as_tensor(np.argsort(c.numpy(), kind="stable")[: self.keep])
        self.X, self.c = X[order], c[order]

    def result(self, history, evals, batches, bad) -> SearchResult:
        return SearchResult(x=self.X[0], cost=float(self.c[0]), population=self.X, costs=self.c, history=history,
                            evaluations=evals, generations=batches, non_finite=bad)


def _batched(objective, box: Box, batches, total: int, desc: str, keep: int, target, progress) -> SearchResult:
    """Score coordinate batches in turn, keeping the best ``keep``; stop at ``target``."""
    best = _Best(keep, box.dim)
    with progress_bar(total=total, desc=desc, enabled=progress) as bar:
        score = _Scorer(objective, box, bar, rows=True)
        for X in batches:
            best.add(X, score.coords(X)[0])
            if score.reached(target):
                break
    return best.result(score.history, score.evaluations, score.batches, score.non_finite)


def monte_carlo(objective: Objective, space, *, samples: int = 1024, batch: int = 256, seed: int = 0,
                target: float | None = None, init: torch.Tensor | None = None, keep: int = 64,
                progress: bool = True) -> SearchResult:
    """Monte Carlo search: ``samples`` points drawn uniformly in the box, scored ``batch`` at a time.

    Seed 002's identification ("random inputs over the uniform domain ... selecting the best solution").
    Uniform in the unit cube of the box, i.e. uniform in each coordinate, or in its logarithm where the
    box searches a log scale (a ``Box`` built without ``log`` is uniform in every coordinate).

    Parameters
    ----------
    objective : ``X (N, D) -> (N,)`` costs, one call per batch.
    space : a ``SearchSpace``/``Box`` or ``(lower, upper)``.
    samples : points drawn (the budget); batch : points per objective call.
    seed : random seed (same seed, same points); target : stop when the best cost ≤ target.
    init : optional members ``(M, D)`` (coordinates) scored first, in addition to the samples.
    keep : the best members returned as ``population`` (best first); ``history`` is the best cost after
        each batch, ``generations`` the number of batches.
    """
    box = _as_box(space)
    if int(samples) < 1 or int(batch) < 1 or int(keep) < 1:
        raise ValueError(f"monte_carlo needs samples, batch and keep >= 1, got {samples}, {batch}, {keep}")
    rng = np.random.default_rng(seed)

    def batches():
        if init is not None:
            yield torch.as_tensor(init, dtype=torch.float64).reshape(-1, box.dim)
        for start in range(0, int(samples), int(batch)):
            n = min(int(batch), int(samples) - start)
            yield box.from_unit(torch.as_tensor(rng.random((n, box.dim))))

    extra = 0 if init is None else torch.as_tensor(init).reshape(-1, box.dim).shape[0]
    return _batched(objective, box, batches(), int(samples) + extra, "Monte Carlo", keep, target, progress)


def grid_search(objective: Objective, space, *, points: int | Sequence[int] = 5,
                levels: Sequence[Sequence[float]] | None = None, batch: int = 1024, target: float | None = None,
                keep: int = 64, progress: bool = True) -> SearchResult:
    """Systematic search: every point of a grid over the box, scored ``batch`` at a time (seed 004).

    Parameters
    ----------
    objective : ``X (N, D) -> (N,)`` costs, one call per batch.
    space : a ``SearchSpace``/``Box`` or ``(lower, upper)``.
    points : points per coordinate (one int for all, or one per coordinate, each >= 2), evenly spaced in
        the unit cube of the box from bound to bound (so geometrically spaced on log-scale coordinates).
    levels : explicit grid values per coordinate (``D`` sequences, in coordinates); replaces ``points``
        (e.g. a paper's step sizes: ``a`` in steps of 0.01, ``n`` integer).
    batch : grid points per objective call; target : stop when the best cost ≤ target.
    keep : the best members returned as ``population`` (best first); the grid is enumerated lazily (the
        last coordinate varies fastest), so its size is limited by time, not memory.
    """
    box = _as_box(space)
    if levels is not None:
        axes = [np.asarray(v, dtype=np.float64).reshape(-1) for v in levels]
        if len(axes) != box.dim or any(len(a) < 1 for a in axes):
            raise ValueError(f"levels must give at least one value for each of the {box.dim} coordinates, "
                             f"got {[len(a) for a in axes]}")
        to_coords = lambda G: torch.as_tensor(G)  # noqa: E731
    else:
        counts = [int(points)] * box.dim if np.isscalar(points) else [int(p) for p in points]
        if len(counts) != box.dim or min(counts) < 2:
            raise ValueError(f"points must be >= 2 for each of the {box.dim} coordinates, got {points}")
        axes = [np.linspace(0.0, 1.0, k) for k in counts]
        to_coords = lambda G: box.from_unit(torch.as_tensor(G))  # noqa: E731
    if int(batch) < 1 or int(keep) < 1:
        raise ValueError(f"grid_search needs batch and keep >= 1, got {batch}, {keep}")
    shape = tuple(len(a) for a in axes)
    total = math.prod(shape)

    def batches():
        for start in range(0, total, int(batch)):
            idx = np.unravel_index(np.arange(start, min(start + int(batch), total)), shape)
            yield to_coords(np.stack([a[i] for a, i in zip(axes, idx)], axis=1))

    return _batched(objective, box, batches(), total, "grid search", keep, target, progress)
