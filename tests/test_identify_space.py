"""Identification's search space: trend boxes from the data, parameter domains, batched values per function kind."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybridhyst.data import Record
from hybridhyst.identify import RecordsProblem, SearchSpace, fisher_analysis, output_jacobian
from hybridhyst.physics.effects import EFFECTS, Viscous
from hybridhyst.physics.models import Constitutive


def test_box_coordinates_have_finite_gradients_on_wide_linear_scales():
    """``from_unit`` is differentiated by Levenberg–Marquardt's exact Jacobians and the gradient refinement; a
    linear coordinate whose box reaches beyond ±709 (a Bouc–Wen β of ±1.5e5 1/m) once got a NaN gradient from
    the log branch's overflowing exp. That made the Bouc–Wen benchmark's hysteresis candidate stay at its
    start with exact Jacobians (2026-11-25)."""
    from hybridhyst.identify.space import Box

    box = Box([-1.5e5, 0.0, 0.1], [1.5e5, 7.6e6, 20.0], log=[False, False, True])
    U = torch.tensor([[0.505, 0.0005, 0.5]], dtype=torch.float64, requires_grad=True)
    X = box.from_unit(U)
    (dX,) = torch.autograd.grad(X.sum(), U)
    assert torch.allclose(X.detach(), torch.tensor([[1.5e3, 3.8e3, math.sqrt(2.0)]], dtype=torch.float64))
    assert torch.allclose(dX, torch.tensor([[3e5, 7.6e6, math.sqrt(2.0) * math.log(200.0)]], dtype=torch.float64))


def test_coordinates_from_logits_and_their_derivatives_are_autograds_to_the_last_bit():
    """Levenberg–Marquardt chains its exact Jacobians through ``Box.from_logits`` instead of a backward pass; the
    numbers must be autograd's exactly, or every fit (and each committed result) would move."""
    from hybridhyst.identify.space import Box

    box = Box([-1.5e5, 0.0, 0.1, 1e-6, -3.0], [1.5e5, 7.6e6, 20.0, 1e3, 7.0], log=[False, False, True, True, False])
    W = torch.randn(400, 5, dtype=torch.float64, generator=torch.Generator().manual_seed(0)) * 6
    W[:3] = torch.tensor([0.0, 40.0, -40.0], dtype=torch.float64)[:, None]  # the centre and saturated logits
    Wg = W.clone().requires_grad_(True)
    X = box.from_unit(torch.sigmoid(Wg))
    (dX,) = torch.autograd.grad(X.sum(), Wg)
    X2, dX2 = box.from_logits(W)
    assert torch.equal(X2, X.detach())
    assert torch.equal(dX2, dX)


def test_a_trend_starting_at_zero_gets_a_box_from_the_data(float64):
    """A slope at 0 is searched within ± factor · |intercept| / (range of the condition in the data), not
    (-1, 1), which would miss a parameter doubling over 0.01 ... 0.09 MPa (slope ~ 84 for c = 6.7); the
    intercept's box lets the line pivot about the data."""
    from hybridhyst.identify.space import SearchSpace
    from hybridhyst.physics.compositions import vpptd_algebraic

    model = vpptd_algebraic(c={"kind": "linear", "slope": 0.0, "intercept": 6.7, "condition": "pressure_mpa"}).double()
    plain = {c.name: (c.lower, c.upper) for c in SearchSpace(model).coordinates}
    scaled = {c.name: (c.lower, c.upper) for c in SearchSpace(model, condition_ranges={"pressure_mpa": (0.01, 0.09)})
              .coordinates}
    assert plain["viscous.c.c1"] == (-1.0, 1.0)
    half = 10 * 6.7 / 0.08
    assert scaled["viscous.c.c1"] == pytest.approx((-half, half))
    assert scaled["viscous.c.c0"] == pytest.approx((6.7 - 67 - half * 0.09, 6.7 + 67 + half * 0.09))


