"""Numerics of the one simulator: known solutions, convergence order, solver agreement, gradients."""

import math
from pathlib import Path

import numpy as np
import pytest
import torch
from torch.nn.utils.stateless import _reparametrize_module

from hybridhyst.physics import build_model
from hybridhyst.physics.compositions import COMPOSITIONS
from hybridhyst.physics.effects import LinearStiffness, Viscous
from hybridhyst.physics.models import DrivenOscillator
from hybridhyst.simulate import ORDER, simulate


def _damped_oscillator(c=0.4, k=4.0, m=1.0):
    return DrivenOscillator([Viscous(c=c), LinearStiffness(k=k)], mass=m)


def _exact_free(t, c=0.4, k=4.0, m=1.0, x0=1.0):
    zeta_w = c / (2 * m)
    wd = math.sqrt(k / m - zeta_w**2)
    return torch.exp(-zeta_w * t) * (x0 * torch.cos(wd * t) + x0 * zeta_w / wd * torch.sin(wd * t))


def test_free_damped_oscillator_matches_closed_form(float64):
    t = torch.linspace(0, 5, 501)
    y = simulate(_damped_oscillator(), torch.zeros(1, 501), t=t, initial_state=[[1.0, 0.0]])
    assert torch.allclose(y[0, :, 0], _exact_free(t), atol=1e-8)


def test_forced_response_matches_steady_state_amplitude(float64):
    # x'' + 0.4 x' + 4 x = sin(w t): steady-state amplitude 1 / sqrt((k - w²)² + (c w)²)
    w, n = 1.3, 1601
    t = torch.linspace(0, 80, n)
    y = simulate(_damped_oscillator(), torch.sin(w * t)[None], t=t, substeps=2)[0, :, 0]
    amp = y[t > 60].abs().max().item()
    assert amp == pytest.approx(1 / math.sqrt((4 - w**2) ** 2 + (0.4 * w) ** 2), rel=1e-3)


@pytest.mark.parametrize("method", sorted(ORDER))
def test_convergence_order(method, float64):
    """Error of each explicit scheme falls as h^order on a smooth problem."""
    model = _damped_oscillator()
    errors = []
    for n in (41, 81, 161):
        t = torch.linspace(0, 4, n)
        y = simulate(model, torch.zeros(1, n), t=t, initial_state=[[1.0, 0.0]], method=method)
        errors.append((y[0, -1, 0] - _exact_free(t[-1:])[0]).abs().item())
    observed = [math.log2(errors[i] / errors[i + 1]) for i in range(2)]
    assert observed[-1] == pytest.approx(ORDER[method], abs=0.3), observed


def test_substeps_equal_a_finer_grid(float64):
    model = _damped_oscillator()
    t = torch.linspace(0, 4, 41)
    coarse = simulate(model, torch.zeros(1, 41), t=t, initial_state=[[1.0, 0.0]], substeps=4)
    fine_t = torch.linspace(0, 4, 161)
    fine = simulate(model, torch.zeros(1, 161), t=fine_t, initial_state=[[1.0, 0.0]])
    assert torch.allclose(coarse[0, :, 0], fine[0, ::4, 0], atol=1e-12)


def test_torchdiffeq_agrees_with_fixed_step(float64):
    model = COMPOSITIONS["boucwen_benchmark"]().double()
    t = torch.arange(120) / 750.0
    u = 50 * torch.sin(2 * math.pi * 20 * t)[None]
    fixed = simulate(model, u, t=t, substeps=8)
    adaptive = simulate(model, u, t=t, solver="torchdiffeq", rtol=1e-7, atol=1e-10)
    assert torch.allclose(fixed, adaptive, atol=2e-4 * fixed.abs().max().item())


