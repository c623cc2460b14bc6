"""Levenberg–Marquardt in identification: diverging rows, free coordinates, non-finite and exact Jacobians."""

from __future__ import annotations

import math

import pytest
import torch
from test_identify import _dahl, _linear, _records

from hybridhyst.identify import RecordsProblem, SearchSpace
from hybridhyst.identify.refine import levenberg_marquardt
from hybridhyst.physics.effects import EFFECTS
from hybridhyst.physics.models import Constitutive


def test_levenberg_marquardt_survives_rows_that_diverge():
    """A restart whose simulation diverges (NaN residuals and Jacobian) gets a zero step; the others go on."""
    from hybridhyst.identify.space import Box

    box = Box([0.0, 0.0], [4.0, 4.0])
    target = torch.tensor([1.0, 2.0], dtype=torch.float64)

    def residual_rows(X):
        r = (X - target) * torch.tensor([1.0, 3.0], dtype=torch.float64)
        return torch.where((X[:, :1] > 3.0), torch.full_like(r, float("nan")), r)

    starts = torch.tensor([[3.5, 3.5], [0.5, 0.5]])  # the first row is NaN from the start
    res = levenberg_marquardt(residual_rows, box, starts, iters=30, progress=False)
    assert torch.allclose(res.x, target, atol=1e-6) and res.cost < 1e-12


def test_levenberg_marquardt_takes_differences_where_an_exact_jacobian_is_not_finite():
    """A row whose exact Jacobian is not finite where its residuals are (a sensitivity that overflows) gets a
    finite-difference Jacobian instead of zero steps, and reaches the optimum."""
    from hybridhyst.identify.space import Box

    box = Box([0.0, 0.0], [4.0, 4.0])
    target = torch.tensor([1.0, 2.0], dtype=torch.float64)
    weights = torch.tensor([1.0, 3.0], dtype=torch.float64)

    def residual_rows(X):
        return (X - target) * weights

    def jacobian_rows(X, free):  # exact, but infinite on the line x0 = 2.5 (where the start lies)
        J = torch.diag(weights)[None, :, free].expand(X.shape[0], -1, -1).clone()
        J[(X[:, 0] - 2.5).abs() < 1e-9] = float("inf")
        return residual_rows(X), J

    start = torch.tensor([[2.5, 2.5]], dtype=torch.float64)
    res = levenberg_marquardt(residual_rows, box, start, iters=30, progress=False, jacobian_rows=jacobian_rows)
    assert torch.allclose(res.x, target, atol=1e-6) and res.cost < 1e-12
    assert res.evaluations > 1 + 2  # the start's Jacobian took differences: one row per coordinate


def test_levenberg_marquardt_moves_only_free_coordinates():
    """``free`` masks coordinates: held ones keep each row's start, free ones reach their conditional optimum."""
    from hybridhyst.identify.space import Box

    box = Box([-4.0, -4.0], [4.0, 4.0])

    def residual_rows(X):  # optimum of x0 given x1 is x0 = 1 + 0.5 x1; joint optimum (1, 2)
        return torch.stack([X[:, 0] - 1.0 - 0.5 * X[:, 1], X[:, 1] - 2.0], dim=1)

    starts = torch.tensor([[0.0, -1.0], [3.0, 1.0]], dtype=torch.float64)
    res = levenberg_marquardt(residual_rows, box, starts, iters=40, free=torch.tensor([True, False]), progress=False)
    assert torch.allclose(res.X[:, 1], starts[:, 1])
    assert torch.allclose(res.X[:, 0], 1.0 + 0.5 * starts[:, 1], atol=1e-6)
    with pytest.raises(ValueError, match="no free coordinate"):
        levenberg_marquardt(residual_rows, box, starts, free=torch.tensor([False, False]), progress=False)


