"""hybridhyst-train's convergence guarantees (issue 12 item 4): the nominal starts from a batched identification
on the training records, metrics.json reports the starting nominal's own errors beside the run's, a run never
ends worse on validation than the model it started from (also after a resume), and a resumed run equals an
uninterrupted one.

The data are written here with numpy alone (not with library code): torque-angle loops of the law
M = c·φ̇ + k·φ + k2·φ³ + Ms·sign(φ̇) (φ in deg, φ̇ in rad/s, M in Nm) with constant parameters far from
model=vpptd_algebraic's defaults (6.7, 0.65, 0.0055, 9.5), three amplitudes, 0.2 Nm noise.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.training import predict_split, split_metrics

NOISE = 0.2  # Nm
LAW = {"c": 12.0, "k": 1.1, "k2": 0.009, "Ms": 15.0}  # Nm·s/rad, Nm/deg, Nm/deg³, Nm


def write_loops(path, amplitudes=(6.0, 8.0, 10.0), fs=100.0, f=0.8, cycles=2, seed=0):
    """One record per amplitude [deg]: ``cycles`` cycles of a sine at ``f`` Hz sampled at ``fs`` Hz."""
    rng = np.random.default_rng(seed)
    rows = ["record,t,angle_deg,torque_nm,amplitude_deg"]
    for a in amplitudes:
        t = np.arange(int(round(cycles * fs / f)) + 1) / fs
        w = 2 * np.pi * f
        phi, phi_dot = a * np.sin(w * t), np.deg2rad(a * w * np.cos(w * t))
        m = LAW["c"] * phi_dot + LAW["k"] * phi + LAW["k2"] * phi**3 + LAW["Ms"] * np.sign(phi_dot)
        m = m + rng.normal(0.0, NOISE, size=len(t))
        rows += [f"a{a:g},{ti:.4f},{p:.6f},{y:.6f},{a:g}" for ti, p, y in zip(t, phi, m)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    return write_loops(tmp_path_factory.mktemp("data") / "loops.csv")


def _compose(csv, run_dir, *overrides):
    data = [f"data.path={csv}", "data=table", "data.record=record", "data.input=angle_deg",
            "data.output=torque_nm", "data.conditions=[amplitude_deg]", "data.units={t: s, x: deg, y: Nm}",
            "model=vpptd_algebraic", "split.held_out=[{amplitude_deg: [10]}]", "split.val=[{amplitude_deg: [8]}]",
            "logger=none", "trainer.enable_progress_bar=false", "nominal_init.progress=false",
            "residual.hidden=2x16", "datamodule.window=64", "datamodule.warmup=8", "datamodule.batch_size=8",
            f"run_dir={run_dir}"]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=[*data, *overrides])


def _start_rmse(cfg) -> float:
    """The module's training RMSE on whole records before any epoch (what trainer.fit starts from)."""
    torch.manual_seed(0)
    dm = train.build_datamodule(cfg)
    module = train.build_module(cfg, dm)
    return split_metrics(predict_split(module, dm, "train"))["rmse"]


def test_the_nominal_starts_from_an_identified_fit_by_default(loops, tmp_path):
    default = _start_rmse(_compose(loops, tmp_path, "module=physics"))
    assert default == pytest.approx(NOISE, rel=0.15)  # the noise floor before the first epoch
    config_values = _start_rmse(_compose(loops, tmp_path, "module=physics", "nominal_init.start=none"))
    assert config_values > 10 * NOISE  # what it would start from without the identification
    # seed 000's recipe re-initialises the parameters near zero: no identification there
    noise_start = _start_rmse(_compose(loops, tmp_path, "module=physics", "loss=pinn_recipe"))
    assert noise_start > 10 * NOISE
    info = train.run_info(_compose(loops, tmp_path, "module=physics", "loss=pinn_recipe"))
    assert info["nominal_init"] == "init_noise"
    with pytest.raises(ValueError, match="unknown nominal_init.start 'fit'"):
        _start_rmse(_compose(loops, tmp_path, "nominal_init.start=fit"))
    with pytest.raises(ValueError, match="nominal_init.settings.generation"):
        _start_rmse(_compose(loops, tmp_path, "nominal_init.settings={generation: 3}"))


