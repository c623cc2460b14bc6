"""Control channels that vary in time: parameter functions of a control evaluated at every stage, a lag and a
saturation of the control, Spencer's MR damper; the compiled path equals the reference, values and gradients."""

import math

import numpy as np
import pytest
import torch

from hybridhyst.physics.effects import EFFECTS
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate, simulate_jacobian
from tests.test_fast import CONTROL_EFFECTS, _assert_agree

LINEAR = {"kind": "linear", "condition": "voltage"}


def _voltage(B: int, T: int, dt: float, seed: int = 0) -> torch.Tensor:
    """A random piecewise-constant voltage, smoothed a little: steps every 40 samples."""
    g = np.random.default_rng(seed)
    steps = g.uniform(0.0, 2.0, size=(B, T // 40 + 1)).repeat(40, axis=1)[:, :T]
    kernel = np.ones(5) / 5
    return torch.tensor(np.stack([np.convolve(s, kernel, mode="same") for s in steps]))


def _spencer_model():
    """Spencer et al. 1997's MR damper (their Table, in N, cm, s), the voltage lagged (η) and saturated."""
    return Constitutive({
        "coil": EFFECTS["control_lag"](control="voltage", eta=190.0),
        "limit": EFFECTS["control_saturation"](control="voltage", c_max=3.0),
        "damper": EFFECTS["spencer_mr"](alpha={**LINEAR, "intercept": 140.0, "slope": 695.0},
                                        c0={**LINEAR, "intercept": 21.0, "slope": 3.5},
                                        c1={**LINEAR, "intercept": 283.0, "slope": 2.95},
                                        k0=46.9, k1=5.0, x0=14.3, gamma=363.0, beta=363.0, A=301.0, n=2.0),
    }).double()


def test_every_control_effect_has_a_case():
    assert CONTROL_EFFECTS == {"control_lag", "control_saturation", "spencer_mr"} <= set(EFFECTS)
    assert {type(e).name for e in _spencer_model().effects.values()} == CONTROL_EFFECTS


def test_fast_path_equals_reference_with_a_control(float64):
    t = torch.arange(200) * 2e-4  # five voltage steps: the lag, the saturation and the damper's every branch
    x = 1.5 * torch.sin(2 * math.pi * 2.5 * t + 1.0)[None].expand(2, -1)
    _assert_agree(_spencer_model(), x, t, conditions={"voltage": _voltage(2, 200, 2e-4)}, substeps=4)


def test_fast_path_equals_reference_for_an_oscillator_whose_damping_follows_a_control(float64):
    model = DrivenOscillator({"damper": EFFECTS["viscous"](c={"kind": "exp_rise", "y0": 0.2, "a": 1.0, "b": 2.0,
                                                              "condition": "pressure"}),
                              "spring": EFFECTS["linear_stiffness"](k={"kind": "polynomial", "coeffs": [3.0, 0.5, 0.2],
                                                                       "condition": "pressure"})},
                             mass=0.1).double()
    t = torch.arange(300) * 5e-3
    u = torch.sin(2 * math.pi * 1.1 * t)[None].expand(2, -1)
    pressure = torch.stack([torch.linspace(0.0, 1.0, 300), torch.linspace(1.0, 0.2, 300)])
    _assert_agree(model, u, t, conditions={"pressure": pressure}, substeps=2)


def test_a_function_of_a_control_is_evaluated_at_every_sample(float64):
    """F = c(v(t)) ẋ has no state: at every sample the output is the function at that sample's control."""
    model = Constitutive({"damper": EFFECTS["viscous"](c={**LINEAR, "intercept": 0.5, "slope": 2.0})}).double()
    t = torch.arange(200) * 1e-3
    x = torch.sin(2 * math.pi * 3.0 * t)[None]
    v = _voltage(1, 200, 1e-3)
    velocity = torch.tensor(np.gradient(x[0].numpy(), t.numpy(), edge_order=2))
    for backend in ("reference", "fast"):
        y = simulate(model, x, t=t, conditions={"voltage": v}, input_channels=("x",), backend=backend)[0, :, 0]
        assert torch.allclose(y, (0.5 + 2.0 * v[0]) * velocity, rtol=1e-12, atol=1e-12)


def test_a_constant_control_gives_what_the_constant_condition_gives(float64):
    model = _spencer_model()
    t = torch.arange(300) * 2e-4
    x = 1.5 * torch.sin(2 * math.pi * 2.5 * t)[None].expand(2, -1)
    level = torch.tensor([0.0, 1.5])
    signal = simulate(model, x, t=t, conditions={"voltage": level[:, None].expand(-1, 300)}, substeps=4,
                      backend="fast")
    plain = _spencer_model()
    del plain.effects["coil"], plain.effects["limit"]
    plain._init_layout(plain.effects)
    saturated = 3.0 * torch.tanh(level / 3.0)
    constant = simulate(plain, x, t=t, conditions={"voltage": saturated}, substeps=4, backend="fast")
    assert torch.allclose(signal, constant, rtol=1e-10, atol=1e-9)


def test_the_lag_follows_a_step_as_the_first_order_solution(float64):
    """u̇ = −η (u − v) for a step of v from 0 to 1 at t = 0⁺: u = 1 − exp(−η t), read through a viscous law."""
    eta = 50.0
    model = Constitutive({"coil": EFFECTS["control_lag"](control="voltage", eta=eta),
                          "damper": EFFECTS["viscous"](c={**LINEAR, "intercept": 0.0, "slope": 1.0})}).double()
    t = torch.arange(501) * 1e-4
    x = t[None].clone()  # unit velocity: the force is the lagged voltage
    v = torch.ones(1, 501)
    v[0, 0] = 0.0
    y = simulate(model, x, t=t, conditions={"voltage": v}, substeps=8, backend="fast")[0, :, 0]
    # the input is linearly interpolated over the first interval (a ramp from 0 to 1), then held
    h = 1e-4
    ramp_end = 1 - (1 - math.exp(-eta * h)) / (eta * h)
    exact = 1 - (1 - ramp_end) * torch.exp(-eta * (t - h))
    assert torch.allclose(y[1:], exact[1:], rtol=1e-9, atol=1e-10)


def test_sensitivities_with_a_control_equal_autograd(float64):
    model = _spencer_model()
    t = torch.arange(200) * 2e-4
    x = 1.5 * torch.sin(2 * math.pi * 2.5 * t)[None].expand(2, -1)
    cond = {"voltage": _voltage(2, 200, 2e-4, seed=3)}
    values = model.evaluate({"voltage": cond["voltage"]}, 2)
    y, dy, keys = simulate_jacobian(model, x, t, values=values, conditions=cond, substeps=4)
    assert ("damper", "alpha.c1") in keys and ("coil", "eta") in keys
    for j, (key, name) in enumerate(keys):
        leaf = {k: {n: v.detach().clone().requires_grad_(k == key and n == name) for n, v in d.items()}
                for k, d in values.items()}
        ref = simulate(model, x, t=t, conditions=cond, values=leaf, substeps=4, backend="fast")
        (g,) = torch.autograd.grad(ref[..., 0].sum(), [leaf[key][name]])
        assert torch.allclose(dy[..., 0, j].sum(dim=1), g, rtol=1e-7, atol=1e-9 * float(g.abs().max()) + 1e-12)


def _spencer_independent(t_eval, x, dx, v):
    """Spencer et al. 1997's equations (4)-(9) integrated by scipy's Radau at tight tolerances, written here from
    the paper (N, cm, s, V): nothing of the library's integrator, effects or parameter functions."""
    from scipy.integrate import solve_ivp

    def field(t, s):
        z, y, u = s
        alpha, c0, c1 = 140.0 + 695.0 * u, 21.0 + 3.50 * u, 283.0 + 2.95 * u
        dy = (alpha * z + c0 * dx(t) + 46.9 * (x(t) - y)) / (c0 + c1)
        dr = dx(t) - dy
        dz = -363.0 * abs(dr) * z * abs(z) - 363.0 * dr * z * z + 301.0 * dr
        return [dz, dy, -190.0 * (u - v(t))]

    sol = solve_ivp(field, (t_eval[0], t_eval[-1]), [0.0, 0.0, v(t_eval[0])], method="Radau", t_eval=t_eval,
                    rtol=1e-10, atol=1e-12, max_step=2e-4)
    z, y, u = sol.y
    c1 = 283.0 + 2.95 * u
    alpha, c0 = 140.0 + 695.0 * u, 21.0 + 3.50 * u
    dy = (alpha * z + c0 * dx(t_eval) + 46.9 * (x(t_eval) - y)) / (c0 + c1)
    return c1 * dy + 5.0 * (x(t_eval) - 14.3)


def test_spencer_config_reproduces_an_independent_solution_of_the_paper_equations(float64):
    """conf/model/mr_damper_spencer.yaml, with the paper's parameter values, driven as in its tests (2.5 Hz,
    1.5 cm) under a voltage that varies (0.25 to 2.25 V at 1 Hz) against the paper's equations solved by scipy."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    model = instantiate(OmegaConf.load("conf/model/mr_damper_spencer.yaml")).double()
    w = 2 * math.pi * 2.5
    x = lambda t: 1.5 * np.sin(w * t)  # noqa: E731
    dx = lambda t: 1.5 * w * np.cos(w * t)  # noqa: E731
    v = lambda t: 1.25 - 1.0 * np.cos(2 * math.pi * 1.0 * t)  # noqa: E731
    t = np.arange(0, 1.2, 1e-4)
    expected = _spencer_independent(t, x, dx, v)
    u = torch.tensor(np.stack([x(t), dx(t)], -1))[None]
    y = simulate(model, u, t=torch.tensor(t), conditions={"voltage": torch.tensor(v(t))[None]}, substeps=4,
                 backend="fast")[0, :, 0].detach().numpy()
    assert np.abs(y - expected).max() < 1e-4 * np.abs(expected).max()  # 7.7e-6 measured
    assert 1000 < np.abs(expected).max() < 2000  # N: the paper's damper, about ±1.5 kN at the highest voltages


def test_a_function_of_a_control_says_which_effects_act_on_the_control_it_reads():
    """A parameter after a lag and a saturation of the voltage follows what they pass on, not the measured voltage:
    the parameter table says so (the function's config stays the plain one a program builds from)."""
    table = _spencer_model().parameter_table()
    alpha = table["damper"]["alpha"]
    assert alpha["value"].endswith(", voltage after coil then limit") and alpha["function"]["condition"] == "voltage"
    assert alpha["function"] == {"kind": "linear", "slope": 695.0, "intercept": 140.0, "condition": "voltage"}
    assert table["limit"]["c_max"]["value"] == pytest.approx(3.0)  # a constant: a number
    # an effect listed before the lag reads the measured voltage
    early = Constitutive({"damper": EFFECTS["viscous"](c={**LINEAR, "intercept": 0.5, "slope": 2.0}),
                          "coil": EFFECTS["control_lag"](control="voltage", eta=50.0)}).parameter_table()
    assert "after" not in early["damper"]["c"]["value"]


def test_parameter_derivatives_of_functions_of_a_control_are_forward_ads(float64):
    """``RecordsProblem``'s reverse-mode derivatives of the parameter values w.r.t. the coordinates, for functions
    of a control (one value per coordinate, evaluated at every stage): forward-mode AD's to the last bit, with a
    coefficient held."""
    from hybridhyst.data.records import Record
    from hybridhyst.identify.problem import RecordsProblem
    from hybridhyst.identify.space import SearchSpace
    from tests.test_identify_refine import forward_mode_values

    model = _spencer_model()
    t = (torch.arange(200) * 2e-4).numpy()
    volts = _voltage(3, 200, 2e-4, seed=4).numpy()
    records = [Record(name=f"r{i}", t=t, x=1.5 * np.sin(2 * math.pi * 2.5 * t), y=np.zeros(200),
                      controls={"voltage": volts[i]}) for i in range(3)]
    held = "damper.c0.c1"
    space = SearchSpace(model, free=[n for n in SearchSpace(model).names if n != held])
    problem = RecordsProblem(space, records)
    X = space.initial()[None].expand(2, -1).clone() * torch.tensor([[1.0], [1.05]], dtype=torch.float64)
    (_, _, U, _, cond), idx = problem.groups[0], list(range(space.dim))
    got = problem._value_jacobian(X, idx, cond, U.shape[0])
    assert "alpha.c1" in got["damper"] and "c0.c0" in got["damper"]
    for k, d in forward_mode_values(space, X, idx, cond, U.shape[0]).items():
        for n, want in d.items():
            assert torch.equal(got[k][n], want), (k, n)