def test_parameter_derivatives_are_forward_ads_to_the_last_bit(float64):
    """``RecordsProblem`` writes a constant's derivative as a unit column and takes the other functions' by reverse
    mode (``row_jacobian``; every Jacobian of every fit asks for them): the numbers must be forward-mode AD's, exactly
    for constants and polynomial trends (products in the same order), to rounding for an exponential law (the chain
    rule's factors multiplied in the other order), with a held coordinate and a subset of free coordinates."""
    from hybridhyst.physics.parameters import ExpRise

    dahl = _dahl(sigma0=10.0, c=0.5)
    dahl.effects["dahl"].params["Fc"] = _linear(1.0, 20.0)
    spring = EFFECTS["linear_stiffness"](k=3.0)
    spring.params["k"] = ExpRise(2.0, 1.5, 20.0, condition="pressure_mpa")
    model = Constitutive({"spring": spring, **dict(dahl.effects)},
                         units=dahl.units).double()
    data = _records(model, [{"pressure_mpa": p} for p in (0.02, 0.05, 0.08)])
    held = ("dahl.sigma0", "spring.k.b")  # a constant and a trend's coordinate held at their values
    space = SearchSpace(model, free=[n for n in SearchSpace(model).names if n not in held])
    problem = RecordsProblem(space, list(data))
    X = space.initial()[None].expand(3, -1).clone() * torch.tensor([[1.0], [1.1], [0.9]], dtype=torch.float64)
    for idx in (list(range(space.dim)), [0, space.dim - 1]):
        _, _, U, _, cond = problem.groups[0]
        ad = forward_mode_values(space, X, idx, cond, U.shape[0])
        got = problem._value_jacobian(X, idx, cond, U.shape[0])
        assert got.keys() == ad.keys()
        for k, d in ad.items():
            assert got[k].keys() == d.keys()
            for n, want in d.items():
                if (k, n) == ("spring", "k"):
                    assert torch.allclose(got[k][n], want, rtol=1e-15, atol=0.0) and bool(want.abs().sum() > 0)
                else:
                    assert torch.equal(got[k][n], want), (k, n)


