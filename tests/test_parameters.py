"""Constrained parameters and parameter functions of a condition."""

import math

import pytest
import torch

from hybridhyst.physics.parameters import (
    Bounded,
    ParameterSpec,
    PerCondition,
    Positive,
    build_function,
    project_to_bounds,
    render_unit,
)


@pytest.mark.parametrize("transform, values", [(Positive(), [1e-4, 0.3, 5.0, 80.0]),
                                               (Bounded(-2.0, 3.0), [-1.99, 0.0, 2.5])])
def test_parametrizations_invert_exactly(transform, values, float64):
    v = torch.tensor(values)
    assert torch.allclose(transform(transform.right_inverse(v)), v, rtol=1e-10)


def test_positive_keeps_a_gradient_where_a_clamp_would_not(float64):
    raw = torch.tensor(-30.0, requires_grad=True)  # deep in the tail
    Positive()(raw).backward()
    assert raw.grad.item() > 0


def test_out_of_range_initial_values_are_rejected():
    with pytest.raises(ValueError, match="Positive"):
        Positive().right_inverse(torch.tensor(-1.0))
    with pytest.raises(ValueError, match="strictly inside"):
        Bounded(0.0, 1.0).right_inverse(torch.tensor(1.5))


def test_constant_with_positive_spec_trains_the_raw_value(float64):
    fn = build_function(2.5, ParameterSpec(1.0, "F/x", (0, 10), "positive"))
    assert fn(None, 3).tolist() == pytest.approx([2.5] * 3)
    names = [n for n, _ in fn.named_parameters()]
    assert names == ["parametrizations.value.original"]


@pytest.mark.parametrize(
    "cfg, p, expected",
    [
        ({"kind": "linear", "slope": 12.726, "intercept": 2.5581}, 0.05, 2.5581 + 12.726 * 0.05),
        ({"kind": "polynomial", "coeffs": [0.5325, -7.7916, 106.76, -479.08]}, 0.05,
         0.5325 - 7.7916 * 0.05 + 106.76 * 0.05**2 - 479.08 * 0.05**3),
        ({"kind": "exp_rise", "y0": 1.0, "a": 2.0, "b": 30.0}, 0.05, 1.0 + 2.0 * (1 - math.exp(-1.5))),
        ({"kind": "exp_decay", "y0": 1.0, "a": 2.0, "b": 30.0}, 0.05, 1.0 + 2.0 * math.exp(-1.5)),
        ({"kind": "exp_growth", "y0": 1.0, "a": 2.0, "b": 30.0}, 0.05, 1.0 + 2.0 * math.exp(1.5)),
        ({"kind": "neural", "base": 4.0, "condition": "pressure_mpa"}, 0.05, 4.0),
    ],
)
def test_parameter_functions_of_pressure(cfg, p, expected, float64):
    fn = build_function(cfg)
    value = fn({"pressure_mpa": torch.tensor([p, p])}, 2)
    assert value.tolist() == pytest.approx([expected] * 2, rel=1e-12)
    value.sum().backward()
    assert all(q.grad is not None for q in fn.parameters())


def test_per_condition_values_and_unknown_level(float64):
    fn = PerCondition([0.01, 0.05], [3.0, 7.0], condition="pressure_mpa")
    assert fn({"pressure_mpa": torch.tensor([0.05, 0.01])}, 2).tolist() == [7.0, 3.0]
    with pytest.raises(ValueError, match="0.03"):
        fn({"pressure_mpa": torch.tensor([0.03])}, 1)


def test_unknown_function_kind_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown parameter function 'cubic'"):
        build_function({"kind": "cubic"})


def test_units_render_in_the_models_symbols():
    assert render_unit("F*t/x", {"F": "Nm", "x": "deg", "t": "s"}) == "Nm*s/deg"
    assert render_unit("F/x^3", {"F": "kip", "x": "in"}) == "kip/in^3"


# -- coordinates of parameter functions (what identification searches) -------------------------------------