def test_a_trend_that_leaves_its_parameters_domain_at_a_records_condition_simulates_nothing(float64):
    """Seen in a user trial: a refit drove a Dahl element's σ0 and Fc trends below zero at a training level
    (σ0 = −3.74 + 3.84·I kip/in): the boxes bound a trend's coefficients, not its values. A member whose
    positive (or bounded) parameter is out of its domain at a record's condition is NaN there, and its cost
    infinite; inside the domain nothing changes."""
    from hybridhyst.identify.space import SearchSpace
    from hybridhyst.physics.compositions import vpptd_algebraic

    model = vpptd_algebraic(c={"kind": "linear", "slope": 50.0, "intercept": 2.0, "condition": "pressure_mpa"}).double()
    space = SearchSpace(model, condition_ranges={"pressure_mpa": (0.01, 0.09)}, refit_trends=True)
    x = space.initial()
    rows = torch.stack([x, x.clone()])
    rows[1, space.names.index("viscous.c.c0")] = -1.0  # c = −1 + 50 p: below zero at p < 0.02
    pressures = torch.tensor([0.01, 0.05, 0.09], dtype=torch.float64)
    c = space.values(rows, {"pressure_mpa": pressures}, 3)["viscous"]["c"].reshape(2, 3)
    assert torch.allclose(c[0], 2.0 + 50.0 * pressures)
    assert torch.isnan(c[1, 0]) and torch.allclose(c[1, 1:], -1.0 + 50.0 * pressures[1:])
    assert list(space.domains) == [("viscous", "c")]  # a constant is held in its domain by its box
    t = np.linspace(0, 2, 200)
    records = [Record(name=f"p{p}", t=t, x=np.sin(np.pi * t), y=np.zeros_like(t), conditions={"pressure_mpa": p},
                      units={"t": "s", "x": "deg", "y": "Nm"}) for p in (0.01, 0.05, 0.09)]
    problem = RecordsProblem(space, records, method="rk4", substeps=1, backend="reference")
    cost = problem.cost(rows)
    assert math.isfinite(float(cost[0])) and not math.isfinite(float(cost[1]))


def test_finite_difference_jacobian_at_a_domain_edge_is_one_sided(float64):
    """Seed 001's study ended 'the output Jacobian at the optimum is not finite' where a fitted viscous trend
    reached 0 at one pressure: the central difference's lower side left c's domain (NaN there). There the
    difference is one-sided on the finite side and equals the exact derivative; where the point itself does
    not simulate, the Jacobian stays NaN and the Fisher analysis still refuses it."""
    from hybridhyst.physics.compositions import vpptd_algebraic

    c = {"kind": "linear", "slope": 4.0, "intercept": -1.0, "condition": "pressure_mpa"}  # c = 0 at p = 0.25
    space = SearchSpace(vpptd_algebraic(c=c).double())
    t = np.linspace(0, 2, 200)
    records = [Record(name=f"p{p}", t=t, x=np.sin(np.pi * t), y=np.zeros_like(t), conditions={"pressure_mpa": p},
                      units={"t": "s", "x": "deg", "y": "Nm"}) for p in (0.25, 0.5, 0.75)]
    problem = RecordsProblem(space, records, method="rk4", substeps=1, backend="reference")
    x = space.initial()
    assert float(space.values(x[None], {"pressure_mpa": torch.tensor([0.25])}, 1)["viscous"]["c"][0]) == 0.0
    fd = output_jacobian(problem.predict, x, method="fd")
    exact = output_jacobian(problem.predict, x, method="autograd")
    assert torch.isfinite(fd).all() and torch.allclose(fd, exact, rtol=1e-5, atol=1e-6)
    assert torch.allclose(fd[:, :2], exact[:, :2], rtol=1e-6, atol=1e-8)  # c's coefficients: one-sided at p = 0.25
    assert fisher_analysis(fd, x, space.names, sigma=0.1, log=space.log).eigenvalues[0] > 0

    def edge(X):  # a response defined for X0 >= 0 only
        return torch.where(X[:, :1] >= 0, 3 * X[:, :1] + X[:, 1:] * torch.arange(1.0, 4.0), math.nan)

    J = output_jacobian(edge, torch.tensor([0.0, 1.0]), method="fd")
    assert torch.allclose(J, torch.tensor([[3.0, 1.0], [3.0, 2.0], [3.0, 3.0]]), rtol=1e-6)
    J = output_jacobian(edge, torch.tensor([-1e-3, 1.0]), method="fd")  # the point itself outside: stays NaN
    assert torch.isnan(J[:, 0]).all()
    with pytest.raises(ValueError, match="not finite"):
        fisher_analysis(J, torch.tensor([-1e-3, 1.0]), ["a", "b"], sigma=0.1)


@pytest.mark.parametrize("power,lo,hi,span", [(1, 0.01, 0.09, 0.08), (2, -1.0, 2.0, 4.0), (2, -3.0, -1.0, 8.0),
                                               (3, -1.0, 2.0, 9.0), (1, 5.0, 5.0, 5.0)])