def forward_mode_values(space, X: torch.Tensor, idx: list[int], cond, R: int) -> dict:
    """The oracle: each row's parameter values' derivatives ``{effect: {value: (N·R, F)}}`` w.r.t. the coordinates
    ``idx`` by forward-mode AD (``scripts/bench_jacobian.py``'s, which times it against reverse mode)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "bench_jacobian.py"
    spec = importlib.util.spec_from_file_location("bench_jacobian", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench.forward_mode_values(space, X, idx, cond, R)


def test_a_selection_of_parameter_derivatives_is_the_batched_product_to_the_last_bit(float64):
    """``problem._chain`` takes the columns of a pure 0/1 selection instead of multiplying (constants only); the
    values must be the product's, and a non-finite derivative, of a parameter a coordinate selects or of one left
    out, must spoil its sample's row as the product does (inf · 0 = NaN), which Levenberg–Marquardt and the Fisher
    analysis check for."""
    from hybridhyst.identify.problem import _chain

    g = torch.Generator().manual_seed(0)
    dy = torch.randn(6, 50, 5, dtype=torch.float64, generator=g)
    pick = torch.zeros(5, 3, dtype=torch.float64)
    pick[[4, 1, 2], [0, 1, 2]] = 1.0  # parameters 0 and 3 are no free coordinate's
    twice = pick.clone()
    twice[1, 0], twice[4, 0] = 1.0, 0.0  # two coordinates of one parameter's value
    for dvdx in (pick, twice, pick * torch.tensor([1.0, 1.0, 0.5]), torch.eye(5)):  # a trend: no selection; every
        # parameter's own column in order: dy itself
        dvdx = dvdx.expand(6, -1, -1)
        assert torch.equal(_chain(dy, dvdx), dy @ dvdx)
    for where in ((2, 7, 0), (3, 9, 4)):  # left out, then selected
        bad = dy.clone()
        bad[where] = math.inf
        got, want = _chain(bad, pick.expand(6, -1, -1)), bad @ pick.expand(6, -1, -1)
        assert torch.equal(got.isnan(), want.isnan()) and torch.equal(got.nan_to_num(), want.nan_to_num())
        assert bool(got[where[0], where[1]].isnan().any())


def test_populations_of_any_size_simulate_as_their_rows_alone(float64):
    """``RecordsProblem`` repeats its inputs once for the largest population yet and hands a leading slice of them to
    smaller ones: residuals and Jacobians of a population, grown and shrunk, are those of each row on its own."""
    dahl = _dahl(sigma0=10.0, c=0.5)
    dahl.effects["dahl"].params["Fc"] = _linear(1.0, 20.0)
    data = _records(dahl.double(), [{"pressure_mpa": p} for p in (0.02, 0.05, 0.08)])
    problem = RecordsProblem(SearchSpace(dahl.double()), list(data))
    X = problem.space.initial()[None] * torch.linspace(0.8, 1.2, 5, dtype=torch.float64)[:, None]
    free = torch.ones(problem.space.dim, dtype=torch.bool)
    alone = [problem.residuals(X[i:i + 1]) for i in range(5)]
    alone_jacobians = [problem.jacobian_rows(X[i:i + 1], free) for i in range(5)]
    for n in (2, 5, 3, 1):
        assert torch.equal(problem.residuals(X[:n]), torch.cat(alone[:n]))
        r, J = problem.jacobian_rows(X[:n], free)
        assert torch.equal(r, torch.cat([a[0] for a in alone_jacobians[:n]]))
        assert torch.equal(J, torch.cat([a[1] for a in alone_jacobians[:n]]))
    # with coordinates held (the loop's tangent carries only the parameters the free ones move) the same columns
    r, J = problem.jacobian_rows(X, free)
    for held in (["dahl.sigma0"], ["viscous.c", "dahl.Fc.c1"], [n for n in problem.space.names if n != "dahl.sigma0"]):
        assert set(held) <= set(problem.space.names)
        some = torch.tensor([n not in held for n in problem.space.names])
        r2, J2 = problem.jacobian_rows(X, some)
        assert torch.equal(r2, r) and torch.equal(J2, J[..., some])


def test_exact_jacobian_equals_finite_differences_with_trends_and_play(float64):
    """``RecordsProblem.jacobian_rows`` (forward sensitivities through the parameter functions and the
    compiled loop) against central differences of the residuals, for a model with a play before a spring (a
    projected state), a parameter linear in a condition and records at several conditions, on a subset of
    coordinates; then LM with it takes the same path as with finite differences."""
    def play_model(r, c, k, Fc):
        dahl = _dahl(sigma0=10.0, c=c)
        dahl.effects["dahl"].params["Fc"] = Fc
        return Constitutive({"play": EFFECTS["backlash"](r=r), "spring": EFFECTS["linear_stiffness"](k=k),
                             **dict(dahl.effects)}, units=dahl.units).double()

    data = _records(play_model(0.1, 0.5, 3.0, _linear(1.0, 20.0)), [{"pressure_mpa": p} for p in (0.02, 0.05, 0.08)])
    problem = RecordsProblem(SearchSpace(play_model(0.07, 0.3, 2.0, _linear(1.5, 12.0))), list(data))
    X = problem.space.initial()[None].expand(2, -1).clone()
    X[1] *= 1.1
    free = torch.ones(problem.space.dim, dtype=torch.bool)
    free[problem.space.names.index("dahl.sigma0")] = False
    r, J = problem.jacobian_rows(X, free)
    assert torch.allclose(r, problem.residuals(X), rtol=0, atol=1e-12)
    for j, i in enumerate(torch.nonzero(free).reshape(-1).tolist()):
        h = 1e-6 * max(abs(float(X[:, i].abs().max())), 1.0)
        E = torch.zeros_like(X)
        E[:, i] = h
        fd = (problem.residuals(X + E) - problem.residuals(X - E)) / (2 * h)
        assert torch.allclose(J[:, :, j], fd, rtol=1e-4, atol=1e-6 * float(fd.abs().max())), problem.space.names[i]
    assert float(J[:, :, 0].abs().max()) > 0.1  # the play's half-width moves the spring's force
    exact = levenberg_marquardt(problem.residuals, problem.space, X, iters=40, progress=False,
                                jacobian_rows=problem.jacobian_rows)
    fd = levenberg_marquardt(problem.residuals, problem.space, X, iters=40, progress=False)
    assert exact.cost <= fd.cost * (1 + 1e-6) and torch.allclose(exact.x, fd.x, rtol=1e-4)  # the same path
    assert exact.cost < 0.1 * fd.history[0]
    assert exact.evaluations < fd.evaluations / 2  # a Jacobian pass counts as one row, not one per coordinate
    assert RecordsProblem(problem.space, list(data), backend="reference").jacobian_rows is None


def test_levenberg_marquardt_stops_simulating_rows_that_have_converged():
    """With ``rtol``, a row whose Gauss–Newton step no longer gains is not simulated again (the run ends when every
    row has converged), while a row still descending a curved valley goes on: the same optimum as ``rtol=0``
    for every row, in fewer simulated rows."""
    from hybridhyst.identify.space import Box

    box = Box([-3.0, -3.0], [3.0, 3.0])
    calls = []

    def residual_rows(X):  # Rosenbrock's valley as residuals: minimum at (1, 1)
        calls.append(X.shape[0])
        return torch.stack([10.0 * (X[:, 1] - X[:, 0] ** 2), 1.0 - X[:, 0]], dim=1)

    starts = torch.tensor([[1.0 + 1e-9, 1.0], [-1.2, 1.0], [0.5, 2.0]], dtype=torch.float64)
    every = levenberg_marquardt(residual_rows, box, starts, iters=200, progress=False)
    n_every = sum(calls)
    calls.clear()
    converged = levenberg_marquardt(residual_rows, box, starts, iters=200, progress=False, rtol=1e-6)
    assert torch.allclose(converged.X, every.X, atol=1e-5)
    assert torch.allclose(converged.X[1], torch.ones(2, dtype=torch.float64), atol=1e-5)
    assert sum(calls) < n_every / 2 and converged.evaluations < every.evaluations
    assert len(converged.history) < len(every.history)  # the run ended when every row had converged