def test_nominal_init_settings_lie_over_the_identify_defaults_and_the_simulation(loops, tmp_path):
    """identify() arguments of the nominal's start: conf/identify.yaml's block, no Fisher analysis and the
    training simulation, then nominal_init.settings over them all; a key named like a helper argument is the
    same one-line error as any unknown key."""
    opts = train._identify_settings(_compose(loops, tmp_path, "simulation.substeps=3"))
    assert opts.fisher is False and opts.simulation.substeps == 3 and opts.pop == 32 and opts.bounds == {}
    opts = train._identify_settings(_compose(loops, tmp_path, "simulation.substeps=3",
                                             "nominal_init.settings={pop: 8, simulation: {substeps: 2}, fisher: true, "
                                             "bounds: {viscous.c: [0.1, 2]}}"))
    assert (opts.pop, opts.simulation.substeps, opts.fisher) == (8, 2, True)
    assert opts.simulation.backend == "fast"  # the rest of the training simulation kept
    assert opts.bounds == {"viscous.c": (0.1, 2)} and isinstance(opts.bounds["viscous.c"], tuple)
    for key in ("where", "block"):
        with pytest.raises(ValueError, match=f"unknown config key nominal_init.settings.{key}"):
            train._identify_settings(_compose(loops, tmp_path, f"nominal_init.settings={{{key}: 3}}"))


def test_a_run_never_ends_worse_on_validation_than_its_start_also_after_a_resume(loops, tmp_path):
    bad = ["module=hybrid", "trainer.lr=10", "trainer.nominal_lr=10", "trainer.max_epochs=2"]
    result = train.run(_compose(loops, tmp_path / "a", *bad))
    metrics = json.loads((tmp_path / "a" / "metrics.json").read_text())
    nominal = metrics["nominal"]
    assert nominal["source"] == "identify" and nominal["identify"]["records"] == 1
    assert set(nominal) >= {"train", "val", "test"} and nominal["train"]["rmse"] == pytest.approx(NOISE, rel=0.15)
    assert math.isfinite(nominal["test"]["rmse"]) and list(nominal["test"]["per_condition"]) == ["amplitude_deg=10"]
    start = metrics["start"]
    assert start["split"] == "val" and start["restored"] and start["trained_rmse"] > start["rmse"]
    assert metrics["val"]["rmse"] <= nominal["val"]["rmse"]
    assert metrics["val"]["rmse"] == pytest.approx(nominal["val"]["rmse"], rel=1e-12)  # the identified start
    assert result["info"]["evaluated"] == "best" and result["info"]["placement"] == "output"
    # resumed for one more epoch: the start (and the nominal block) come from the checkpoint
    ckpt = tmp_path / "a" / "checkpoints" / "last.ckpt"
    resumed = train.run(_compose(loops, tmp_path / "b", *bad[:-1], "trainer.max_epochs=3", f"ckpt_path={ckpt}"))
    assert resumed["info"]["epochs"] == 3 and resumed["start"]["restored"]
    assert resumed["nominal"] == metrics["nominal"]  # from the checkpoint, not identified again
    assert resumed["val"]["rmse"] == pytest.approx(nominal["val"]["rmse"], rel=1e-12)


def _weights(path):
    return torch.load(path, map_location="cpu", weights_only=False)["state_dict"]