def test_trend_scale_is_the_value_over_the_change_of_the_power_across_the_data(power, lo, hi, span):
    """Δ = max − min of c^power over [lo, hi] (0 included when the range straddles it); one level: |c|^power."""
    from hybridhyst.identify.space import trend_scale

    assert trend_scale(-3.0, power, lo, hi) == pytest.approx(3.0 / span)
    assert trend_scale(0.0, power, lo, hi) is None and trend_scale(1.0, 1, 0.0, 0.0) is None


def test_trend_boxes_of_a_partly_known_polynomial_and_under_a_user_box(float64):
    """A coefficient at 0 beside a known one gets the trend box, the known one and the constant term keep the
    general rule, except in a local refit of fitted trends (``refit_trends``, the discovery loop's): there the
    known one gets a box symmetric about 0 (a trend may vanish or turn) and the constant term reaches as far as
    the higher coefficients can move the value (its sign is not the parameter's), over data at more than one
    level only. A user's box for the slope widens the intercept's reach with it."""
    from hybridhyst.identify.space import SearchSpace
    from hybridhyst.physics.compositions import vpptd_algebraic

    ranges = {"pressure_mpa": (0.01, 0.09)}
    quad = vpptd_algebraic(c={"kind": "polynomial", "coeffs": [6.7, 20.0, 0.0], "condition": "pressure_mpa"}).double()
    box = {c.name: (c.lower, c.upper) for c in SearchSpace(quad, condition_ranges=ranges).coordinates}
    assert box["viscous.c.c2"] == pytest.approx((-10 * 6.7 / (0.09**2 - 0.01**2), 10 * 6.7 / (0.09**2 - 0.01**2)))
    assert box["viscous.c.c0"] == pytest.approx((0.67, 67.0)) and box["viscous.c.c1"] == pytest.approx((2.0, 200.0))
    def boxes(**options):
        return {c.name: (c.lower, c.upper) for c in SearchSpace(quad, refit_trends=True, **options).coordinates}

    refit = boxes(condition_ranges=ranges)
    assert refit["viscous.c.c1"] == pytest.approx((-200.0, 200.0)) and refit["viscous.c.c2"] == box["viscous.c.c2"]
    reach = 10 * 6.7 + 200.0 * 0.09 + box["viscous.c.c2"][1] * 0.09**2
    assert refit["viscous.c.c0"] == pytest.approx((6.7 - reach, 6.7 + reach))
    one_level = boxes(condition_ranges={"pressure_mpa": (0.03, 0.03)})
    assert one_level["viscous.c.c0"] == pytest.approx((0.67, 67.0))
    assert one_level["viscous.c.c1"] == pytest.approx((2.0, 200.0))
    line = vpptd_algebraic(c={"kind": "linear", "slope": 0.0, "intercept": 6.7, "condition": "pressure_mpa"}).double()
    wide = {c.name: (c.lower, c.upper)
            for c in SearchSpace(line, {"viscous.c.c1": (-5000.0, 5000.0)}, condition_ranges=ranges).coordinates}
    assert wide["viscous.c.c1"] == (-5000.0, 5000.0)
    assert wide["viscous.c.c0"] == pytest.approx((6.7 - 67 - 5000 * 0.09, 6.7 + 67 + 5000 * 0.09))


