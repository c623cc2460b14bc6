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