_SPECS = {
    "nonnegative": ParameterSpec(0.0, "F", (0.0, 2.0), "nonnegative"),
    "positive": ParameterSpec(1.0, "F", (0.5, 2.0), "positive"),
    "bounded": ParameterSpec(1.0, "F", (0.5, 2.0), "bounded"),
    "real": ParameterSpec(1.0, "F", (0.5, 2.0), "real"),
}
_P = {"pressure_mpa": torch.tensor([0.01, 0.09, 0.05, 0.01], dtype=torch.float64)}
# every registered kind, with the coordinates it declares (suffixes) and the values it starts from
_KINDS = {
    "constant": ({"kind": "constant", "value": 1.2}, [""]),
    "fixed": ({"kind": "fixed", "value": 1.2}, []),
    "linear": ({"kind": "linear", "slope": 12.0, "intercept": 1.5}, [".c0", ".c1"]),
    "polynomial": ({"kind": "polynomial", "coeffs": [1.5, -8.0, 90.0, -400.0]}, [".c0", ".c1", ".c2", ".c3"]),
    "exp_rise": ({"kind": "exp_rise", "y0": 1.0, "a": 0.8, "b": 30.0}, [".y0", ".a", ".b"]),
    "exp_decay": ({"kind": "exp_decay", "y0": 1.0, "a": 0.8, "b": 30.0}, [".y0", ".a", ".b"]),
    "exp_growth": ({"kind": "exp_growth", "y0": 1.0, "a": 0.3, "b": 10.0}, [".y0", ".a", ".b"]),
    "per_condition": ({"kind": "per_condition", "levels": [0.01, 0.05, 0.09], "values": [0.7, 1.1, 1.5],
                       "condition": "pressure_mpa"},
                      ["[pressure_mpa=0.01]", "[pressure_mpa=0.05]", "[pressure_mpa=0.09]"]),
    "neural": ({"kind": "neural", "base": 1.2, "condition": "pressure_mpa", "hidden": 3},
               [".base", *(f".net.body.0.weight[{i}]" for i in range(3)), *(f".net.body.0.bias[{i}]" for i in range(3)),
                *(f".net.head.weight[{i}]" for i in range(3)), ".net.head.bias[0]"]),
}


def test_every_registered_kind_is_covered_here():
    from hybridhyst.physics.parameters import _FUNCTIONS

    assert set(_KINDS) == set(_FUNCTIONS)


def _function(kind, constraint):
    fn = build_function(dict(_KINDS[kind][0]), _SPECS[constraint])
    if kind == "neural":  # a trained-looking network, not the zero start
        torch.manual_seed(0)
        for p in fn.net.parameters():
            torch.nn.init.normal_(p, std=0.7)
    return fn


@pytest.mark.parametrize("constraint", sorted(_SPECS))
@pytest.mark.parametrize("kind", sorted(_KINDS))
def test_coordinates_round_trip_and_batched_evaluation(kind, constraint, float64):
    """coordinates() names and reads the function's free scalars; set_coordinates writes them back (through a
    constraint's right_inverse); evaluate_batch of P coordinate vectors equals the function itself at each."""
    fn = _function(kind, constraint)
    declared = fn.coordinates()
    x = fn.coordinate_values().detach()
    assert [c.suffix for c in declared] == _KINDS[kind][1]
    assert torch.equal(x, torch.tensor([c.value for c in declared]))
    members = torch.stack([x, x * 1.3, x * 0.8 + 0.01]) if x.numel() else torch.zeros(3, 0)
    batched = fn.evaluate_batch(members, _P, 4)
    assert batched.shape == (3, 4)
    for row, coords in zip(batched, members):
        fn.set_coordinates(coords)
        assert torch.allclose(fn.coordinate_values(), coords, rtol=1e-12, atol=1e-12)
        assert [c.value for c in fn.coordinates()] == pytest.approx(coords.tolist(), rel=1e-12, abs=1e-12)
        assert torch.allclose(fn(_P, 4), row, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="coordinates"):
        fn.set_coordinates(torch.zeros(x.numel() + 1))