def test_a_nonnegative_polynomial_is_never_searched_below_zero(float64):
    """The travel a device made before a record, carried from record to record (``discover.carried_travel``), is a
    line in the travel before it whose coefficients are both ≥ 0: a local refit of fitted trends (boxes symmetric
    about 0) once turned its slope negative, and the start travel of a held-out record that came after more travel
    than any training record went below 0 (a spring built up from zero stiffness started at minus its value: 15.8
    × noise held out on the bed's `coulomb` case without its spring). The flag round-trips through the config and
    training's projection puts its coefficients back at 0."""
    from hybridhyst.identify.space import SearchSpace
    from hybridhyst.physics.parameters import build_function, project_to_bounds

    ranges = {"pressure_mpa": (0.01, 0.09)}
    for slope in (0.0, 20.0):
        line = {"kind": "linear", "slope": slope, "intercept": 6.7, "condition": "pressure_mpa"}
        signed = {c.name: (c.lower, c.upper) for c in SearchSpace(
            vpptd_algebraic_c(line), condition_ranges=ranges, refit_trends=True).coordinates}
        kept = {c.name: (c.lower, c.upper) for c in SearchSpace(
            vpptd_algebraic_c({**line, "nonnegative": True}), condition_ranges=ranges, refit_trends=True).coordinates}
        for name in ("viscous.c.c0", "viscous.c.c1"):
            assert signed[name][0] < 0 and kept[name] == (0.0, signed[name][1]), (name, signed[name], kept[name])
    fn = build_function({"kind": "linear", "slope": 2.0, "intercept": 0.5, "condition": "travel_before",
                         "nonnegative": True})
    assert fn.config() == {"kind": "linear", "slope": 2.0, "intercept": 0.5, "condition": "travel_before",
                           "nonnegative": True}
    assert "nonnegative" not in build_function({"kind": "linear", "slope": 2.0, "intercept": 0.5}).config()
    with pytest.raises(ValueError, match="nonnegative linear function needs every coefficient >= 0, got intercept "
                                         "0.5, slope -1"):
        build_function({"kind": "linear", "slope": -1.0, "intercept": 0.5, "nonnegative": True})
    with pytest.raises(ValueError, match="nonnegative polynomial function needs every coefficient >= 0, got c0 = 0.5, "
                                         "c1 = -1"):
        build_function({"kind": "polynomial", "coeffs": [0.5, -1.0], "nonnegative": True})
    flagged = vpptd_algebraic_c({"kind": "linear", "slope": 2.0, "intercept": 6.7, "nonnegative": True})
    assert {c.name: (c.lower, c.upper) for c in SearchSpace(flagged, {"viscous.c.c1": (-3.0, 5.0)}).coordinates}[
        "viscous.c.c1"] == (0.0, 5.0)  # a user's box is clipped at 0 ...
    with pytest.raises(ValueError, match="viscous.c.c1: a coefficient of a nonnegative function is never negative"):
        SearchSpace(flagged, {"viscous.c.c1": (-3.0, -1.0)})  # ... and one entirely below it is said
    model = vpptd_algebraic_c({"kind": "linear", "slope": 2.0, "intercept": 6.7, "nonnegative": True})
    with torch.no_grad():
        model.effects["viscous"].params["c"].coeffs.copy_(torch.tensor([-1.0, 3.0]))
    project_to_bounds(model)
    assert model.effects["viscous"].params["c"].coeffs.tolist() == [0.0, 3.0]


def vpptd_algebraic_c(c):
    from hybridhyst.physics.compositions import vpptd_algebraic

    return vpptd_algebraic(c=c).double()


def test_a_trend_box_holds_a_steep_line_far_from_zero(float64):
    """Conditions far from 0 (band tension 30 ... 36 lb): a parameter that grows five-fold across the data is
    ``v + 2/3 v (T - 30)``, slope 2/3 v and intercept -19 v. A box sized by the largest |condition| (± 10 v / 36)
    or the general rule for the intercept ((v / 10, 10 v), positive) misses it; the one rule of identification
    and discovery (``trend_scale``) holds it, and the discovery loop's condition candidate gets the same box."""
    from hybridhyst.discover.candidates import condition_candidates
    from hybridhyst.discover.fitting import _space
    from hybridhyst.identify.space import SearchSpace, condition_ranges
    from hybridhyst.physics.compositions import vpptd_algebraic

    v = 2.0
    line = {"kind": "linear", "slope": 0.0, "intercept": v, "condition": "tension_lb"}
    model = vpptd_algebraic(c=line).double()
    recs = [Record(f"r{T}", np.linspace(0, 1, 5), np.zeros(5), np.zeros(5), {"tension_lb": T}) for T in (30, 33, 36)]
    assert condition_ranges(recs) == {"tension_lb": (30.0, 36.0)}
    box = {c.name: (c.lower, c.upper) for c in SearchSpace(model, condition_ranges=condition_ranges(recs)).coordinates}
    lo, hi = box["viscous.c.c1"]
    assert lo < -2 / 3 * v and 2 / 3 * v < hi
    lo, hi = box["viscous.c.c0"]
    assert lo < -19 * v < hi
    # the discovery loop's candidate making a constant c a line in tension gets the same boxes
    const = vpptd_algebraic(c=v).double()
    cands = condition_candidates(const, {"tension_lb": [30, 33, 36]})
    cand = next(c for c in cands if c.name == "viscous.c~tension_lb")
    found = {c.name: (c.lower, c.upper) for c in _space(cand.build(const), recs, bounds=cand.bounds).coordinates}
    assert found["viscous.c.c1"] == pytest.approx(box["viscous.c.c1"])
    assert found["viscous.c.c0"] == pytest.approx(box["viscous.c.c0"])


