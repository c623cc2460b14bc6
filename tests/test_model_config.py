"""A model written as a config (``physics.model_config``) builds back into the same model: same responses, same
parameter table, after a YAML round trip; a network's weights come from the state dict."""

from __future__ import annotations

import math

import pytest
import torch
from omegaconf import OmegaConf

from hybridhyst.physics import build_model, model_config
from hybridhyst.physics.compositions import COMPOSITIONS
from hybridhyst.physics.effects import EFFECTS
from hybridhyst.physics.effects.base import ControlEffect
from hybridhyst.physics.models import conditions_used
from hybridhyst.physics.parameters import ExpRise, Linear, NeuralFunction, PerCondition
from hybridhyst.simulate import simulate

pytestmark = pytest.mark.usefixtures("float64")  # conftest: float64 default dtype, restored afterwards

LEVEL = 0.05  # the operating condition every test record is at


def _moved(model: torch.nn.Module, seed: int = 0) -> torch.nn.Module:
    """Every coordinate moved off its config default (so a config that wrote defaults would fail)."""
    g = torch.Generator().manual_seed(seed)
    for fn in model.modules():
        if hasattr(fn, "set_coordinates") and fn.coordinates():
            x = fn.coordinate_values().detach()
            fn.set_coordinates(x * (0.8 + 0.4 * torch.rand(x.shape, generator=g)) + 0.01)
    return model


def _rebuilt(model):
    text = OmegaConf.to_yaml(OmegaConf.create(model_config(model)))  # what a run directory holds
    cfg = OmegaConf.to_container(OmegaConf.create(text))
    assert cfg.pop("_target_") == "hybridhyst.physics.build_model"
    return build_model(**cfg).double()


def _response(model):
    t = torch.linspace(0, 1.0, 301)
    u = torch.stack([torch.sin(2 * math.pi * t), 0.5 * torch.sin(3 * math.pi * t)]) * 0.1
    conditions = {c: LEVEL for c in conditions_used(model)}
    for effect in model.effects.values():  # what acts on a control channel reads a signal
        if isinstance(effect, ControlEffect):
            conditions[effect.control] = LEVEL + 0.2 * u / u.abs().max()
    return simulate(model, u, t, conditions=conditions, method="heun").detach()


@pytest.mark.parametrize("name", sorted(COMPOSITIONS))
def test_every_composition_builds_back_from_its_config(name):
    model = _moved(COMPOSITIONS[name]().double())
    again = _rebuilt(model)
    assert again.describe() == model.describe()
    torch.testing.assert_close(_response(again), _response(model), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("kind", range(3), ids=["linear", "exp_rise", "per_condition"])
@pytest.mark.parametrize("effect", sorted(set(EFFECTS) - {"neural"}))
def test_every_effect_with_functions_of_a_condition_builds_back(effect, kind):
    """Each library effect added to a nominal, its first free parameter a function of a condition of each kind."""
    base = COMPOSITIONS["dahl_friction"]().double()
    added = EFFECTS[effect]()
    free = [p for p, fn in added.params.items() if fn.coordinates()]
    if free:
        value = float(added.params[free[0]](None, 1)[0].detach()) or 0.1
        kinds = [Linear(0.3 * value, value, "current"), ExpRise(value, 0.5 * value, 3.0, "current"),
                 PerCondition([LEVEL, 0.5], [value, 2 * value], "current")]
        added.params[free[0]] = kinds[kind]
    model = _moved(base.augmented({"added": added.double()}), seed=1)
    again = _rebuilt(model)
    assert again.describe() == model.describe()
    torch.testing.assert_close(_response(again), _response(model), rtol=1e-12, atol=1e-12)


def test_a_network_is_written_as_its_form_and_loaded_with_its_weights():
    base = COMPOSITIONS["dahl_friction"]().double()
    net = EFFECTS["neural"](inputs=("x", "v"), latent_states=1, hidden=[6, 5], scales={"x": 2.0, "F": 3.0},
                           conditions={"current": (0.3, 0.1)}).double()
    base.effects["dahl"].params["sigma0"] = NeuralFunction(2.0, "current", hidden=4)
    model = base.augmented({"net": net})
    for p in model.parameters():  # non-zero weights everywhere, so an unloaded copy differs (a positive shift keeps
        p.data.add_(0.05 * torch.rand_like(p))  # every physical parameter in its domain: c, σ0, Fc >= 0)
    again = _rebuilt(model)
    assert not torch.allclose(_response(again), _response(model))
    again.load_state_dict(model.state_dict())
    torch.testing.assert_close(_response(again), _response(model), rtol=1e-12, atol=1e-12)


def test_a_networks_scales_are_written_from_its_state_not_its_constructor():
    """A state dict loaded after construction sets the scales and condition normalisation; the config written
    afterwards must carry them (not the constructor's), so the rebuilt model needs no state dict for them."""
    made = EFFECTS["neural"](inputs=("x", "v"), scales={"x": 1.0, "v": 1.0, "F": 1.0}, conditions={"I": (0.0, 1.0)})
    saved = EFFECTS["neural"](inputs=("x", "v"), scales={"x": 2.0, "v": 8.0, "F": 3.0}, conditions={"I": (0.5, 0.2)})
    made.load_state_dict(saved.state_dict())
    assert made.options()["scales"] == saved.options()["scales"] == {"x": 2.0, "v": 8.0, "F": 3.0}
    assert made.options()["conditions"] == saved.options()["conditions"] == {"I": [0.5, 0.2]}
    for inputs in (("x",), ("v",)):  # the scale of x or v that is not an input comes from the rate scale s_v / s_x
        made = EFFECTS["neural"](inputs=inputs, scales={"x": 1.0, "v": 1.0, "F": 1.0})
        made.load_state_dict(EFFECTS["neural"](inputs=inputs, scales={"x": 2.0, "v": 8.0, "F": 3.0}).state_dict())
        assert made.options()["scales"] == {"x": 2.0, "v": 8.0, "F": 3.0}, inputs


def test_a_model_crosses_to_a_worker_process_as_its_config_and_state():
    """multiprocessing's pickler (what discovery's forked workers send back): torch's parametrized modules refuse
    to pickle, so a model goes as its config and state dict; it comes back equal in every tensor, its dtype and its
    response, a network's weights included. ``copy.deepcopy`` is left as torch has it (a frozen parameter stays
    frozen)."""
    import copy
    from multiprocessing.reduction import ForkingPickler

    import hybridhyst.discover.fitting  # noqa: F401 - registers the structures with the pickler

    base = COMPOSITIONS["dahl_friction"]().double()
    base.effects["dahl"].params["sigma0"] = NeuralFunction(2.0, "current", hidden=4)
    model = _moved(base.augmented({"net": EFFECTS["neural"](inputs=("x", "v"), latent_states=1, hidden=[5]).double(),
                                   "play": EFFECTS["backlash"]().double()}), seed=2)
    for p in model.parameters():
        p.data.add_(0.05 * torch.rand_like(p))
    again = ForkingPickler.loads(ForkingPickler.dumps(model))
    assert type(again) is type(model) and again.describe() == model.describe()
    state, back = model.state_dict(), again.state_dict()
    assert list(back) == list(state)
    for key, value in state.items():
        assert back[key].dtype == value.dtype and torch.equal(back[key], value), key
    assert torch.equal(_response(again), _response(model))
    plain = COMPOSITIONS["dahl_friction"]().double()
    next(plain.parameters()).requires_grad_(False)
    assert not next(copy.deepcopy(plain).parameters()).requires_grad