def test_adjoint_gradient_matches_direct(float64):
    model = _damped_oscillator().double()
    t = torch.linspace(0, 2, 21)
    u = torch.sin(3 * t)[None]
    grads = []
    for adjoint in (False, True):
        model.zero_grad()
        y = simulate(model, u, t=t, solver="torchdiffeq", adjoint=adjoint, rtol=1e-6, atol=1e-8)
        (y**2).sum().backward()
        grads.append(torch.cat([p.grad.flatten() for p in model.parameters()]))
    assert torch.allclose(grads[0], grads[1], rtol=1e-4)


# Per composition: a short input in its own units and conditions, on a grid fine enough to be stable.
GRADCHECK_CASES = {
    "vpptd_algebraic": dict(amp=10.0, freq=0.8, dt=2e-3, n=40, cond=None),
    "modified_bouc_wen": dict(amp=10.0, freq=0.79, dt=2e-3, n=40, cond={"pressure_mpa": [0.03, 0.07]}),
    "vpptd_rig": dict(amp=10.0, freq=0.3, dt=2e-3, n=40, cond={"pressure_mpa": [0.03, 0.07]}),
    "bouc_wen_p": dict(amp=0.01, freq=0.5, dt=1e-3, n=40, cond={"pressure_mpa": [0.01, 0.04]}),
    "bouc_wen_classic": dict(amp=1.0, freq=1.0, dt=2e-3, n=40, cond=None),
    "piezo_attenuation": dict(amp=50.0, freq=10.0, dt=2e-5, n=40, cond=None),
    "dahl_friction": dict(amp=1.0, freq=1.0, dt=2e-3, n=40, cond=None),
    "lugre_friction": dict(amp=1.0, freq=1.0, dt=2e-3, n=40, cond=None),
    "boucwen_benchmark": dict(amp=50.0, freq=20.0, dt=1 / 750, n=40, cond=None),
}


def test_every_composition_has_a_gradcheck_case():
    assert set(GRADCHECK_CASES) == set(COMPOSITIONS)


@pytest.mark.parametrize("name", sorted(GRADCHECK_CASES))
def test_gradcheck_every_composition(name, float64):
    """d(response)/d(every raw parameter) by autograd equals central differences (float64)."""
    case = GRADCHECK_CASES[name]
    model = COMPOSITIONS[name]().double()
    names = [n for n, _ in model.named_parameters()]
    params = tuple(p.detach().clone().requires_grad_() for _, p in model.named_parameters())
    assert params, f"{name} has no trainable parameters"
    cond = {k: torch.tensor(v) for k, v in case["cond"].items()} if case["cond"] else None
    batch = 2 if cond else 1
    t = torch.arange(case["n"]) * case["dt"]
    u = (case["amp"] * torch.sin(2 * math.pi * case["freq"] * t + 0.3)).expand(batch, -1)

    def response(*ps):
        with _reparametrize_module(model, dict(zip(names, ps))):
            return simulate(model, u, t=t, conditions=cond, initial_state=None)

    assert torch.isfinite(response(*params)).all()
    assert torch.autograd.gradcheck(response, params, eps=1e-6, atol=1e-5, rtol=1e-4, fast_mode=True)


MODEL_CONFIGS = sorted((Path(__file__).parents[1] / "conf" / "model").glob("*.yaml"))


@pytest.mark.parametrize("path", MODEL_CONFIGS, ids=[p.stem for p in MODEL_CONFIGS])
def test_every_model_config_instantiates_and_simulates(path, float64):
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    model = instantiate(OmegaConf.load(path)).double()
    t = torch.arange(50) * 1e-3
    cond = {"pressure_mpa": torch.tensor([0.05]), "voltage": torch.linspace(0.0, 1.0, 50)[None]}  # (a control)
    y = simulate(model, 0.1 * torch.sin(2 * math.pi * t)[None], t=t, conditions=cond)
    assert y.shape == (1, 50, model.output_dim) and torch.isfinite(y).all()
    described = model.describe()
    for key, effect in model.effects.items():  # every parameter is described with a value and a rendered unit
        assert set(described[key]) == set(effect.params)
        assert all(d["value"] and d["unit"] for d in described[key].values())