_KIND_CONFIGS = {  # every parameter-function kind, placed on parameters with different constraints
    "constant": 1.4,
    "fixed": {"kind": "fixed", "value": 1.4},
    "linear": {"kind": "linear", "slope": 6.0, "intercept": 1.1},
    "polynomial": {"kind": "polynomial", "coeffs": [1.5, -8.0, 90.0, -400.0]},
    "exp_rise": {"kind": "exp_rise", "y0": 1.0, "a": 0.8, "b": 30.0},
    "exp_decay": {"kind": "exp_decay", "y0": 1.0, "a": 0.8, "b": 30.0},
    "exp_growth": {"kind": "exp_growth", "y0": 1.0, "a": 0.3, "b": 10.0},
    "per_condition": {"kind": "per_condition", "levels": [0.01, 0.05, 0.09], "values": [0.9, 1.2, 1.6],
                      "condition": "pressure_mpa"},
    "neural": {"kind": "neural", "base": 1.4, "condition": "pressure_mpa", "hidden": 3},
}


def test_every_parameter_function_kind_is_covered_by_the_search_space_test():
    from hybridhyst.physics.parameters import _FUNCTIONS

    assert set(_KIND_CONFIGS) == set(_FUNCTIONS)


@pytest.mark.parametrize("where", ["viscous.c", "dahl.Fc", "bouc_wen.n"])  # nonnegative, positive, bounded
@pytest.mark.parametrize("kind", sorted(_KIND_CONFIGS))
def test_search_space_values_equal_the_models_own_evaluation(kind, where, float64):
    """The batched path of identification (``SearchSpace.values``) gives, row for row, what the model itself
    evaluates once the member is written into it (``to_model``), and ``initial`` reads the member back."""
    effect, pname = where.split(".")
    kwargs = {"viscous": {"c": 0.3}, "dahl": {"Fc": 1.5, "sigma0": 10.0}, "bouc_wen": {"n": 2.0}}
    kwargs[effect][pname] = _KIND_CONFIGS[kind]
    model = Constitutive({"viscous": Viscous(**kwargs["viscous"]), "dahl": EFFECTS["dahl"](**kwargs["dahl"]),
                          "bouc_wen": EFFECTS["bouc_wen"](**kwargs["bouc_wen"])}).double()
    fn = model.effects[effect].params[pname]
    if kind == "neural":  # a trained-looking network, not the zero start
        torch.manual_seed(0)
        for p in fn.net.parameters():
            torch.nn.init.normal_(p, std=0.7)
    cond = {"pressure_mpa": torch.tensor([0.01, 0.09, 0.05, 0.01, 0.05])}
    R = 5
    space = SearchSpace(model, condition_ranges={"pressure_mpa": (0.01, 0.09)})
    x0 = space.initial()
    want = model.evaluate(cond, R)
    partial = SearchSpace(model, free=space.names[::2])  # the others held at their values
    for sp, x in ((space, x0), (partial, x0[::2])):
        own = sp.values(x[None], cond, R)
        for key, params in want.items():
            for name, value in params.items():
                torch.testing.assert_close(own[key][name], value, rtol=1e-12, atol=1e-12)
    members = space.from_unit(torch.rand(3, space.dim, generator=torch.Generator().manual_seed(1),
                                         dtype=torch.float64))
    got = space.values(members, cond, R)
    for n, x in enumerate(members):
        space.to_model(x)
        torch.testing.assert_close(space.initial(), x, rtol=1e-12, atol=1e-12)
        for key, params in model.evaluate(cond, R).items():
            for name, value in params.items():
                # a function of the condition is NaN where its value leaves the parameter's domain (a search
                # member that simulates nothing), the model's own value elsewhere
                out = (~model.effects[key].param_specs[name].admits(value)
                       if (key, name) in space.domains else torch.zeros_like(value, dtype=torch.bool))
                row = got[key][name][n * R:(n + 1) * R]
                assert torch.isnan(row[out]).all()
                torch.testing.assert_close(row[~out], value[~out], rtol=1e-12, atol=1e-12)
    if kind == "neural":  # network weights have no known sign: boxes symmetric about 0
        weights = [c for c in space.coordinates if ".net." in c.name]
        assert len(weights) == 3 + 3 + 3 + 1 and all(c.lower == -c.upper for c in weights)
