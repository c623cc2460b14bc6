"""The Levenberg–Marquardt stage after Adam (``trainer.lm``, ``training.marquardt``): its normal equations are
the exact Gauss–Newton ones of the whole training records' simulation error (``Jᵀr`` is half the cost's gradient
by autograd, ``JᵀJ`` is ``Jᵀ J`` of the forward sensitivities), a step never raises the cost, the stage lowers the
training error below Adam's, and settings it cannot honour are one-line errors."""

from __future__ import annotations

import json

import pytest
import torch
from hydra import compose, initialize_config_dir

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.training.build import build_datamodule, build_module
from hybridhyst.training.marquardt import MarquardtStage

SMOKE = ["experiment=smoke", "logger=none", "nominal_init.start=none"]
DYNAMICS = [*SMOKE, "baseline=hybrid_dynamics", "freeze_nominal=false", "residual.hidden=1x6"]


def _compose(overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides)


def _stage(tmp_path, overrides=DYNAMICS):
    cfg = _compose([*overrides, f"run_dir={tmp_path}"])
    dm = build_datamodule(cfg)
    dm.setup("fit")
    module = build_module(cfg, dm)
    torch.manual_seed(0)
    with torch.no_grad():  # a network that is not zero: every weight has a derivative
        for p in module.net.net.parameters():
            p.normal_(0.0, 0.3)
    whole = dm.whole("train")
    records = [{k: v[None] for k, v in whole[i].items()} for i in range(len(whole))]
    return module, MarquardtStage(module), records


def test_normal_equations_are_the_exact_gauss_newton_ones(tmp_path, float64):
    module, stage, records = _stage(tmp_path)
    JtJ, Jtr, cost = stage.normal_equations(module, records)
    assert cost == pytest.approx(stage.cost(module, records), rel=1e-10)
    coords = [*stage.raw, *stage.weights]
    assert len(stage.raw) > 0 and len(stage.weights) > 0  # the nominal's parameters and the network's weights
    # the same cost through the simulator's adjoint: its gradient is 2 Jᵀr / n
    def residuals():
        return torch.cat([((module.simulate_nominal(b, model=module.model) - b["y"]) / module.y_scale * b["mask"])
                          .reshape(-1) for b in records])

    n = float(sum(b["mask"].sum() for b in records))
    grads = torch.autograd.grad(residuals().square().sum() / n, coords, allow_unused=True)
    g = torch.cat([torch.zeros(p.numel()) if gr is None else gr.reshape(-1) for gr, p in zip(grads, coords)])
    assert float(g.abs().max()) > 0
    torch.testing.assert_close(2.0 * Jtr / n, g, rtol=1e-7, atol=1e-9 * float(g.abs().max()))
    torch.testing.assert_close(JtJ, JtJ.T)
    # JᵀJ is Jᵀ J: along a direction v, vᵀ JᵀJ v = |J v|², J v by central differences of the residuals
    x = stage.coordinates()
    v = torch.randn(x.shape, generator=torch.Generator().manual_seed(3), dtype=torch.float64) * x.abs().clamp_min(0.1)
    h = 1e-6
    with torch.no_grad():
        stage.assign(x + h * v)
        up = residuals()
        stage.assign(x - h * v)
        down = residuals()
    stage.assign(x)
    Jv = (up - down) / (2 * h)
    assert float(v @ JtJ @ v) == pytest.approx(float(Jv.square().sum()), rel=1e-5)


def test_a_step_never_raises_the_cost(tmp_path, float64):
    module, stage, records = _stage(tmp_path)
    costs = [stage.cost(module, records)]
    for _ in range(4):
        out = stage.step(module, records)
        assert out["start_cost"] == pytest.approx(costs[-1], rel=1e-9)
        assert out["cost"] <= out["start_cost"]
        assert out["cost"] == pytest.approx(stage.cost(module, records), rel=1e-12)  # the parameters hold it
        costs.append(out["cost"])
    assert costs[-1] < 0.5 * costs[0]


def test_the_stage_lowers_the_training_error_below_adams(tmp_path):
    adam = train.run(_compose([*DYNAMICS, f"run_dir={tmp_path / 'adam'}"]))
    both = train.run(_compose([*DYNAMICS, f"run_dir={tmp_path / 'both'}", "trainer.lm.steps=3"]))
    assert both["info"]["lm_steps"] == 3 and both["info"]["lm_steps_done"] == 3
    assert both["info"]["lbfgs_steps_done"] == 0 and both["info"]["epochs"] == adam["info"]["epochs"]
    assert both["logged"]["train/lm_damping"] > 0
    # the trained models before the run's rule that keeps the start where training ends worse (here the Adam
    # epochs end above the start, a nominal near the noise; the stage brings them back down)
    assert both["start"]["trained_rmse"] < 0.8 * adam["start"]["trained_rmse"]
    saved = json.loads((tmp_path / "both" / "metrics.json").read_text())
    assert saved["info"]["lm_steps_done"] == 3
    ckpts = sorted(p.name for p in (tmp_path / "both" / "checkpoints").iterdir())
    assert ckpts == ["best.ckpt", "last.ckpt"]
    best = torch.load(tmp_path / "both" / "checkpoints" / "best.ckpt", weights_only=False)
    assert best["epoch"] == 2  # the best of both stages: the stage's last step (its epochs count from 0)
    resumed = train.run(_compose([*DYNAMICS, f"run_dir={tmp_path / 'resumed'}", "trainer.lm.steps=3",
                                  f"ckpt_path={tmp_path / 'adam' / 'checkpoints' / 'last.ckpt'}"]))
    assert resumed["start"]["trained_rmse"] == pytest.approx(both["start"]["trained_rmse"], rel=1e-9)


@pytest.mark.parametrize("overrides, match", [
    ([*DYNAMICS, "trainer.lm.steps=2", "trainer.lm.damping=0"], "trainer.lm needs"),
    ([*DYNAMICS, "trainer.lm.steps=2", "+trainer.lm.stepz=3"], r"unknown trainer.lm key\(s\) \['stepz'\]"),
    ([*DYNAMICS, "trainer.lm.steps=2", "trainer.lbfgs.steps=2"], "both set"),
    ([*DYNAMICS, "trainer.lm.steps=2", "loss.kind=mae"], "loss.kind=mae"),
    ([*SMOKE, "baseline=hybrid_mlp", "trainer.lm.steps=2"], "placement=output"),
    ([*SMOKE, "baseline=lstm", "trainer.lm.steps=2"], "module=physics or hybrid"),
    ([*DYNAMICS, "trainer.lm.steps=2", "trainer.accelerator=gpu"], "runs on the CPU"),
])
def test_settings_it_cannot_honour_are_one_line_errors(tmp_path, overrides, match):
    with pytest.raises(ValueError, match=match):
        train.run(_compose([*overrides, f"run_dir={tmp_path}"]))
    assert not (tmp_path / "checkpoints").exists()  # refused before the Adam epochs, not after them