def test_records_input_returns_one_tensor_per_record(float64):
    from hybridhyst.data.records import Record

    model = build_model("constitutive", {"v": {"effect": "viscous", "c": 2.0}}).double()
    t1, t2 = np.linspace(0, 1, 101), np.linspace(0, 2, 51)
    recs = [Record("a", t1, np.sin(t1), np.zeros(101)), Record("b", t2, t2, np.zeros(51))]
    out = simulate(model, recs)
    assert [o.shape for o in out] == [(101, 1), (51, 1)]
    assert torch.allclose(out[1][:, 0], torch.full((51,), 2.0), atol=1e-9)  # c · d(t)/dt


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(inputs=torch.zeros(1, 1), dt=0.1), "at least 2"),
        (dict(inputs=torch.tensor([[0.0, float("nan"), 1.0]]), dt=0.1), "NaN"),
        (dict(inputs=torch.zeros(1, 3), t=torch.tensor([0.0, 0.2, 0.1])), "strictly increasing"),
        (dict(inputs=torch.zeros(1, 3)), "dt"),
        (dict(inputs=torch.zeros(1, 3), dt=0.1, method="rk7"), "rk7"),
        (dict(inputs=torch.zeros(1, 3), dt=0.1, solver="magic"), "magic"),
    ],
)
def test_bad_simulation_input_is_a_clear_error(kwargs, message):
    model = build_model("constitutive", {"v": {"effect": "viscous", "c": 2.0}})
    with pytest.raises(ValueError, match=message):
        simulate(model, **kwargs)


def test_unknown_effect_and_condition_are_clear_errors():
    with pytest.raises(ValueError, match="did you mean 'viscous'"):
        build_model("constitutive", {"v": {"effect": "viscus"}})
    model = build_model("constitutive", {"v": {"effect": "viscous",
                                               "c": {"kind": "linear", "slope": 1.0, "intercept": 0.0}}})
    with pytest.raises(ValueError, match="pressure_mpa"):
        simulate(model, torch.zeros(1, 5), dt=0.1)


def test_driven_convergence_is_second_order_in_the_sample_interval(float64):
    """With the input known at samples only (linear inside each interval), a driven model converges as
    h² whatever the scheme's own order (documented in ``simulate``)."""
    model = _damped_oscillator()
    w = 1.7

    def final_x(n):
        t = torch.linspace(0, 4, n)
        u = torch.stack([torch.sin(w * t), w * torch.cos(w * t), -(w**2) * torch.sin(w * t)], dim=-1)[None]
        return simulate(model, u, t=t, backend="fast")[0, -1, 0]  # the reference equals it: tests/test_fast.py

    exact = final_x(6401)
    errors = [(final_x(n) - exact).abs().item() for n in (101, 201, 401)]
    observed = math.log2(errors[1] / errors[2])
    assert observed == pytest.approx(2.0, abs=0.3), errors


def test_records_on_different_grids_are_not_batched_together(float64):
    from hybridhyst.data.records import Record

    model = build_model("constitutive", {"v": {"effect": "viscous", "c": 1.0}}).double()
    ta = np.linspace(0, 1, 11)
    tb = np.r_[0.0, np.linspace(0.5, 1, 10)]  # same length and end points, other grid
    a, b = Record("a", ta, ta, np.zeros(11)), Record("b", tb, tb, np.zeros(11))
    together = simulate(model, [a, b])
    alone = simulate(model, [b])
    assert torch.allclose(together[1], alone[0])
    assert torch.allclose(together[1][:, 0], torch.ones(11), atol=1e-9)  # c · dx/dt with x = t


