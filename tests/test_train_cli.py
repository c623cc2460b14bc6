"""hybridhyst-train: every config of every group composes and instantiates (the gpu and ddp trainers with the CPU as
their accelerator where there is no CUDA), a run writes its directory, runs are deterministic and resumable, a
finished run is kept by skip_finished, TensorBoard gets the promised tags, and a multirun with one failing job keeps
the others' results (and the report lists the failure)."""

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
from omegaconf import OmegaConf

from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.nets import build_net
from hybridhyst.physics.models import NominalModel, conditions_used
from hybridhyst.studies import STUDIES

CONF = Path(CONF_DIR)
GROUPS = ["data", "model", "residual", "loss", "trainer", "logger", "baseline", "sweep", "experiment"]
SMOKE = ["experiment=smoke", "logger=none", "nominal_init.start=none"]  # the identified start: test_train_convergence


def _compose(overrides, hydra_cfg=False):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides, return_hydra_config=hydra_cfg)


def _options(group):
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))


# Hidden states of every nominal in conf/model: a hysteretic state per Bouc–Wen, Dahl or LuGre effect, plus position
# and velocity for a driven oscillator (m ẍ + Σ forces = drive). A new model config needs its count here.
STATE_DIMS = {
    "bouc_wen_classic": 1, "bouc_wen_p": 1, "coulomb_viscous": 0, "dahl_friction": 1, "lugre_friction": 1,
    "modified_bouc_wen": 1, "modified_bouc_wen_constant": 1, "vpptd_algebraic": 0, "vpptd_algebraic_linear": 0,
    "mr_damper": 1, "mr_damper_voltage": 1 + 1, "mr_damper_spencer": 1 + 2, "boucwen_benchmark": 2 + 1,
    "linear_oscillator": 2, "piezo_attenuation": 2 + 1, "vpptd_rig": 2 + 1,
}


def _widths(hidden) -> list[int]:
    """'4x128' -> [128, 128, 128, 128] (the residual configs' layers x width), parsed here, not by the library."""
    if isinstance(hidden, str):
        layers, width = hidden.split("x")
        return [int(width)] * int(layers)
    return [int(h) for h in hidden]


def _check_residual(cfg, option):
    """The network of a residual config: the configured layers and widths, (batch, time, 3) -> (batch, time, 1),
    zero at the start (the hybrid starts at its nominal)."""
    widths = _widths(cfg.residual.hidden)
    net = build_net(cfg.residual.kind, 3, 1, cfg.residual.hidden, cfg.residual.activation).double()
    if cfg.residual.kind == "mlp":
        linear = [m for m in net.modules() if isinstance(m, torch.nn.Linear)]
        assert [m.out_features for m in linear] == [*widths, 1], option
        assert [m.in_features for m in linear] == [3, *widths], option
    else:
        assert (net.lstm.num_layers, net.lstm.hidden_size, net.lstm.input_size) == (len(widths), widths[0], 3)
    out = net(torch.randn(2, 7, 3, dtype=torch.float64))
    assert out.shape == (2, 7, 1) and torch.count_nonzero(out) == 0, option


def _check_trainer(cfg, tmp_path, option):
    """Every trainer config goes through the app's builder; gpu and ddp on a machine without CUDA with the
    accelerator overridden to the CPU (ddp: two CPU processes), so everything but the device is still checked."""
    from lightning.pytorch.accelerators import CPUAccelerator, CUDAAccelerator
    from lightning.pytorch.strategies import DDPStrategy, SingleDeviceStrategy

    wanted = cfg.trainer.accelerator
    if wanted == "gpu" and not torch.cuda.is_available():
        devices = 2 if cfg.trainer.strategy == "ddp" else 1
        cfg = _compose([f"trainer={option}", "trainer.accelerator=cpu", f"trainer.devices={devices}"])
    trainer = train.build_trainer(cfg, tmp_path)
    accelerator = CUDAAccelerator if cfg.trainer.accelerator == "gpu" else CPUAccelerator
    assert isinstance(trainer.accelerator, accelerator), option
    strategy = DDPStrategy if cfg.trainer.strategy == "ddp" else SingleDeviceStrategy
    assert isinstance(trainer.strategy, strategy), (option, type(trainer.strategy).__name__)
    if cfg.trainer.strategy == "ddp":
        assert trainer.num_devices == (torch.cuda.device_count() if cfg.trainer.devices == -1 else cfg.trainer.devices)
    else:
        assert trainer.num_devices == 1
    assert trainer.max_epochs == cfg.trainer.max_epochs and trainer.precision == cfg.trainer.precision
    assert trainer.gradient_clip_val == cfg.trainer.gradient_clip_val and trainer.num_nodes == cfg.trainer.num_nodes
    assert [type(c).__name__ for c in trainer.callbacks].count("ModelCheckpoint") == 2  # best + last