def test_per_condition_takes_a_constraint_and_loads_its_old_state(float64):
    fn = PerCondition([0.01, 0.05], [3.0, 7.0], "pressure_mpa", _SPECS["positive"])  # was a KeyError ('values')
    assert fn.values.tolist() == pytest.approx([3.0, 7.0], rel=1e-12)
    old = PerCondition([0.01, 0.05], [1.0, 2.0], "pressure_mpa")
    old.load_state_dict({"levels": torch.tensor([0.01, 0.05]), "values": torch.tensor([4.0, 5.0])})
    assert old.values.tolist() == [4.0, 5.0]


def test_neural_function_is_a_nets_mlp_starting_at_its_base(float64):
    from hybridhyst.nets import MLP

    fn = build_function({"kind": "neural", "base": 4.0, "condition": "pressure_mpa", "hidden": 5})
    assert isinstance(fn.net, MLP) and fn.net.hidden == [5]
    assert sum(p.numel() for p in fn.parameters()) == 1 + (5 + 5) + (5 + 1)
    assert fn(_P, 4).tolist() == [4.0] * 4
    assert all(c.signed for c in fn.coordinates()[1:]) and not fn.coordinates()[0].signed


# -- project_to_bounds -------------------------------------------------------------------------------------

class _Effect(torch.nn.Module):
    """What ``project_to_bounds`` reads: ``param_specs`` and ``params``."""

    def __init__(self, constraint, value):
        super().__init__()
        self.param_specs = {"a": _SPECS[constraint]}
        self.params = torch.nn.ModuleDict({"a": build_function(value, _SPECS[constraint])})


def _store(fn, values):
    """Put ``values`` in an unconstrained function's storage directly (as an optimiser step would)."""
    attr = "value" if hasattr(fn, "value") else "level_values"
    with torch.no_grad():
        getattr(fn, attr).copy_(torch.tensor(values).reshape(getattr(fn, attr).shape))


@pytest.mark.parametrize("kind", ["constant", "per_condition"])
def test_projection_puts_nonnegative_values_back_into_their_bounds(kind, float64):
    levels = {"kind": "per_condition", "levels": [1, 2, 3, 4], "values": 1.0, "condition": "pressure_mpa"}
    model = torch.nn.Sequential(_Effect("nonnegative", 1.0 if kind == "constant" else levels))
    fn = model[0].params["a"]
    before = [-0.5, 0.0, 1.3, 2.5] if kind == "per_condition" else [-0.5]
    _store(fn, before)
    project_to_bounds(model)
    expected = [0.0, 0.0, 1.3, 2.0] if kind == "per_condition" else [0.0]
    assert fn.coordinate_values().tolist() == expected  # 1.3 (in the box) exactly unchanged
    _store(fn, [2.5] * len(before))
    project_to_bounds(model)
    assert fn.coordinate_values().tolist() == [2.0] * len(before)


@pytest.mark.parametrize("constraint, value", [("positive", 1.7), ("bounded", 1.7), ("real", 1.7),
                                               ("real", 5.0), ("positive", 5.0), ("nonnegative", 1.7)])
def test_projection_leaves_admissible_and_parametrized_values_alone(constraint, value, float64):
    """Only unconstrained amplitudes (``nonnegative``) are projected: an in-box value is unchanged bit for bit;
    positive / bounded values are admissible by their parametrization (bounded cannot leave its box), and
    ``real`` values and a ``positive`` value above its search bound are not clamped (the bounds are the search
    box there, not a constraint)."""
    model = _Effect(constraint, value)
    fn = model.params["a"]
    before = fn.coordinate_values().detach().clone()
    state = {k: v.clone() for k, v in fn.state_dict().items()}
    project_to_bounds(model)
    assert torch.equal(fn.coordinate_values(), before)
    assert all(torch.equal(v, state[k]) for k, v in fn.state_dict().items())


def test_projection_leaves_coefficients_of_a_condition_alone(float64):
    model = _Effect("nonnegative", {"kind": "linear", "slope": -5.0, "intercept": -1.0})
    project_to_bounds(model)
    assert model.params["a"].coordinate_values().tolist() == [-1.0, -5.0]
