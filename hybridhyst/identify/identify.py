"""``identify``: batched global search, gradient refinement and identifiability analysis on records.

One cost evaluation simulates population × records in one ``simulate(..., values=..., backend="fast")``
call per time grid: member n at record r is batch row n·R + r, with its parameter functions evaluated at
record r's conditions. So a model whose parameters are functions of a condition (e.g. linear in
``pressure_mpa``) is fitted to all pressure levels at once by one search over the function coefficients.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import torch
import torch.autograd.forward_ad as fwAD
from torch import nn

from ..data.batch import record_batches
from ..data.decimate import decimate_all
from ..data.records import Record, RecordSet
from ..settings import intra_op_threads
from ..simulate import jacobian_covers, resolved_substeps, simulate, simulate_jacobian
from ..simulate.api import dual_level
from ..simulate.inputs import with_rates
from .fisher import FisherReport, fisher_analysis, output_jacobian
from .refine import levenberg_marquardt
from .refine import refine as refine_rows
from .search import cma_es, differential_evolution, grid_search, monte_carlo, safe_costs
from .space import SearchSpace, condition_ranges

__all__ = ["IdentificationResult", "RecordsProblem", "identify"]


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
    ``resolve``, the searches and refinements at finer steps are appended in the order they ran.
    wall_s : wall time [s]; evaluations : simulated population rows (× records); search : method name.
    at_bounds : ``{name: "lower" | "upper"}``, coordinates that ended at an edge of the search box (within
    0.1 % of its width, on the log scale where it searches one): the box, not the data, set them.
    substeps : sub-steps per sample the result was simulated with (chosen by step doubling with ``resolve``).
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


class RecordsProblem:
    """Records grouped by length (``data.batch``: every record on its own time grid), with batched
    predictions and costs for a ``SearchSpace``.

    Parameters
    ----------
    space : the model's search space; records : the data; input_channels : channels driving the model.
    method, substeps : fixed-step scheme; backend : ``"fast"`` (compiled, default) or ``"reference"``.
    """

    def __init__(self, space: SearchSpace, records: Sequence[Record], input_channels=("x",), method: str = "rk4",
                 substeps: int = 1, backend: str = "fast"):
        self.space, self.records = space, list(records)
        self.sim = {"method": method, "substeps": int(substeps), "backend": backend}
        dtype = next(iter(space.model.parameters()), torch.zeros((), dtype=torch.float64)).dtype
        # the input rates once (finite differences), not at every cost evaluation
        self.groups = [(b.index, b.t, with_rates(b.inputs, b.t), b.y, b.conditions)
                       for b in record_batches(self.records, input_channels, dtype)]
        self.n_samples = sum(len(r) for r in self.records)
        self.y_flat = torch.cat([g[3].reshape(-1) for g in self.groups])

    def _batch(self, X: torch.Tensor, group) -> dict:
        """The simulation arguments of one time-grid group for the population ``X (N, D)``: member n at record
        r is batch row n·R + r, with its parameter values at record r's conditions."""
        _, t, U, _, cond = group
        N, R = X.shape[0], U.shape[0]
        return {"inputs": U.repeat(N, 1, 1), "t": t.repeat(N, 1), "values": self.space.values(X.to(U.dtype), cond, R),
                "conditions": {k: v.repeat(N, *[1] * (v.ndim - 1)) for k, v in cond.items()} or None}  # networks,
        # controls

    def predict_groups(self, X: torch.Tensor) -> list[torch.Tensor]:
        """Responses ``(N, R_g, T_g)`` of each time-grid group for the population ``X (N, D)``."""
        out = []
        for group in self.groups:
            y = simulate(self.space.model, **self._batch(X, group), **self.sim)
            out.append(y[..., 0].reshape(X.shape[0], group[2].shape[0], -1))
        return out

    def predict(self, X: torch.Tensor) -> torch.Tensor:
        """All responses flattened, ``(N, M)`` with M the total number of samples."""
        return torch.cat([p.reshape(p.shape[0], -1) for p in self.predict_groups(X)], dim=1)

    def record_mse(self, X: torch.Tensor) -> torch.Tensor:
        """Mean squared error ``(N, records)``, columns in the records' order."""
        out = torch.empty(X.shape[0], len(self.records), dtype=torch.float64)
        for (idx, _, _, Y, _), pred in zip(self.groups, self.predict_groups(X)):
            out[:, idx] = (pred - Y[None]).square().mean(dim=2).to(torch.float64)
        return out

    def residuals(self, X: torch.Tensor) -> torch.Tensor:
        """Model minus measured response, all samples flattened, ``(N, M)``."""
        return self.predict(X) - self.y_flat.to(X.dtype)[None]

    @property
    def jacobian_rows(self):
        """``(X (N, D), free (D,) booleans) -> (residuals (N, M), Jacobian (N, M, F))`` w.r.t. the F free
        coordinates, exact: the compiled loop's forward sensitivities w.r.t. the parameter values
        (``simulate_jacobian``, one pass where finite differences take one simulation per coordinate) times
        the parameter functions' derivatives w.r.t. the coordinates (forward-mode AD). None where the
        sensitivities do not cover the model (the reference backend, an input delay, networks): then
        Levenberg–Marquardt takes finite differences."""
        if self.sim["backend"] != "fast" or not jacobian_covers(self.space.model):
            return None
        return self._jacobian

    def _value_jacobian(self, X: torch.Tensor, idx: list[int], cond, R: int) -> dict:
        """``{effect: {parameter: (N·R, F)}}``: each row's parameter values differentiated w.r.t. the free
        coordinates ``idx``, in one forward-mode pass (coordinate j's direction in its own block of rows)."""
        N, F = X.shape[0], len(idx)
        E = X.new_zeros(N, F, X.shape[1])
        E[:, torch.arange(F), idx] = 1.0
        with dual_level():
            values = self.space.values(fwAD.make_dual(X.repeat_interleave(F, 0), E.reshape(N * F, -1)), cond, R)
            tangents = {k: {n: fwAD.unpack_dual(v).tangent for n, v in d.items()} for k, d in values.items()}
        return {k: {n: X.new_zeros(N * R, F) if v is None else v.reshape(N, F, R).transpose(1, 2).reshape(N * R, F)
                    for n, v in d.items()} for k, d in tangents.items()}

    def _jacobian(self, X: torch.Tensor, free: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        idx = torch.nonzero(torch.as_tensor(free, dtype=torch.bool)).reshape(-1).tolist()
        res, jac = [], []
        for group in self.groups:
            _, _, U, Y, cond = group
            N, R = X.shape[0], U.shape[0]
            Xd = X.detach().to(U.dtype)
            dvalues = self._value_jacobian(Xd, idx, cond, R)
            y, dy, keys = simulate_jacobian(self.space.model, **self._batch(Xd, group), method=self.sim["method"],
                                            substeps=self.sim["substeps"])
            dvdx = torch.stack([dvalues[k][n] for k, n in keys], dim=1)  # (N·R, parameters, F)
            res.append((y[..., 0].reshape(N, R, -1) - Y[None]).reshape(N, -1))
            jac.append((dy[..., 0, :] @ dvdx).reshape(N, -1, len(idx)))
        return torch.cat(res, dim=1).to(torch.float64), torch.cat(jac, dim=1).to(torch.float64)

    def cost(self, X: torch.Tensor) -> torch.Tensor:
        """Pooled MSE over every sample of every record, ``(N,)`` (differentiable)."""
        sse = 0.0
        for (_, _, _, Y, _), pred in zip(self.groups, self.predict_groups(X)):
            sse = sse + (pred - Y[None]).square().sum(dim=(1, 2))
        return sse / self.n_samples


def culprits(problem: RecordsProblem, x: torch.Tensor) -> list[str]:
    """Coordinates whose reset alone (to the starting value or the box centre) makes a non-finite fit finite.

    One batched evaluation of 2 D rows; if no single reset helps, every coordinate is named.
    """
    space = problem.space
    centre = space.from_unit(torch.full((1, space.dim), 0.5, dtype=torch.float64))[0]
    start = torch.tensor([c.value for c in space.coordinates], dtype=torch.float64)
    diag = torch.arange(space.dim)
    X = x.expand(2 * space.dim, -1).clone()
    X[diag, diag] = start
    X[space.dim + diag, diag] = centre
    finite = torch.isfinite(safe_costs(problem.cost, X)).reshape(2, space.dim).any(dim=0)
    names = [n for n, ok in zip(space.names, finite.tolist()) if ok]
    return names or space.names


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
    raise ValueError(f"unknown search method {method!r}; choose 'de', 'cma', 'mc' or 'grid'")


def _local(problem, mode, found, opts, target, progress):
    """Refine the best finite members of a search in one batch; returns (result or None, rows simulated)."""
    starts = found.population[torch.isfinite(found.costs)][: max(1, int(opts["restarts"]))]
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


def _rounds(problem, coarse, method, pop, generations, rounds, seed, target, mode, opts, progress):
    """Global search (on ``coarse``, the decimated problem) then batched refinement (on ``problem``),
    repeated (search resumed with the refined points) until the target is met or ``rounds`` are done.
    Returns (x, cost, history, rows simulated)."""
    x, cost, evals, init = None, math.inf, 0, None
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
        ref, n = _local(problem, mode, found, opts, target, progress)
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
            raise ValueError("jacobian='exact' needs the fast backend and a model without an input delay or networks")
        J = exact(x[None], torch.ones(D, dtype=torch.bool))[1][0]
    else:
        J = output_jacobian(problem.predict, x, method=jacobian)
    return fisher_analysis(J, x, problem.space.names, max(sigma, 1e-300), log=problem.space.log)


def identify(model: nn.Module, records, *, method: str = "cma", pop: int | None = 32, generations: int = 30,
             rounds: int = 3, refine: bool | str = "lm", restarts: int = 8, lm_steps: int = 40, adam_steps: int = 40,
             lbfgs_steps: int = 60, lr: float = 0.05,
             bounds: Mapping[str, tuple[float, float]] | None = None, box_factor: float = 10.0,
             noise_sd: float | None = None, target: float | None = None, seed: int = 0, fisher: bool = True,
             jacobian: str = "auto", progress: bool = True, input_channels=("x",), ode_method: str = "rk4",
             substeps: int = 1, search_decimate: int = 1, backend: str = "fast", resolve: bool = False,
             max_substeps: int = 16, torch_threads: int | None = 1) -> IdentificationResult:
    """Identify a nominal model's free parameters from records: global search, refinement, identifiability.

    Parameters
    ----------
    model : nominal model; its current values centre the default search box and it is fitted in place.
    records : a ``Record``, ``RecordSet`` or list of records (different conditions are fitted jointly).
    method : ``"cma"`` (CMA-ES, default: the more reliable on Bouc–Wen fits), ``"de"`` (differential
        evolution), ``"mc"`` (Monte Carlo: uniform samples of the box, seed 002) or ``"grid"`` (systematic
        search on an even grid, seed 004), the last two with a budget of pop × generations points;
        pop, generations : population size and generations per round.
    rounds : search + refinement rounds at most; a round after the first resumes the search from the
        refined points and the last population (new seed), and runs only while ``target`` is not met.
    refine : local refinement of the best ``restarts`` members, all in one batch: ``"lm"`` (default, also
        ``True``: batched Levenberg–Marquardt, ``lm_steps`` iterations), ``"gradient"`` (Adam ``adam_steps``
        then L-BFGS ``lbfgs_steps`` through the exact adjoint, Adam step ``lr``) or ``"none"``.
    bounds, box_factor : search-box overrides and default width (``SearchSpace``).
    noise_sd : response noise standard deviation for the Fisher analysis (default: the residual RMSE);
        also the default early-stop target of the search, cost ≤ (1.01 noise_sd)². With ``fisher``, a search
        stopped at the target is refined on (``lm_steps`` more Levenberg–Marquardt iterations) to the
        least-squares minimum, whose scatter the standard deviations describe.
    target : stop the search at this cost (MSE); seed : random seed (same seed, same result).
    fisher : run the identifiability analysis; jacobian : ``"exact"`` (forward sensitivities, one pass:
        ``RecordsProblem.jacobian_rows``), ``"autograd"`` (exact, M simulated rows for M samples), ``"fd"``
        (central differences, 2 D rows) or ``"auto"`` (exact where it covers the model, else autograd up to
        512 samples × records, else fd).
    input_channels, ode_method, substeps, backend : simulation settings (``simulate``).
    search_decimate : run the global search on every ``search_decimate``-th sample of each record (the
        refinement and every reported cost use all samples). 2 halves the search's cost; the coarser grid
        only has to rank members, so it works while the input is smooth at twice the sample interval.
    resolve, max_substeps : step doubling (``simulate.resolved_substeps``): once identified, the fewest sub-steps
        per sample (from ``substeps`` up to ``max_substeps``) at which halving the step changes the model's
        response by at most 0.1 %; where that is more than ``substeps`` the refinement goes on at the finer
        step from the identified point, and the check is repeated; then the search runs again at the finer step
        (the coarse fit's basin is the integrator's error's) and the better of the two is kept (and checked
        again). A sharp loop on a coarse sample grid is otherwise fitted as the integrator's error shapes it.
    torch_threads : torch intra-op threads during the run (restored after; None leaves them). The compiled
        simulator already runs rows in parallel (threads); torch threads competing with it made identification
        of the seed 001 loop about 5x slower on a 2-core machine.

    Raises
    ------
    ValueError
        When the best fit is not finite, naming the parameters whose values drove the divergence.
    """
    settings = {k: v for k, v in locals().items() if k not in ("model", "records", "torch_threads")}
    with intra_op_threads(torch_threads):
        return _identify(model, records, **settings)


def _problem(space, records, input_channels, ode_method, substeps, backend, decimate: int = 1) -> RecordsProblem:
    """``records`` (for a search: every ``decimate``-th sample of each) at ``substeps`` per sample interval."""
    if int(decimate) != 1:
        records = decimate_all(records, int(decimate), "identification")
    return RecordsProblem(space, records, input_channels, ode_method, int(substeps), backend)


def _identify(model, records, *, method, pop, generations, rounds, refine, restarts, lm_steps, adam_steps,
              lbfgs_steps, lr, bounds, box_factor, noise_sd, target, seed, fisher, jacobian, progress, input_channels,
              ode_method, substeps, search_decimate, backend, resolve, max_substeps) -> IdentificationResult:
    start = time.perf_counter()
    records = _records(records)
    space = SearchSpace(model, bounds, factor=box_factor, condition_ranges=condition_ranges(records))
    sim = (input_channels, ode_method)
    problem = _problem(space, records, *sim, substeps, backend)
    decimate = int(search_decimate)
    coarse = _problem(space, records, *sim, substeps, backend, decimate) if decimate != 1 else problem
    if target is None and noise_sd:
        target = (1.01 * noise_sd) ** 2
    mode = {True: "lm", False: "none", None: "none"}.get(refine, refine)
    if mode not in ("lm", "gradient", "none"):
        raise ValueError(f"unknown refine mode {refine!r}; choose 'lm', 'gradient' or 'none'")
    opts = {"restarts": restarts, "lm_steps": lm_steps, "adam_steps": adam_steps, "lbfgs_steps": lbfgs_steps,
            "lr": lr}
    x, cost, history, evals = _rounds(problem, coarse, method, pop, generations, rounds, seed, target, mode, opts,
                                      progress)

    state = {"problem": problem, "x": x, "cost": cost, "evals": evals}

    def go_on(s: int) -> None:  # Levenberg–Marquardt on from the current point at s sub-steps per sample
        if s != state["problem"].sim["substeps"]:
            state["problem"] = _problem(space, records, *sim, s, backend)
        p, x = state["problem"], state["x"]
        with torch.no_grad():
            cost = float(p.cost(x[None])[0])  # the same point on this problem
        ref = levenberg_marquardt(p.residuals, space, x[None], iters=int(lm_steps), progress=progress,
                                  jacobian_rows=p.jacobian_rows)
        history["refine"] += ref.history
        state["evals"] += ref.evaluations * len(p.records)
        if ref.cost < cost or not math.isfinite(cost):
            x, cost = ref.x, ref.cost
        space.to_model(x)
        state.update(x=x, cost=cost)

    def check(s: int) -> float:  # step doubling from s sub-steps, going on (go_on) wherever it doubles
        space.to_model(state["x"])
        return resolved_substeps(space.model, records, substeps=s, max_substeps=int(max_substeps), refit=go_on,
                                 method=ode_method, backend=backend, input_channels=tuple(input_channels))[1]

    def search_again(s: int, k: int) -> bool:  # the search at s sub-steps; its fit replaces the current if better
        grid = state["problem"] if decimate == 1 else _problem(  # the same step on the decimated grid
            space, records, *sim, s * decimate, backend, decimate)
        x2, cost2, more, n = _rounds(state["problem"], grid, method, pop, generations, rounds,
                                     seed + k * max(1, int(rounds)), target, mode, opts, progress)
        state["evals"] += n
        for key, values in more.items():
            history[key] += values
        better = cost2 < state["cost"]
        if better:
            state.update(x=x2, cost=cost2)
        return better

    resolution, searched = math.nan, problem.sim["substeps"]
    if resolve and math.isfinite(cost):
        resolution = check(searched)
        # The refit at a finer step starts in the basin of the fit at the coarser one, whose optimum the
        # integrator's error shaped: search again at the finer step, keep the better and check it again
        while state["problem"].sim["substeps"] != searched and not (target is not None and state["cost"] <= target):
            searched = state["problem"].sim["substeps"]
            if search_again(searched, int(math.log2(searched))):
                resolution = check(searched)
    if fisher and target is not None and state["cost"] <= target and mode != "none":
        # the search stopped at the target, short of the least-squares minimum (as may a refit at a finer step,
        # lm_steps from a coarser fit); the Fisher standard deviations describe the minimum's scatter, so go on to
        # it (the early-stopped point scatters more than they say)
        go_on(state["problem"].sim["substeps"])
    problem, x, cost, evals = state["problem"], state["x"], state["cost"], state["evals"]
    if not math.isfinite(cost):
        names = culprits(problem, x)
        raise ValueError(f"identification ended non-finite: every simulation diverged; parameters driving it: "
                         f"{names}; narrow their bounds, add substeps or a finer time grid")
    space.to_model(x)
    result = _result(problem, x, cost, noise_sd, fisher, jacobian, history, evals, method, start)
    result.substeps, result.resolution = problem.sim["substeps"], resolution
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
