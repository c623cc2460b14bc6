"""Global searches: differential evolution (scipy) and CMA-ES (cma, IPOP) on closed-form bowls — optimum found,
bounds respected, one objective call per generation, exact evaluation counts, seeds, target, bad members —
and Monte Carlo and grid (systematic) search: budgets, batching, reproducibility, bad members, ``identify``."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest
import torch

from hybridhyst.data import Record
from hybridhyst.identify import Box, cma_es, differential_evolution, grid_search, identify, monte_carlo
from hybridhyst.physics.effects import EFFECTS, Viscous
from hybridhyst.physics.models import Constitutive
from hybridhyst.simulate import simulate

OPT = torch.tensor([0.3, -0.6], dtype=torch.float64)


class Bowl:
    """cost = |x − OPT|², recording every batch it is called with."""

    def __init__(self):
        self.calls: list[torch.Tensor] = []

    def __call__(self, X):
        self.calls.append(X.clone())
        return (X - OPT).square().sum(dim=1)


SHIFT = torch.tensor([0.3, -0.6, 0.7], dtype=torch.float64)
BOX3 = ([-2.0] * 3, [2.0] * 3)
SEARCHES = [differential_evolution, cma_es]


def rosenbrock(X):
    """Rosenbrock's valley shifted so its minimum 0 is at ``SHIFT`` (inside ``BOX3``), ``(N, 3) -> (N,)``; in
    three dimensions it has no other local minimum (from four on it has one more)."""
    Y = X - SHIFT + 1.0
    return (100 * (Y[:, 1:] - Y[:, :-1] ** 2) ** 2 + (1 - Y[:, :-1]) ** 2).sum(dim=1)


class Recorder:
    """Wraps an objective, recording every batch it is called with."""

    def __init__(self, fn):
        self.fn, self.calls = fn, []

    def __call__(self, X):
        self.calls.append(X.clone())
        return self.fn(X)


@pytest.mark.parametrize("search", SEARCHES)
def test_search_finds_the_minimum_of_a_shifted_rosenbrock(search):
    res = search(rosenbrock, BOX3, pop=24, generations=400, seed=1, progress=False)
    assert res.cost < 1e-8 and torch.allclose(res.x, SHIFT, atol=1e-3)
    assert res.cost == pytest.approx(float(rosenbrock(res.x[None])[0]), abs=1e-15)
    assert res.history == sorted(res.history, reverse=True) and res.history[-1] == res.cost
    assert bool((res.costs[1:] >= res.costs[:-1]).all()) and res.costs[0] == res.cost  # best first


@pytest.mark.parametrize("search", [*SEARCHES, partial(cma_es, boundary="transform")],
                         ids=["differential_evolution", "cma_es_reflect", "cma_es_transform"])
def test_search_stays_in_the_box_and_finds_an_optimum_on_its_bound(search):
    """The unconstrained minimum (1.5, -0.6) lies outside [-1, 1]²: the constrained one is (1, -0.6)."""
    bowl = Recorder(lambda X: (X - torch.tensor([1.5, -0.6], dtype=torch.float64)).square().sum(dim=1))
    res = search(bowl, ([-1.0, -1.0], [1.0, 1.0]), pop=16, generations=80, seed=0, progress=False)
    seen = torch.cat(bowl.calls)
    assert bool(((seen >= -1.0) & (seen <= 1.0)).all()) and bool(((res.population.abs()) <= 1.0).all())
    assert res.x.tolist() == pytest.approx([1.0, -0.6], abs=1e-3) and res.cost == pytest.approx(0.25, abs=1e-3)


def test_differential_evolution_scores_the_whole_population_once_per_generation():
    rec = Recorder(rosenbrock)
    res = differential_evolution(rec, BOX3, pop=12, generations=25, seed=2, progress=False)
    assert [c.shape for c in rec.calls] == [(12, 3)] * 26  # the initial population, then one per generation
    assert res.generations == 25 and res.evaluations == 12 * 26 and len(res.history) == 26
    assert res.population.shape == (12, 3) and res.costs.shape == (12,)
    # the final population is the best of each member's lineage: every cost was seen, none above the start
    seen = torch.cat([rosenbrock(c) for c in rec.calls])
    assert all(bool(torch.isclose(seen, c).any()) for c in res.costs)
    assert float(res.costs.max()) <= float(rosenbrock(rec.calls[0]).max())


def test_cma_es_scores_one_generation_per_call_and_restarts_with_doubled_populations():
    rec = Recorder(rosenbrock)
    res = cma_es(rec, BOX3, pop=10, generations=30, seed=2, progress=False)
    assert [c.shape for c in rec.calls] == [(10, 3)] * 30  # one run, no restart needed within the budget
    assert res.generations == 30 and res.evaluations == 300 and len(res.history) == 30
    # a flat objective stops each run at once (cma's flat-fitness test): IPOP restarts with 2× the population
    # until the next run no longer fits the budget of pop × generations = 160 rows
    flat = Recorder(lambda X: torch.zeros(X.shape[0], dtype=torch.float64))
    res = cma_es(flat, BOX3, pop=8, generations=20, seed=0, progress=False)
    sizes = [c.shape[0] for c in flat.calls]
    runs = sorted(set(sizes))
    assert runs == [8 * 2**k for k in range(len(runs))] and len(runs) >= 3 and sizes == sorted(sizes)
    assert res.evaluations == sum(sizes) <= 160 and res.generations == len(sizes) and sum(sizes) + 2 * runs[-1] > 160


@pytest.mark.parametrize("search", SEARCHES)
def test_same_seed_same_search_and_another_seed_differs(search):
    runs = [search(rosenbrock, BOX3, pop=12, generations=20, seed=s, progress=False) for s in (5, 5, 6)]
    assert torch.equal(runs[0].x, runs[1].x) and runs[0].history == runs[1].history
    assert torch.equal(runs[0].population, runs[1].population)
    assert not torch.equal(runs[0].x, runs[2].x) and runs[0].history != runs[2].history


def test_cma_es_leaves_numpy_global_state_and_working_directory_alone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    np.random.seed(123)
    expected = np.random.random(3)
    np.random.seed(123)
    cma_es(rosenbrock, BOX3, pop=8, generations=10, seed=0, progress=False)
    assert np.array_equal(np.random.random(3), expected)  # cma samples through our Generator
    assert list(tmp_path.iterdir()) == []  # no outcmaes/ or other log files


@pytest.mark.parametrize("search", SEARCHES)
def test_search_stops_at_the_first_generation_that_reaches_target(search):
    rec = Recorder(rosenbrock)
    res = search(rec, BOX3, pop=16, generations=500, seed=3, target=1e-3, progress=False)
    assert res.cost <= 1e-3 and res.history[-1] <= 1e-3 < res.history[-2]
    assert res.evaluations == sum(c.shape[0] for c in rec.calls) < 16 * 500
    assert res.cost == pytest.approx(float(rosenbrock(res.x[None])[0]))


def test_differential_evolution_starts_from_init_and_stops_if_it_meets_target():
    rec = Recorder(rosenbrock)
    res = differential_evolution(rec, BOX3, pop=10, generations=50, init=SHIFT[None], target=1e-12, progress=False)
    assert len(rec.calls) == 1 and torch.allclose(rec.calls[0][0], SHIFT, rtol=0, atol=1e-14)  # via the unit cube
    assert res.evaluations == 10 and res.generations == 0 and res.cost < 1e-20
    assert torch.allclose(res.x, SHIFT, rtol=0, atol=1e-14)


def test_cma_es_starts_its_first_run_at_init():
    rec = Recorder(rosenbrock)
    cma_es(rec, BOX3, pop=400, generations=1, sigma0=0.01, init=SHIFT[None], progress=False)
    assert torch.allclose(rec.calls[0].mean(dim=0), SHIFT, atol=0.01)  # sd of that mean: 0.01 · 4 / 20 = 0.002


@pytest.mark.parametrize("search", SEARCHES)
def test_search_survives_nan_and_raising_members(search):
    """NaN for x₀ < 0; the batch raises whenever a member has x₁ > 0.5 (members are then scored one by one,
    and those raise alone): both count as infinitely bad, and the best feasible point is found."""
    opt = torch.tensor([0.2, 0.3], dtype=torch.float64)

    def nasty(X):
        if bool((X[:, 1] > 0.5).any()):
            raise RuntimeError("simulation diverged")
        c = (X - opt).square().sum(dim=1)
        return torch.where(X[:, 0] < 0, torch.full_like(c, math.nan), c)

    res = search(nasty, ([-1.0, -1.0], [1.0, 1.0]), pop=16, generations=60, seed=0, progress=False)
    assert res.non_finite > 0 and math.isfinite(res.cost) and res.cost < 1e-6
    assert res.x.tolist() == pytest.approx(opt.tolist(), abs=1e-3)


def test_cma_es_checks_its_boundary_handling():
    with pytest.raises(ValueError, match="unknown boundary handling"):
        cma_es(rosenbrock, BOX3, boundary="clip", progress=False)


def test_differential_evolution_checks_its_options():
    with pytest.raises(ValueError, match="unknown strategy"):
        differential_evolution(rosenbrock, BOX3, strategy="best3bin", progress=False)
    with pytest.raises(ValueError, match="at least 5"):
        differential_evolution(rosenbrock, BOX3, pop=4, progress=False)
    res = differential_evolution(rosenbrock, BOX3, pop=20, generations=200, strategy="rand1bin", F=0.7, CR=0.5,
                                 seed=0, progress=False)
    assert res.cost < 0.05  # the exploratory strategy still descends the valley


def test_monte_carlo_samples_uniformly_within_budget_and_batches():
    bowl = Bowl()
    res = monte_carlo(bowl, ([-1.0, -1.0], [1.0, 1.0]), samples=4000, batch=512, seed=3, progress=False)
    seen = torch.cat(bowl.calls)
    assert [c.shape[0] for c in bowl.calls] == [512] * 7 + [416] and res.evaluations == 4000
    assert res.generations == 8 and len(res.history) == 8 and res.history == sorted(res.history, reverse=True)
    assert bool(((seen >= -1) & (seen <= 1)).all())
    assert seen.mean(dim=0).abs().max() < 0.05  # uniform on [-1, 1]: mean 0, sd of the mean ~0.009
    # nearest of 4000 uniform points in an area of 4: expected squared distance 4 / (π · 4000) ≈ 3e-4
    assert res.cost < 5e-3 and res.cost == pytest.approx(float(bowl(res.x[None])[0]))
    assert res.costs.shape[0] == 64 and bool((res.costs[1:] >= res.costs[:-1]).all())
    again = monte_carlo(Bowl(), ([-1.0, -1.0], [1.0, 1.0]), samples=4000, batch=512, seed=3, progress=False)
    other = monte_carlo(Bowl(), ([-1.0, -1.0], [1.0, 1.0]), samples=4000, batch=512, seed=4, progress=False)
    assert torch.equal(again.x, res.x) and not torch.equal(other.x, res.x)


def test_monte_carlo_init_target_and_non_finite_members():
    res = monte_carlo(Bowl(), ([-1.0, -1.0], [1.0, 1.0]), samples=1000, batch=100, init=OPT[None], target=1e-12,
                      progress=False)
    assert res.cost == 0.0 and res.evaluations == 1 and torch.equal(res.x, OPT)

    def half_bad(X):
        c = (X - OPT).square().sum(dim=1)
        return torch.where(X[:, 0] < 0, torch.full_like(c, math.nan), c)

    res = monte_carlo(half_bad, ([-1.0, -1.0], [1.0, 1.0]), samples=2000, batch=500, progress=False)
    assert 800 < res.non_finite < 1200 and math.isfinite(res.cost) and res.cost < 1e-2


def test_monte_carlo_on_a_log_box_is_uniform_in_the_logarithm():
    seen = []
    monte_carlo(lambda X: seen.append(X) or X[:, 0], Box([1.0], [100.0], log=[True]), samples=4000, progress=False)
    frac_below_10 = float((torch.cat(seen) < 10).double().mean())
    assert frac_below_10 == pytest.approx(0.5, abs=0.03)  # linear sampling would give 9/99


def test_grid_search_enumerates_every_point_and_finds_the_grid_optimum():
    bowl = Bowl()
    res = grid_search(bowl, ([-1.0, -1.0], [1.0, 1.0]), points=[5, 6], batch=7, progress=False)
    seen = torch.cat(bowl.calls)
    assert res.evaluations == 30 and seen.shape == (30, 2) and max(c.shape[0] for c in bowl.calls) == 7
    assert sorted(set(seen[:, 0].tolist())) == pytest.approx(np.linspace(-1, 1, 5).tolist())
    assert sorted(set(seen[:, 1].tolist())) == pytest.approx(np.linspace(-1, 1, 6).tolist())
    assert res.x.tolist() == pytest.approx([0.5, -0.6])  # nearest grid point to (0.3, -0.6)
    levels = grid_search(Bowl(), ([-1.0, -1.0], [1.0, 1.0]), levels=[[0.1, 0.3], [-0.6, 0.0, 0.6]], progress=False)
    assert levels.evaluations == 6 and levels.cost == 0.0 and torch.equal(levels.x, OPT)


def test_grid_search_on_a_log_box_is_geometric_and_checks_its_options():
    seen = []
    grid_search(lambda X: seen.append(X) or X[:, 0], Box([1.0], [100.0], log=[True]), points=3, progress=False)
    assert torch.cat(seen)[:, 0].tolist() == pytest.approx([1.0, 10.0, 100.0])
    with pytest.raises(ValueError, match="points must be >= 2"):
        grid_search(Bowl(), ([0.0, 0.0], [1.0, 1.0]), points=[3], progress=False)
    with pytest.raises(ValueError, match="levels must give"):
        grid_search(Bowl(), ([0.0, 0.0], [1.0, 1.0]), levels=[[0.5]], progress=False)


@pytest.mark.parametrize("method", ["mc", "grid"])
def test_identify_with_monte_carlo_or_grid_then_lm_recovers_a_spring_dashpot(method, float64):
    truth = Constitutive({"viscous": Viscous(c=0.4), "spring": EFFECTS["linear_stiffness"](k=3.0)}).double()
    t = np.linspace(0.0, 2.0, 201)
    x = np.sin(2 * np.pi * t)
    with torch.no_grad():
        y = simulate(truth, torch.as_tensor(x)[None], t=torch.as_tensor(t), backend="fast")[0, :, 0].numpy()
    model = Constitutive({"viscous": Viscous(c=1.0), "spring": EFFECTS["linear_stiffness"](k=1.0)}).double()
    res = identify(model, Record(name="r", t=t, x=x, y=y), search=method, pop=16, generations=4, rounds=1,
                   fisher=False, progress=False)
    assert res.search == method and res.x["viscous.c"] == pytest.approx(0.4, rel=1e-5)
    assert res.x["spring.k"] == pytest.approx(3.0, rel=1e-5)
