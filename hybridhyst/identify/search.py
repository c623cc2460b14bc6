"""Population-based global search whose whole population is one batched objective call.

``objective(X) -> costs`` takes a population ``X (N, D)`` of coordinates (float64) and returns ``(N,)``
costs; in ``identify`` it is one ``simulate(..., values=..., backend="fast")`` over population × records.
The searches — differential evolution, CMA-ES, Monte Carlo (uniform random sampling, seed 002) and a
systematic grid (seed 004) — work in the unit cube of the search box (log scale for wide positive
coordinates, see ``space.Box``), are reproducible with ``seed`` (a NumPy ``Generator`` drives every random
choice), stop early at ``target`` and treat members whose cost is NaN/inf, or whose evaluation raises, as
infinitely bad: they never crash the search.
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


def _score(objective, box: Box, U: np.ndarray) -> np.ndarray:
    return safe_costs(objective, box.from_unit(torch.as_tensor(U))).numpy()


def _de_trials(rng, U, costs, F, CR, strategy):
    """Mutation (rand/1 or best/1, F dithered per generation) and binomial crossover; bounce-back repair."""
    N, D = U.shape
    idx = np.array([rng.choice(np.delete(np.arange(N), i), 3, replace=False) for i in range(N)])
    f = rng.uniform(*F) if isinstance(F, tuple) else F
    base = U[np.argmin(costs)][None] if strategy == "best1bin" else U[idx[:, 2]]
    mutant = base + f * (U[idx[:, 0]] - U[idx[:, 1]])
    cross = rng.random((N, D)) < CR
    cross[np.arange(N), rng.integers(0, D, N)] = True
    trial = np.where(cross, mutant, U)
    low, high = trial < 0, trial > 1  # bounce back between the parent and the violated bound
    trial = np.where(low, U * rng.random((N, D)), trial)
    return np.where(high, U + (1 - U) * rng.random((N, D)), trial)


def differential_evolution(objective: Objective, space, *, pop: int | None = None, generations: int = 200,
                           F: float | tuple[float, float] = (0.5, 1.0), CR: float = 0.9,
                           strategy: str = "best1bin", seed: int = 0, target: float | None = None,
                           init: torch.Tensor | None = None, progress: bool = True) -> SearchResult:
    """Differential evolution with a batched population.

    Parameters
    ----------
    objective : ``X (N, D) -> (N,)`` costs, one call per generation.
    space : a ``SearchSpace``/``Box`` or ``(lower, upper)``.
    pop : population size (default ``max(16, 5 D)``); generations : at most this many.
    F : differential weight, or an interval it is drawn from each generation (dither); CR : crossover rate.
    strategy : ``"best1bin"`` (fast on smooth fits) or ``"rand1bin"`` (more exploratory).
    seed : random seed; the same seed gives the same result. target : stop when the best cost ≤ target.
    init : optional members ``(M, D)`` (coordinates) placed in the initial population.
    """
    if strategy not in ("best1bin", "rand1bin"):
        raise ValueError(f"unknown strategy {strategy!r}; choose 'best1bin' or 'rand1bin'")
    box = _as_box(space)
    rng = np.random.default_rng(seed)
    N = int(pop or max(16, 5 * box.dim))
    if N < 4:
        raise ValueError(f"differential evolution needs a population of at least 4, got {N}")
    U = _latin_hypercube(rng, N, box.dim)
    if init is not None:
        start = box.to_unit(torch.as_tensor(init, dtype=torch.float64).reshape(-1, box.dim)).numpy()
        U[: len(start)] = np.clip(start[:N], 0, 1)
    costs = _score(objective, box, U)
    bad, history, gens = int(np.isinf(costs).sum()), [float(costs.min())], 0
    with progress_bar(total=generations, desc="differential evolution", enabled=progress) as bar:
        while gens < generations and not (target is not None and history[-1] <= target):
            trial = _de_trials(rng, U, costs, F, CR, strategy)
            tc = _score(objective, box, trial)
            bad += int(np.isinf(tc).sum())
            better = tc <= costs
            U[better], costs[better] = trial[better], tc[better]
            history.append(float(costs.min()))
            gens += 1
            bar.update(1)
            bar.set_postfix(cost=f"{history[-1]:.4g}")
    return _finish(box, U, costs, history, N * (gens + 1), gens, bad)


@dataclass
class _CMAState:
    mean: np.ndarray
    sigma: float
    C: np.ndarray
    pc: np.ndarray
    ps: np.ndarray


def _cma_weights(lam: int, D: int) -> dict:
    mu = lam // 2
    w = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
    w /= w.sum()
    mueff = 1.0 / np.sum(w**2)
    cc = (4 + mueff / D) / (D + 4 + 2 * mueff / D)
    cs = (mueff + 2) / (D + mueff + 5)
    c1 = 2 / ((D + 1.3) ** 2 + mueff)
    cmu = min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((D + 2) ** 2 + mueff))
    damps = 1 + 2 * max(0.0, math.sqrt((mueff - 1) / (D + 1)) - 1) + cs
    chi = math.sqrt(D) * (1 - 1 / (4 * D) + 1 / (21 * D**2))
    return dict(mu=mu, w=w, mueff=mueff, cc=cc, cs=cs, c1=c1, cmu=cmu, damps=damps, chi=chi)


def _cma_update(s: _CMAState, Y: np.ndarray, order: np.ndarray, p: dict, gen: int) -> None:
    """Standard (μ/μ_w, λ) update of mean, paths, covariance and step size (Hansen 2016, tutorial)."""
    D = s.mean.shape[0]
    ysel = Y[order[: p["mu"]]]
    yw = p["w"] @ ysel
    s.mean = s.mean + s.sigma * yw
    vals, vecs = np.linalg.eigh(s.C)
    inv_sqrt = vecs @ np.diag(1 / np.sqrt(np.maximum(vals, 1e-300))) @ vecs.T
    s.ps = (1 - p["cs"]) * s.ps + math.sqrt(p["cs"] * (2 - p["cs"]) * p["mueff"]) * (inv_sqrt @ yw)
    norm_ps = np.linalg.norm(s.ps)
    hsig = norm_ps / math.sqrt(1 - (1 - p["cs"]) ** (2 * gen)) / p["chi"] < 1.4 + 2 / (D + 1)
    s.pc = (1 - p["cc"]) * s.pc + hsig * math.sqrt(p["cc"] * (2 - p["cc"]) * p["mueff"]) * yw
    rank_mu = (ysel.T * p["w"]) @ ysel
    delta = (1 - hsig) * p["cc"] * (2 - p["cc"])
    s.C = (1 - p["c1"] - p["cmu"]) * s.C + p["c1"] * (np.outer(s.pc, s.pc) + delta * s.C) + p["cmu"] * rank_mu
    s.C = (s.C + s.C.T) / 2
    s.sigma *= math.exp((p["cs"] / p["damps"]) * (norm_ps / p["chi"] - 1))


def cma_es(objective: Objective, space, *, pop: int | None = None, generations: int = 200, sigma0: float = 0.3,
           seed: int = 0, target: float | None = None, init: torch.Tensor | None = None,
           progress: bool = True) -> SearchResult:
    """CMA-ES in the unit cube of the search box, one batched objective call per generation.

    Samples outside the cube are reflected back into it before evaluation (and used reflected in the
    update). Parameters as for ``differential_evolution``; ``pop`` defaults to ``4 + 3 ln D`` rounded up
    to at least 8, ``sigma0`` is the initial step size in unit-cube coordinates, ``init`` one start point
    (default the centre of the box).
    """
    box = _as_box(space)
    D = box.dim
    lam = int(pop or max(8, 4 + int(3 * math.log(D))))
    p = _cma_weights(lam, D)
    rng = np.random.default_rng(seed)
    mean = np.full(D, 0.5) if init is None else \
        np.clip(box.to_unit(torch.as_tensor(init).reshape(1, D)).numpy()[0], 0, 1)
    s = _CMAState(mean=mean, sigma=float(sigma0), C=np.eye(D), pc=np.zeros(D), ps=np.zeros(D))
    best_u, best_c, history, bad, gen = mean.copy(), math.inf, [], 0, 0
    last_U, last_c = mean[None], np.array([math.inf])
    with progress_bar(total=generations, desc="CMA-ES", enabled=progress) as bar:
        for gen in range(1, generations + 1):
            vals, vecs = np.linalg.eigh(s.C)
            Z = rng.standard_normal((lam, D))
            U = s.mean + s.sigma * Z @ (vecs * np.sqrt(np.maximum(vals, 0))).T
            U = np.abs(U) % 2.0
            U = np.where(U > 1, 2 - U, U)  # reflect into [0, 1]
            costs = _score(objective, box, U)
            bad += int(np.isinf(costs).sum())
            order = np.argsort(costs, kind="stable")
            if costs[order[0]] < best_c:
                best_c, best_u = float(costs[order[0]]), U[order[0]].copy()
            history.append(best_c)
            last_U, last_c = U, costs
            bar.update(1)
            bar.set_postfix(cost=f"{best_c:.4g}")
            if target is not None and best_c <= target:
                break
            _cma_update(s, (U - s.mean) / s.sigma, order, p, gen)
            if s.sigma * math.sqrt(max(np.linalg.eigvalsh(s.C).max(), 0)) < 1e-12:
                break
    U_all = np.vstack([best_u[None], last_U])
    c_all = np.concatenate([[best_c], last_c])
    return _finish(box, U_all, c_all, history, lam * gen, gen, bad)


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
    best, history, evals, bad, n = _Best(keep, box.dim), [], 0, 0, 0
    with progress_bar(total=total, desc=desc, enabled=progress) as bar:
        for X in batches:
            c = safe_costs(objective, X)
            best.add(X, c)
            evals, bad, n = evals + X.shape[0], bad + int(torch.isinf(c).sum()), n + 1
            history.append(float(best.c[0]))
            bar.update(X.shape[0])
            bar.set_postfix(cost=f"{history[-1]:.4g}")
            if target is not None and history[-1] <= target:
                break
    return best.result(history, evals, n, bad)


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
