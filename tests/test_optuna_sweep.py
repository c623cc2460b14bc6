"""sweep=optuna: Hydra's Optuna sweeper searches architecture, lambda_phys and learning rate over
hybridhyst-train jobs. The config composes into the search space it promises; each job returns its
validation RMSE (train RMSE without a validation split) to the sweeper, which writes the best one to
optimization_results.yaml; a failing job scores +inf instead of ending the study."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest
import yaml
from hydra import compose, initialize_config_dir

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR

pytest.importorskip("hydra_plugins.hydra_optuna_sweeper")

SMOKE = ["experiment=smoke", "logger=none", "predictions=false"]
SEARCHED = {"residual.hidden", "loss.lambda_phys", "trainer.lr"}


def _compose(overrides, hydra_cfg=False):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides, return_hydra_config=hydra_cfg)


def _sweep(tmp_path, *overrides, n_trials=2):
    """``hybridhyst-train -m sweep=optuna`` in a subprocess; (process, sweep dir)."""
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "hybridhyst.cli.train", "-m", "sweep=optuna", f"hydra.sweeper.n_trials={n_trials}",
           *SMOKE, *overrides, f"hydra.sweep.dir={out}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONWARNINGS": "ignore"},
                          timeout=300)
    return proc, out


def test_optuna_sweep_composes_into_the_promised_search_space():
    from hydra_plugins.hydra_optuna_sweeper._impl import create_params_from_overrides
    from optuna.distributions import CategoricalDistribution, LogUniformDistribution

    cfg = _compose(["sweep=optuna"], hydra_cfg=True)
    sweeper = cfg.hydra.sweeper
    assert sweeper._target_.endswith("OptunaSweeper")
    assert sweeper.sampler._target_ == "optuna.samplers.TPESampler" and sweeper.sampler.seed == 0
    assert sweeper.direction == "minimize" and sweeper.n_jobs == 1 and sweeper.n_trials >= 10
    assert set(sweeper.params) == SEARCHED
    space, fixed = create_params_from_overrides([f"{k}={v}" for k, v in sweeper.params.items()])
    assert not fixed and set(space) == SEARCHED
    assert isinstance(space["residual.hidden"], CategoricalDistribution)
    assert "4x128" in space["residual.hidden"].choices  # the default architecture is a candidate
    for key in ("loss.lambda_phys", "trainer.lr"):
        assert isinstance(space[key], LogUniformDistribution), key
    assert space["trainer.lr"].low < cfg.trainer.lr < space["trainer.lr"].high  # the default lr is inside


def test_the_job_returns_train_rmse_without_a_validation_split(tmp_path):
    cfg = _compose([*SMOKE, "split.val=null", f"run_dir={tmp_path}"])
    value = train._hydra_main(cfg)  # @hydra.main passes a given config straight to the function
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["status"] == "ok" and not metrics["val"]
    assert value == metrics["train"]["rmse"] and math.isfinite(value)


def test_optuna_multirun_samples_trials_and_records_the_best_validation_rmse(tmp_path):
    # 0.03 and 0.07 MPa train, 0.05 validates: with one training pressure the nominal's slopes in p are the search
    # box's, and how the trained model extrapolates to the held-out 0.07 MPa (diverged on one machine) is chance
    proc, out = _sweep(tmp_path, "split.val=[{pressure_mpa: [0.05]}]", "split.held_out=[]")
    assert proc.returncode == 0, proc.stderr[-3000:]
    jobs = sorted(p for p in out.iterdir() if p.is_dir())
    assert [p.name for p in jobs] == ["0", "1"]
    metrics = [json.loads((p / "metrics.json").read_text()) for p in jobs]
    assert all(m["status"] == "ok" and m["val"] for m in metrics)
    sampled = []
    for job in jobs:
        overrides = dict(o.split("=", 1) for o in yaml.safe_load((job / ".hydra" / "overrides.yaml").read_text()))
        assert SEARCHED <= set(overrides)
        config = yaml.safe_load((job / "config.yaml").read_text())  # the job ran with the sampled values
        assert config["trainer"]["lr"] == pytest.approx(float(overrides["trainer.lr"]))
        assert config["loss"]["lambda_phys"] == pytest.approx(float(overrides["loss.lambda_phys"]))
        assert config["residual"]["hidden"] == overrides["residual.hidden"]
        assert 1e-4 <= config["loss"]["lambda_phys"] <= 1.0 and 3e-4 <= config["trainer"]["lr"] <= 3e-2
        sampled.append(tuple(overrides[k] for k in sorted(SEARCHED)))
    assert sampled[0] != sampled[1]
    best = yaml.safe_load((out / "optimization_results.yaml").read_text())
    assert best["name"] == "optuna" and set(best["best_params"]) == SEARCHED
    assert best["best_value"] == pytest.approx(min(m["val"]["rmse"] for m in metrics), rel=1e-12)


def test_a_failing_trial_scores_inf_and_the_study_goes_on(tmp_path):
    proc, out = _sweep(tmp_path, "loss.lambda_phys=-1")  # fixed on the command line: out of the search space
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "lambda_phys must be >= 0" in proc.stderr
    for job in ("0", "1"):  # both ran (the study did not stop at the first) and each says why it failed
        failed = json.loads((out / job / "metrics.json").read_text())
        assert failed["status"] == "failed" and "lambda_phys" in failed["error"]
    best = yaml.safe_load((out / "optimization_results.yaml").read_text())
    assert best["best_value"] == math.inf and "loss.lambda_phys" not in best["best_params"]
