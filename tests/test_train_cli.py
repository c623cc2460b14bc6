"""hybridhyst-train: every config of every group composes (and instantiates where the hardware exists), a
run writes its directory, runs are deterministic and resumable, TensorBoard gets the promised tags, and a
multirun with one failing job keeps the others' results (and the report lists the failure)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate as hydra_instantiate

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.nets import build_net
from hybridhyst.physics.models import NominalModel, conditions_used

CONF = Path(CONF_DIR)
GROUPS = ["data", "model", "residual", "loss", "trainer", "logger", "baseline", "sweep", "experiment"]
SMOKE = ["experiment=smoke", "logger=none", "nominal_init.method=none"]  # the identified start: test_train_convergence


def _compose(overrides, hydra_cfg=False):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides, return_hydra_config=hydra_cfg)


def _options(group):
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))


@pytest.mark.parametrize("group", GROUPS)
def test_every_config_of_every_group_composes_and_instantiates(group, tmp_path):
    assert _options(group), f"conf/{group} is empty"
    for option in _options(group):
        cfg = _compose([f"{group}={option}", f"run_dir={tmp_path}"], hydra_cfg=group == "sweep")
        if group == "model":  # a nominal model whose parameters evaluate to finite numbers
            model = hydra_instantiate(cfg.model, _convert_="all").double()
            assert isinstance(model, NominalModel) and model.parameter_table(), option
            values = model.evaluate({c: torch.full((2,), 0.05) for c in conditions_used(model)}, 2)
            assert values and all(torch.isfinite(v).all() for p in values.values() for v in p.values()), option
        elif group == "residual":  # maps (batch, time, features) to (batch, time, 1), zero at the start
            net = build_net(cfg.residual.kind, 3, 1, cfg.residual.hidden, cfg.residual.activation).double()
            out = net(torch.randn(2, 7, 3, dtype=torch.float64))
            assert out.shape == (2, 7, 1) and torch.count_nonzero(out) == 0, option
        elif group == "sweep":
            assert cfg.hydra.sweeper.params, f"sweep={option} sweeps nothing"
        elif group in ("trainer", "logger") and cfg.trainer.accelerator == "cpu":
            assert train.build_trainer(cfg, tmp_path).max_epochs == cfg.trainer.max_epochs
        elif group in ("trainer",):
            assert cfg.trainer.accelerator == "gpu"  # gpu/ddp: composed only (CI has no GPU)
        elif group == "data" and option != "table":  # table needs data.path (tested in test_data.py)
            assert len(hydra_instantiate(cfg.data, _convert_="all")) > 0
        elif group in ("baseline", "loss"):  # the module each builds, on the smoke data
            small = _compose([*SMOKE, f"{group}={option}", f"run_dir={tmp_path}"])
            dm = train.build_datamodule(small)
            module = train.build_module(small, dm)
            assert module.kind == small.module and module.n_parameters() > 0
            assert train.info(small)["placement"] == (small.placement if small.module == "hybrid" else None)
    if group == "experiment":
        for option in _options(group):  # every training experiment's data and split are consistent
            cfg = _compose([f"experiment={option}"])
            if cfg.app != "train":
                with pytest.raises(ValueError, match=f"is for hybridhyst-{cfg.app}, not hybridhyst-train"):
                    train.run(cfg)
                continue
            dm = train.build_datamodule(cfg)
            assert len(dm.records("train")) and len(dm.records("test"))


@pytest.mark.parametrize("launcher,target", [("local", "JoblibLauncher"), ("slurm", "SlurmLauncher")])
def test_launcher_configs_instantiate(launcher, target):
    cfg = _compose([f"hydra/launcher={launcher}"], hydra_cfg=True)
    assert cfg.hydra.launcher._target_.endswith(target)
    assert type(hydra_instantiate(cfg.hydra.launcher)).__name__ == target


@pytest.mark.parametrize("baseline", ["physics", "hybrid_mlp", "hybrid_lstm", "mlp", "lstm", "std_pinn"])
def test_run_writes_the_run_directory(baseline, tmp_path):
    result = train.run(_compose([*SMOKE, f"baseline={baseline}", f"run_dir={tmp_path}"]))
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["status"] == "ok" and math.isfinite(metrics["test"]["rmse"])
    assert set(metrics) >= {"test", "val", "train", "info", "physics"} and metrics["val"] == {}
    assert set(metrics["test"]) >= {"rmse", "mae", "nrmse", "per_condition"}
    assert list(metrics["test"]["per_condition"]) == ["mixture=1:3, pressure_mpa=0.07"]
    assert metrics["info"]["units"] == {"x": "deg", "F": "Nm", "t": "s"}
    assert (tmp_path / "checkpoints" / "last.ckpt").exists() and (tmp_path / "config.yaml").exists()
    assert (tmp_path / "predictions.parquet").exists()
    nominal = baseline in ("physics", "hybrid_mlp", "hybrid_lstm", "std_pinn")
    assert (tmp_path / "model.pt").exists() == nominal and bool(metrics["physics"]) == nominal
    assert result["info"]["n_parameters"] > 0


def test_same_seed_same_metrics_and_a_resumed_run_equals_an_uninterrupted_one(tmp_path):
    a = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'a'}"]))
    b = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'b'}"]))
    assert a["test"]["rmse"] == b["test"]["rmse"] and a["train"]["rmse"] == b["train"]["rmse"]
    straight = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 's'}", "trainer.max_epochs=3"]))
    ckpt = tmp_path / "a" / "checkpoints" / "last.ckpt"
    resumed = train.run(_compose([*SMOKE, f"run_dir={tmp_path / 'c'}", f"ckpt_path={ckpt}", "trainer.max_epochs=3"]))
    assert resumed["info"]["epochs"] == straight["info"]["epochs"] == 3
    assert resumed["test"]["rmse"] == pytest.approx(straight["test"]["rmse"], rel=1e-9)
    for key, entry in straight["physics"].items():
        assert resumed["physics"][key]["value"] == pytest.approx(entry["value"], rel=1e-9)
    history = (tmp_path / "c" / "parameters.csv").read_text().splitlines()
    assert len(history) == 1 + 3  # header + epochs 0, 1, 2: the history travels with the checkpoint


def test_bad_input_fails_with_a_clear_error_and_a_failed_metrics_file(tmp_path):
    with pytest.raises(ValueError, match="lambda_phys must be >= 0"):
        train.run(_compose([*SMOKE, "loss.lambda_phys=-1", f"run_dir={tmp_path}"]))
    failed = json.loads((tmp_path / "metrics.json").read_text())
    assert failed["status"] == "failed" and "lambda_phys" in failed["error"] and failed["info"]["module"] == "hybrid"
    with pytest.raises(ValueError, match="unknown module 'transformer'"):
        train.run(_compose([*SMOKE, "module=transformer", f"run_dir={tmp_path}"]))


def test_tensorboard_gets_losses_physics_in_units_loops_and_hparams(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    train.run(_compose(["experiment=smoke", "logger=tensorboard", "logger.loop_every_n_epochs=1",
                        f"run_dir={tmp_path}"]))
    tags: dict[str, list] = {"scalars": [], "images": [], "tensors": []}
    for event in (tmp_path / "tensorboard").glob("events.*"):
        acc = EventAccumulator(str(event), size_guidance={"images": 0}).Reload()
        for k in tags:
            tags[k] += acc.Tags().get(k, [])
    assert {"train/loss", "train/data_loss", "val/rmse"} <= set(tags["scalars"])
    assert "phys/friction.v_s [deg/s]" in tags["scalars"]
    assert any(t.startswith("phys/hysteresis.") and t.endswith("]") for t in tags["scalars"])
    assert "loops/mixture=1:3, pressure_mpa=0.07" in tags["images"]
    assert "hp/test_rmse" in tags["scalars"] or "hp/test_rmse" in tags["tensors"]


def test_multirun_keeps_the_other_jobs_when_one_fails_and_the_report_lists_it(tmp_path):
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    cmd = [sys.executable, "-m", "hybridhyst.cli.train", "-m", *SMOKE, "trainer.max_epochs=1",
           "loss.lambda_phys=0.0,-1.0", f"hydra.sweep.dir={tmp_path / 'sweep'}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode != 0  # the sweep as a whole reports the failure ...
    ok = json.loads((tmp_path / "sweep" / "0" / "metrics.json").read_text())
    bad = json.loads((tmp_path / "sweep" / "1" / "metrics.json").read_text())
    assert ok["status"] == "ok" and bad["status"] == "failed"  # ... after every job ran
    report = subprocess.run([sys.executable, "-m", "hybridhyst.cli.report", str(tmp_path / "sweep"),
                             "--out", str(tmp_path / "report")], capture_output=True, text=True, env=env, timeout=120)
    assert report.returncode == 0, report.stderr
    text = (tmp_path / "report" / "report.md").read_text()
    assert "lambda_phys must be >= 0" in text and "hybrid-mlp" in text
