"""The L-BFGS stage after Adam (``trainer.lbfgs``): one step equals torch's L-BFGS on the whole batch in one pass
(the chunked loss and gradient are the full-batch mean), the stage lowers the training loss and keeps the best
checkpoint of both stages, a run resumed after the Adam epochs ends where an uninterrupted one does, and bad
settings are one-line errors; a diverging trial step makes the line search back off (``optim``)."""

from __future__ import annotations

import copy
import json
import math

import pytest
import torch
from hydra import compose, initialize_config_dir

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.optim import line_search_loss
from hybridhyst.training.build import build_datamodule, build_module, build_trainer

SMOKE = ["experiment=smoke", "logger=none", "nominal_init.start=none", "baseline=hybrid_mlp"]


def _compose(overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides)


def test_one_lbfgs_step_is_torchs_lbfgs_on_the_whole_batch(tmp_path, float64):
    cfg = _compose([*SMOKE, f"run_dir={tmp_path}", "trainer.lbfgs.steps=1", "trainer.lbfgs.max_iter=3",
                    "datamodule.batch_size=2"])
    dm = build_datamodule(cfg)
    dm.setup("fit")
    module = build_module(cfg, dm)
    reference, start = copy.deepcopy(module), copy.deepcopy(module)
    windows = len(dm.train_dataloader().dataset)
    assert windows > 2  # more than one chunk of 2 windows
    module.use_lbfgs(max_iter=3, history_size=50, chunk=dm.batch_size)
    dm.batch_size = windows
    first = build_trainer(cfg, tmp_path, callbacks=[])  # only for its best-checkpoint callback
    build_trainer(cfg, tmp_path, after=first).fit(module, dm)
    batch = next(iter(dm.train_dataloader()))
    params = [p for p in reference.parameters() if p.requires_grad]
    opt = torch.optim.LBFGS(params, lr=1.0, max_iter=3, history_size=50, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        loss = reference._objective(batch)  # the whole batch in one pass
        loss.backward()
        return loss

    opt.step(closure)
    for (name, a), b in zip(module.named_parameters(), reference.parameters()):
        torch.testing.assert_close(a, b, rtol=1e-6, atol=1e-9, msg=name)  # summation order aside
    assert any(not torch.equal(a, b) for a, b in zip(module.parameters(), start.parameters()))  # it moved


def test_the_stage_lowers_the_training_error_and_a_resumed_run_repeats_it(tmp_path):
    adam = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'adam'}"]))
    both = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'both'}", "trainer.lbfgs.steps=3"]))
    assert both["info"]["lbfgs_steps"] == 3 and both["info"]["lbfgs_steps_done"] == 3
    assert both["info"]["epochs"] == adam["info"]["epochs"]
    assert both["logged"]["train/lbfgs_evaluations"] >= 1
    assert both["val"] == {} and both["train"]["rmse"] < adam["train"]["rmse"]  # validated on training records
    ckpts = sorted(p.name for p in (tmp_path / "both" / "checkpoints").iterdir())
    assert ckpts == ["best.ckpt", "last.ckpt"]
    last = torch.load(tmp_path / "both" / "checkpoints" / "last.ckpt", weights_only=False)
    assert last["epoch"] == adam["info"]["epochs"] - 1  # last.ckpt stays the end of the Adam epochs
    resumed = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'resumed'}", "trainer.lbfgs.steps=3",
                                  f"ckpt_path={tmp_path / 'adam' / 'checkpoints' / 'last.ckpt'}"]))
    assert resumed["train"]["rmse"] == pytest.approx(both["train"]["rmse"], rel=1e-9)
    assert resumed["test"]["rmse"] == pytest.approx(both["test"]["rmse"], rel=1e-9)
    saved = json.loads((tmp_path / "both" / "metrics.json").read_text())
    assert saved["info"]["lbfgs_steps"] == 3


@pytest.mark.parametrize("override, match", [
    ("trainer.lbfgs.max_iter=0", "trainer.lbfgs needs"),
    ("trainer.lbfgs.steps=-1", "trainer.lbfgs needs"),
    ("+trainer.lbfgs.stepz=3", r"unknown trainer.lbfgs key\(s\) \['stepz'\]"),
    ("~trainer.lbfgs.max_iter", "trainer.lbfgs.max_iter is missing"),
    ("trainer.strategy=ddp", "trainer.lbfgs runs in one process"),
])
def test_bad_lbfgs_settings_are_one_line_errors(override, match, tmp_path):
    with pytest.raises(ValueError, match=match):
        train.run(_compose([*SMOKE, f"run_dir={tmp_path}", "trainer.lbfgs.steps=2", override]))