def dahl_force(t, amplitude, sigma0, Fc, refine=20):
    """Dahl's force under x = A sin(2π t) from the test bed's exact solution along a refined path (numpy, no
    integrator: ``testbed.generators.dahl_exact``)."""
    from hybridhyst.testbed.generators import dahl_exact, fine_grid

    fine = fine_grid(t, refine)
    return sigma0 * dahl_exact(amplitude * np.sin(2 * np.pi * fine), sigma0, Fc)[::refine]


def test_simulate_resolved_takes_the_steps_a_stiffer_record_needs(float64):
    """A Dahl bristle relaxes at σ0 |v| / Fc: resolved on a ±1 sine, the same model on a ±4 sine diverges at
    those sub-steps. ``simulate_resolved`` doubles them for that record and matches the exact solution; on the
    record it was resolved on it keeps its sub-steps and its output."""
    from hybridhyst.data import Record
    from hybridhyst.physics.effects import Dahl
    from hybridhyst.physics.models import Constitutive
    from hybridhyst.simulate import resolved_substeps, simulate_resolved
    from hybridhyst.simulate.api import RESOLVED

    model = Constitutive({"dahl": Dahl(sigma0=100.0, Fc=1.0)}, units={"t": "s", "x": "in", "F": "kip"})
    t = np.arange(0.0, 2.0, 0.01)
    fitted, other = (Record(name=f"A{a}", t=t, x=a * np.sin(2 * np.pi * t), y=np.zeros_like(t)) for a in (1.0, 4.0))
    opts = {"method": "rk4", "backend": "fast"}
    s, _ = resolved_substeps(model, [fitted], substeps=1, **opts)
    with torch.no_grad():
        plain = simulate(model, [other], substeps=s, **opts)[0][:, 0]
    assert not (torch.isfinite(plain).all() and plain.abs().max() < 10.0)  # diverges at the fitted record's steps
    (out,), sub, change = simulate_resolved(model, [other], substeps=s, **opts)
    assert sub > s and change <= RESOLVED
    assert np.sqrt(np.mean((out[:, 0].numpy() - dahl_force(t, 4.0, 100.0, 1.0)) ** 2)) < 2e-3
    (same,), s_same, _ = simulate_resolved(model, [fitted], substeps=s, **opts)
    with torch.no_grad():
        assert s_same == s and torch.equal(same, simulate(model, [fitted], substeps=s, **opts)[0])


def test_coarsest_substeps_halves_back_to_the_steps_a_model_needs(float64):
    """``coarsest_substeps``: step doubling downwards. A Dahl bristle that needs several sub-steps on a ±4 sine,
    given more, is halved back to the count doubling from one finds (every halving judged as a doubling is);
    the same count is kept; a model without a stiff state (a spring and a damper) goes down to one."""
    from hybridhyst.data import Record
    from hybridhyst.physics.effects import Dahl, LinearStiffness, Viscous
    from hybridhyst.physics.models import Constitutive
    from hybridhyst.simulate import coarsest_substeps, resolved_substeps

    t = np.arange(0.0, 2.0, 0.01)
    record = Record(name="A4", t=t, x=4.0 * np.sin(2 * np.pi * t), y=np.zeros_like(t))
    opts = {"method": "rk4", "backend": "fast"}
    stiff = Constitutive({"dahl": Dahl(sigma0=100.0, Fc=1.0)}, units={"t": "s", "x": "in", "F": "kip"})
    needed, _ = resolved_substeps(stiff, [record], substeps=1, max_substeps=64, **opts)
    assert 1 < needed < 32
    assert coarsest_substeps(stiff, [record], 32, **opts) == needed
    assert coarsest_substeps(stiff, [record], needed, **opts) == needed
    assert coarsest_substeps(stiff, [record], 1, **opts) == 1
    plain = Constitutive({"spring": LinearStiffness(k=2.0), "damper": Viscous(c=0.1)})
    assert coarsest_substeps(plain, [record], 16, **opts) == 1
    assert coarsest_substeps(plain, [record], 12, **opts) == 3  # halving stops at an odd count
    assert coarsest_substeps(plain, [record], 3, **opts) == 3