@pytest.mark.parametrize("group", GROUPS)
def test_every_config_of_every_group_composes_and_instantiates(group, tmp_path):
    assert _options(group), f"conf/{group} is empty"
    for option in _options(group):
        cfg = _compose([f"{group}={option}", f"run_dir={tmp_path}"], hydra_cfg=group == "sweep")
        if group == "model":  # a nominal model with its known states, whose parameters evaluate to finite numbers
            model = hydra_instantiate(cfg.model, _convert_="all").double()
            assert isinstance(model, NominalModel) and model.parameter_table(), option
            assert option in STATE_DIMS, f"conf/model/{option}.yaml: add its number of states to STATE_DIMS"
            assert model.state_dim == STATE_DIMS[option], (option, model.state_dim)
            values = model.evaluate({c: torch.full((2,), 0.05) for c in conditions_used(model)}, 2)
            assert values and all(torch.isfinite(v).all() for p in values.values() for v in p.values()), option
        elif group == "residual":
            _check_residual(cfg, option)
        elif group == "sweep":
            assert cfg.hydra.sweeper.params, f"sweep={option} sweeps nothing"
        elif group == "trainer":
            _check_trainer(cfg, tmp_path, option)
        elif group == "logger":
            trainer = train.build_trainer(cfg, tmp_path)
            kind = {"tensorboard": "TensorBoardLogger", "csv": "CSVLogger", "none": None}[cfg.logger.kind]
            assert (type(trainer.logger).__name__ if trainer.logger else None) == kind, option
        elif group == "data" and option != "table":  # table needs data.path (tested in test_data.py)
            assert len(hydra_instantiate(cfg.data, _convert_="all")) > 0
        elif group in ("baseline", "loss"):  # the module each builds, on the smoke data
            small = _compose([*SMOKE, f"{group}={option}", f"run_dir={tmp_path}"])
            dm = train.build_datamodule(small)
            module = train.build_module(small, dm)
            assert module.kind == small.module and module.n_parameters() > 0
            if small.module == "hybrid":  # the built module has the configured placement, not the default
                assert (module.placement, module.latent_states) == (small.placement, int(small.latent_states))
            assert train.run_info(small)["placement"] == (small.placement if small.module == "hybrid" else None)
    if group == "experiment":
        for option in _options(group):  # every training experiment's data and split are consistent
            cfg = _compose([f"experiment={option}"])
            if cfg.app != "train":
                with pytest.raises(ValueError, match=f"is for hybridhyst-{cfg.app}, not hybridhyst-train"):
                    train.run(cfg)
                continue
            if OmegaConf.is_missing(cfg.data, "path"):  # the runs of a study: the study writes their records
                assert cfg.experiment_name in STUDIES, f"experiment={option}: data.path is left to an unknown study"
                assert option.startswith(cfg.experiment_name), option  # the runs are named after their study
                continue
            dm = train.build_datamodule(cfg)
            assert len(dm.records("train")) and len(dm.records("test"))


@pytest.mark.parametrize("launcher,target", [("local", "JoblibLauncher"), ("slurm", "SlurmLauncher")])
def test_launcher_configs_instantiate(launcher, target):
    cfg = _compose([f"hydra/launcher={launcher}"], hydra_cfg=True)
    assert cfg.hydra.launcher._target_.endswith(target)
    assert type(hydra_instantiate(cfg.hydra.launcher)).__name__ == target


def test_dynamics_inputs_reach_the_network_inside_the_dynamics_and_only_it(tmp_path):
    cfg = _compose([*SMOKE, "baseline=hybrid_dynamics", "dynamics_inputs=[x,u]", f"run_dir={tmp_path}"])
    dm = train.build_datamodule(cfg)
    module = train.build_module(cfg, dm)
    assert module.net.inputs == ("x", "u") and module.net.net.body[0].in_features == 2 + 1 + len(dm.condition_names)
    assert train.run_info(cfg)["dynamics_inputs"] == "x,u"
    default = train.build_module(_compose([*SMOKE, "baseline=hybrid_dynamics", f"run_dir={tmp_path}"]), dm)
    assert default.net.inputs == ("x", "v")
    # an experiment config may set the key for every run it sweeps: the output branch and other modules ignore it
    for baseline in ("hybrid_mlp", "physics"):
        other = _compose([*SMOKE, f"baseline={baseline}", "dynamics_inputs=[x,u]", f"run_dir={tmp_path}"])
        assert train.build_module(other, dm).n_parameters() > 0 and train.run_info(other)["dynamics_inputs"] is None
    with pytest.raises(ValueError, match="dynamics_inputs belong to placement=dynamics"):
        type(module)(module.nominal, dm.normaliser.to_dict(), hidden="1x4", dynamics_inputs=("x", "u"))
    with pytest.raises(ValueError, match="unknown input"):
        train.build_module(_compose([*SMOKE, "baseline=hybrid_dynamics", "dynamics_inputs=[x,w]"]), dm)


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