def test_a_resumed_run_equals_an_uninterrupted_one(loops, tmp_path):
    # the last weights: trained, not a floor; a constant rate, as the half run stands in for an interrupted one (a
    # cosine schedule spans its own max_epochs: a 2-epoch run is another schedule, not half of the 4-epoch one)
    common = ["module=hybrid", "evaluate_best=false", "trainer.lr=3e-3", "trainer.lr_schedule=constant"]
    straight = train.run(_compose(loops, tmp_path / "s", *common, "trainer.max_epochs=4"))
    train.run(_compose(loops, tmp_path / "h", *common, "trainer.max_epochs=2"))
    ckpt = tmp_path / "h" / "checkpoints" / "last.ckpt"
    resumed = train.run(_compose(loops, tmp_path / "r", *common, "trainer.max_epochs=4", f"ckpt_path={ckpt}"))
    assert resumed["info"]["epochs"] == straight["info"]["epochs"] == 4
    a, b = _weights(tmp_path / "s" / "checkpoints" / "last.ckpt"), _weights(ckpt)
    assert a.keys() == b.keys()
    for k in a:
        assert torch.allclose(a[k], b[k], rtol=1e-10, atol=1e-12), k
    assert resumed["val"]["rmse"] == pytest.approx(straight["val"]["rmse"], rel=1e-10)
    for key, entry in straight["physics"].items():
        assert resumed["physics"][key]["value"] == pytest.approx(entry["value"], rel=1e-10)
    for key in ("source", "train", "val", "test"):  # the identified start travels with the checkpoint
        assert resumed["nominal"][key] == straight["nominal"][key]
    assert resumed["nominal"]["identify"]["x"] == straight["nominal"]["identify"]["x"]
    assert straight["val"]["rmse"] != straight["nominal"]["val"]["rmse"]  # training moved the weights
    # the resumed run reports its whole training time: the first two epochs' (from the checkpoint) and its own
    half = json.loads((tmp_path / "h" / "metrics.json").read_text())["info"]["train_time_s"]
    info = resumed["info"]
    assert "train_time_this_run_s" not in straight["info"] and 0 < info["train_time_this_run_s"] < info["train_time_s"]
    assert info["train_time_s"] - info["train_time_this_run_s"] == pytest.approx(half, rel=0.5)


def test_the_cosine_schedule_decays_every_rate_to_its_final_share(loops, tmp_path):
    from hybridhyst.training.base import cosine_factor

    assert cosine_factor(0, 10, 0.1) == 1.0 and cosine_factor(10, 10, 0.1) == pytest.approx(0.1)
    assert cosine_factor(5, 10, 0.1) == pytest.approx(0.55) and cosine_factor(12, 10, 0.1) == pytest.approx(0.1)
    cfg = _compose(loops, tmp_path, "module=hybrid", "trainer.max_epochs=3", "trainer.lr_schedule=cosine",
                   "trainer.lr_final_ratio=0.1")
    train.run(cfg)
    ckpt = torch.load(tmp_path / "checkpoints" / "last.ckpt", map_location="cpu", weights_only=False)
    (state,) = ckpt["lr_schedulers"]
    groups = ckpt["optimizer_states"][0]["param_groups"]
    assert len(groups) > 1  # the network and each nominal parameter: all follow the one schedule
    factor = cosine_factor(state["last_epoch"], 3, 0.1)
    assert state["last_epoch"] == 3 and factor == pytest.approx(0.1)  # stepped after each of the 3 epochs
    assert [g["lr"] for g in groups] == pytest.approx([factor * g["initial_lr"] for g in groups], rel=1e-12)
    # the decay spans the trainer's max_epochs: half way through 4 epochs every rate is at 0.1 + 0.9 / 2
    from types import SimpleNamespace

    module = train.build_module(cfg, train.build_datamodule(cfg))
    module._trainer = SimpleNamespace(max_epochs=4)
    conf = module.configure_optimizers()
    optimizer, scheduler = conf["optimizer"], conf["lr_scheduler"]["scheduler"]
    starts = [g["lr"] for g in optimizer.param_groups]
    scheduler.step()
    scheduler.step()
    assert [g["lr"] for g in optimizer.param_groups] == pytest.approx([0.55 * s for s in starts], rel=1e-12)
    module._trainer = SimpleNamespace(max_epochs=-1)
    with pytest.raises(ValueError, match="max_epochs >= 1, got -1"):
        module.configure_optimizers()
    with pytest.raises(ValueError, match="unknown lr_schedule 'linear'"):
        train.run(_compose(loops, tmp_path / "x", "module=hybrid", "trainer.lr_schedule=linear",
                           "nominal_init.start=none"))