def test_a_line_search_into_diverged_simulations_keeps_the_weights_it_started_from(tmp_path, float64):
    cfg = _compose([*SMOKE, f"run_dir={tmp_path}", "trainer.lbfgs.steps=1"])
    dm = build_datamodule(cfg)
    dm.setup("fit")
    module = build_module(cfg, dm)
    start = copy.deepcopy(module)
    module.use_lbfgs(max_iter=5, history_size=10, chunk=dm.batch_size)
    windows = len(dm.train_dataloader().dataset)
    chunks = -(-windows // dm.batch_size)  # objective calls of the first loss evaluation
    dm.batch_size = windows
    honest, calls = module._objective, []

    def diverging(batch, log=False, share=(1.0, 1.0, True)):  # finite at the start, diverged at any trial point
        calls.append(1)
        return honest(batch, log, share) if len(calls) <= chunks else None

    module._objective = diverging
    trainer = build_trainer(cfg, tmp_path, after=build_trainer(cfg, tmp_path))
    trainer.fit(module, dm)
    assert len(calls) > chunks  # trial points were tried and found diverged
    for a, b in zip(module.parameters(), start.parameters()):
        assert torch.equal(a, b)  # no step into them


@pytest.mark.parametrize("rule", ["line_search_loss", "inf"])
def test_a_diverging_trial_step_makes_the_line_search_back_off(rule):
    """f(x) = (x − 0.5)² with a wall at x > 0.6 where the 'simulation' diverges; L-BFGS's first trial from x = 0
    lands at x = 1, beyond it. The shared rule (a large finite loss) lets the search back off and converge; inf,
    what the closures returned before, leaves the step stuck at its start after spending its evaluations."""
    x = torch.zeros(1, dtype=torch.float64, requires_grad=True)
    opt = torch.optim.LBFGS([x], lr=1.0, max_iter=50, line_search_fn="strong_wolfe")
    best, calls = [math.inf], [0]

    def closure():
        calls[0] += 1
        opt.zero_grad()
        if float(x) > 0.6:
            value = torch.tensor(math.inf, dtype=torch.float64)
            return line_search_loss(value, best[0]) if rule == "line_search_loss" else value
        f = (x - 0.5).square().sum()
        f.backward()
        best[0] = min(best[0], float(f))
        return f

    opt.step(closure)
    if rule == "line_search_loss":
        assert best[0] < 1e-12 and calls[0] < 15
    else:
        assert best[0] == pytest.approx(0.25) and calls[0] > 50


@pytest.mark.parametrize("unit", [1.0, 1e-5])
def test_fit_gradient_lbfgs_does_not_depend_on_the_outputs_unit(unit, float64):
    """A response in metres (the Bouc-Wen benchmark's 1e-5 m) has a mean squared error near 1e-10 and gradients
    below torch's L-BFGS tolerance (1e-7): the search must not stop at its start because of the unit (the
    leftover network's weights, O(1) whatever the unit, stayed at zero on that benchmark)."""
    import numpy as np

    from hybridhyst.data.records import Record
    from hybridhyst.identify.gradient import fit_gradient
    from hybridhyst.physics.effects import EFFECTS
    from hybridhyst.physics.models import Constitutive

    t = np.linspace(0.0, 2.0, 201)
    x = unit * np.sin(2 * np.pi * t)
    record = Record(name="r", t=t, x=x, y=3.0 * x + 0.2 * unit * 2 * np.pi * np.cos(2 * np.pi * t))
    model = Constitutive({"spring": EFFECTS["linear_stiffness"](k=1.0), "viscous": EFFECTS["viscous"](c=1.0)}).double()
    fit = fit_gradient(model, [record], steps=0, lbfgs_steps=30, progress=False)
    k = float(model.effects["spring"].params["k"](None, 1)[0])
    c = float(model.effects["viscous"].params["c"](None, 1)[0])
    assert k == pytest.approx(3.0, rel=1e-3) and c == pytest.approx(0.2, rel=1e-2)
    assert fit.loss < 1e-6 * fit.history[0]