def test_skip_finished_keeps_a_finished_run_of_the_same_config_and_reruns_another(tmp_path):
    first = train.run(_compose([*SMOKE, "+skip_finished=true", f"run_dir={tmp_path}"]))
    ckpt = tmp_path / "checkpoints" / "last.ckpt"
    stamp = ckpt.stat().st_mtime_ns
    again = train.run(_compose([*SMOKE, "+skip_finished=true", f"run_dir={tmp_path}"]))
    assert ckpt.stat().st_mtime_ns == stamp  # not trained again
    assert again["test"]["rmse"] == first["test"]["rmse"] and again["info"]["epochs"] == first["info"]["epochs"]
    other = train.run(_compose([*SMOKE, "+skip_finished=true", "trainer.max_epochs=1", f"run_dir={tmp_path}"]))
    assert other["info"]["epochs"] == 1 != first["info"]["epochs"]  # another config: trained
    assert json.loads((tmp_path / "metrics.json").read_text())["info"]["epochs"] == 1
    assert sorted(p.name for p in (tmp_path / "checkpoints").iterdir()) == ["best.ckpt", "last.ckpt"]
    logged = json.loads((tmp_path / "metrics.json").read_text())["logged"]
    assert math.isfinite(logged["train/loss"]) and logged["train/loss"] >= logged["train/data_loss"] > 0


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
    assert {"train/loss", "train/data_loss", "train/rmse"} <= set(tags["scalars"])
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


def test_summary_tells_a_kept_start_from_the_trained_model_and_small_metrics_show_in_the_progress_bar(tmp_path):
    info = {"name": "hybrid-dynamics", "epochs": 3, "train_time_s": 1.0, "units": {"F": "m"}, "evaluated": "best"}
    result = {"info": info, "train": {"rmse": 2.8e-4}, "val": {}, "test": {"rmse": 5e-4},
              "start": {"split": "train", "rmse": 0.00027979, "trained_rmse": 0.00027981, "restored": True}}
    text = train.summary(result, tmp_path)
    assert "RMSE 0.00027981 m is above the starting model's 0.00027979 m" in text  # not 0.0002798 twice
    result["start"]["trained_rmse"] = None  # a diverged run (JSON null)
    assert "RMSE inf m is above" in train.summary(result, tmp_path)
    pytest.importorskip("rich")  # without rich Lightning's tqdm bar prints significant figures already
    trainer = train.build_trainer(_compose([*SMOKE, f"run_dir={tmp_path}", "trainer.enable_progress_bar=true"]),
                                  tmp_path)
    bars = [c for c in trainer.callbacks if type(c).__name__ == "RichProgressBar"]
    assert len(bars) == 1 and f"{2.8e-4:{bars[0].theme.metrics_format}}" == "0.00028"


def test_summary_names_nominal_coordinates_the_identification_left_at_a_box_edge(tmp_path):
    """The nominal a hybrid starts from was identified first; a value the box set (not the data) is named, with
    the keys of this app that widen the box."""
    info = {"name": "hybrid-mlp", "epochs": 1, "train_time_s": 1.0, "units": {"F": "Nm"}, "evaluated": "best"}
    ident = {"rmse": 0.3, "wall_s": 2.0, "at_bounds": {"viscous.c": "upper"}}
    result = {"info": info, "train": {"rmse": 0.2}, "val": {}, "test": {"rmse": 0.3},
              "nominal": {"source": "identify", "identify": ident, "train": {"rmse": 0.3}, "val": {}, "test": {}}}
    text = train.summary(result, tmp_path)
    assert "viscous.c (upper edge)" in text and "nominal_init.settings={bounds:" in text
    ident["at_bounds"] = {}
    assert "edge" not in train.summary(result, tmp_path)
