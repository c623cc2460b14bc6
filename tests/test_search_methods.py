"""Monte Carlo and grid (systematic) search: budgets, batching, reproducibility, bad members, ``identify``."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybridhyst.data import Record
from hybridhyst.identify import Box, grid_search, identify, monte_carlo
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
    res = identify(model, Record(name="r", t=t, x=x, y=y), method=method, pop=16, generations=4, rounds=1,
                   fisher=False, progress=False)
    assert res.search == method and res.x["viscous.c"] == pytest.approx(0.4, rel=1e-5)
    assert res.x["spring.k"] == pytest.approx(3.0, rel=1e-5)
