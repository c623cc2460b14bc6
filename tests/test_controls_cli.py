"""docs/controls.md ("Control inputs"): the example CSV, its documented commands composed and run on it (reduced),
and the one-line errors for a control given wrongly."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate

from hybridhyst.cli.common import CONF_DIR
from tests.test_own_data import example_script, readme_commands

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "controls"


COMMANDS = readme_commands(ROOT / "docs" / "controls.md")


def _compose(app: str, tmp_path: Path, *extra: str, csv: Path | None = None):
    overrides = [o.replace("examples/controls/mr_damper_voltage.csv", str(csv or EXAMPLE / "mr_damper_voltage.csv"))
                 for o in COMMANDS[app]]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(app.split(":")[0], overrides=[f"run_dir={tmp_path}", *overrides, *extra])


def test_the_readme_documents_fit_discover_and_train_with_the_control():
    assert set(COMMANDS) == {"fit", "fit:2", "discover", "train"}
    for overrides in COMMANDS.values():
        assert "data.controls={voltage: voltage_v}" in overrides


@pytest.mark.slow  # 19 s of the example's scipy generator; the committed CSV's checks below run by default
def test_the_example_is_what_make_example_writes(tmp_path):
    written = example_script(EXAMPLE / "make_example.py").main(tmp_path / "mr.csv")
    assert written.read_bytes() == (EXAMPLE / "mr_damper_voltage.csv").read_bytes()
    assert written.stat().st_size < 600_000


def test_the_documented_options_read_the_voltage_as_a_control(tmp_path):
    records = instantiate(_compose("fit", tmp_path).data, _convert_="all")
    assert records.names == [f"r{i}" for i in range(1, 7)]
    r = records[0]
    assert set(r.controls) == {"voltage"} and "voltage" not in r.conditions and r.conditions == {"set": "fit"}
    assert len(r.controls["voltage"]) == len(r) == 2001 and 0 <= r.controls["voltage"].min() < 1.0
    assert r.controls["voltage"].max() > 1.0 and r.units == {"t": "s", "x": "mm", "y": "N"}


def test_fit_with_the_control_reaches_the_noise_and_without_it_does_not(tmp_path):
    from hybridhyst.cli import fit

    quick = ("progress=false", "fit.steps=5", "fit.lbfgs_steps=10", "fit.identify={pop: 12, generations: 8}")
    blind = fit.run(_compose("fit", tmp_path / "blind", *quick))
    voltage = fit.run(_compose("fit:2", tmp_path / "voltage", *quick))
    assert voltage["split"]["held_out"] == ["r5", "r6"]
    assert voltage["rmse"]["held_out"] < 3.0 < 30.0 < blind["rmse"]["held_out"]  # noise: 2 N


def test_train_runs_with_the_voltage_as_a_network_input(tmp_path):
    from hybridhyst.cli import train

    summary = train.run(_compose("train", tmp_path, "progress=false", "trainer.max_epochs=1",
                                 "nominal_init.settings={pop: 8, generations: 3}"))
    assert summary["status"] == "ok" and summary["info"]["conditions"] == "voltage"
    assert np.isfinite(summary["test"]["rmse"])


@pytest.mark.slow
def test_the_documented_discover_command_names_the_voltage_dependence(tmp_path):
    from hybridhyst.cli import discover

    report = discover.run(_compose("discover", tmp_path, "progress=false"))
    names = [s["effect"] for s in report["steps"]]
    assert "viscous.c~voltage" in names and "hysteresis.kappa~voltage" in names
    assert report["after"]["test_rmse"] < 1.2 * 2.0 < report["before"]["test_rmse"] / 10


# -- a control given wrongly: one line naming what to do -------------------------------------------------


def _error(app: str, tmp_path: Path, *extra: str, csv: Path | None = None) -> str:
    from hybridhyst.cli import fit

    cfg = _compose(app, tmp_path, "progress=false", "fit.steps=1", "fit.lbfgs_steps=0", "fit.start=model", *extra,
                   csv=csv)
    with pytest.raises(ValueError) as err:
        fit.run(cfg)
    return str(err.value)


def test_a_control_column_the_file_lacks(tmp_path):
    text = _error("fit:2", tmp_path, "data.controls={voltage: volts}")
    assert "no column 'volts' (the control 'voltage')" in text and "'voltage_v'" in text


def test_a_parameter_function_of_a_control_no_record_carries(tmp_path):
    text = _error("fit:2", tmp_path, "data.controls=null")
    assert "'voltage'" in text and "data.controls" in text


def test_a_varying_column_given_as_a_condition_points_to_data_controls(tmp_path):
    text = _error("fit:2", tmp_path, "data.controls=null", "data.conditions=[set, voltage_v]")
    assert "condition column 'voltage_v' varies within the record" in text and "data.controls" in text


@pytest.mark.parametrize("cell, expected", [("nan", "1 NaN values (rows 7)"), ("1,5", "1 non-numeric values")])
def test_a_bad_control_cell_is_named_with_its_record_column_and_row(cell, expected, tmp_path):
    frame = pd.read_csv(EXAMPLE / "mr_damper_voltage.csv", nrows=400, dtype=str)
    frame.loc[7, "voltage_v"] = cell
    csv = tmp_path / "bad.csv"
    frame.to_csv(csv, index=False)
    text = _error("fit:2", tmp_path / "run", csv=csv)
    assert "record 'r1'" in text and "column 'voltage_v'" in text and expected in text


def test_a_control_given_wrongly_exits_2_with_one_line(tmp_path):
    words = [o.replace("examples/controls/", f"{EXAMPLE}/") for o in COMMANDS["fit:2"]]
    out = subprocess.run([sys.executable, "-m", "hybridhyst.cli.fit", *words, "data.controls=null",
                          f"hydra.run.dir={tmp_path}"], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 2, out.stderr[-2000:]
    assert len(out.stderr.strip().splitlines()) == 1 and "data.controls" in out.stderr


def test_simulate_drives_spencers_damper_by_a_held_voltage_and_a_model_by_the_records_control(tmp_path):
    from hybridhyst.cli import simulate

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=[f"run_dir={tmp_path / 'sine'}", "model=mr_damper_spencer",
                                             "+conditions={voltage: 1.5}", "input.amplitude=1.5",
                                             "input.frequency_hz=2.5", "input.samples_per_cycle=400",
                                             "simulation.substeps=8", "progress=false"])
    simulate.run(cfg)
    force = pd.read_csv(tmp_path / "sine" / "predictions.csv")["force"]
    assert 1000 < force.abs().max() < 2000  # N: the paper's damper at 1.5 V
    words = [o.replace("examples/controls/", f"{EXAMPLE}/") for o in COMMANDS["fit:2"] if not o.startswith("split.")]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=[f"run_dir={tmp_path / 'data'}", *words, "input.kind=data",
                                             "input.select={set: held_out}", "progress=false"])
    summary = simulate.run(cfg)
    table = pd.read_csv(tmp_path / "data" / "predictions.csv")
    assert set(summary["records"]) == {"r5", "r6"} and "voltage" in table.columns


def test_the_physics_residual_refuses_a_lagged_control_in_one_line(tmp_path):
    from hybridhyst.cli import train

    cfg = _compose("train", tmp_path, "progress=false", "model=mr_damper_voltage", "loss.lambda_phys=0.1",
                   "nominal_init.start=none")
    with pytest.raises(ValueError, match="lambda_phys=0 and module=physics or hybrid"):
        train.run(cfg)


def test_simulate_resolves_its_step_or_says_it_cannot(tmp_path):
    """The simulate app makes the check every app makes: a stiff spring on the default sine, which one sub-step
    per sample turns into an overflow, is simulated at the sub-steps it needs; a response that the most sub-steps
    allowed do not resolve is an error (a finite response can still be the integrator's, not the model's)."""
    from hybridhyst.cli import simulate

    def run(name, *extra):
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            cfg = compose("simulate", overrides=[f"run_dir={tmp_path / name}", "model=linear_oscillator",
                                                 "model.effects.stiffness.k=1e9", "progress=false", *extra])
        return simulate.run(cfg)

    resolved = run("resolved")["records"]["sine"]
    assert resolved["substeps"] > 1 and resolved["change"] <= 1e-3
    with pytest.raises(ValueError, match="not resolved"):
        run("capped", "max_substeps=2", "simulation.substeps=2", "model.effects.stiffness.k=1e6")


def test_a_control_in_another_unit_than_the_models_is_one_line(tmp_path):
    text = _error("fit:2", tmp_path, "+data.units.voltage=mV")
    assert "control 'voltage' in 'mV'" in text and "reads it in 'V'" in text


def test_a_control_the_model_does_not_read_is_noted(tmp_path, capsys):
    from hybridhyst.cli import fit

    fit.run(_compose("fit", tmp_path, "progress=false", "fit.steps=1", "fit.lbfgs_steps=0", "fit.start=model"))
    assert "carry the control channel(s) ['voltage']" in capsys.readouterr().out


def test_a_control_a_network_reads_is_not_noted_as_unread():
    """hybridhyst-train with ``datamodule.conditions=[voltage]``: the network reads the channel the nominal does
    not, so no note says that nothing reads it."""
    import numpy as np

    from hybridhyst.data.records import Record
    from hybridhyst.physics.build import build_model
    from hybridhyst.training.config import check_model_data

    t = np.linspace(0.0, 1.0, 11)
    record = Record(name="r", t=t, x=t, y=t, units={"x": "m", "y": "N"}, controls={"voltage": t})
    model = build_model("constitutive", {"viscous": {"effect": "viscous", "c": 1.0}})
    assert "['voltage']" in check_model_data(model, [record])
    assert "voltage" not in check_model_data(model, [record], read_elsewhere=["voltage"])


def test_a_written_model_names_the_unit_of_a_control_it_reads(tmp_path):
    """A trend in a control that discovery added (the nominal named no unit for it) is written with the records'
    unit, so that the discovered model refuses data in another unit later."""
    import numpy as np
    import yaml

    from hybridhyst.cli.common import write_model
    from hybridhyst.data.records import Record
    from hybridhyst.physics.build import build_model

    model = build_model("constitutive", {"viscous": {"effect": "viscous",
                                                      "c": {"kind": "linear", "condition": "current", "intercept": 1.0,
                                                            "slope": 2.0}}})
    t = np.linspace(0.0, 1.0, 11)
    record = Record(name="r", t=t, x=t, y=t, units={"x": "mm", "y": "N", "current": "A"}, controls={"current": t})
    write_model(tmp_path, model, "discovered", "discovered by a test", [record])
    text = (tmp_path / "model" / "discovered.yaml").read_text()
    assert yaml.safe_load(text)["units"]["current"] == "A"
    # summary.json and discovery.json give a trend's config beside its text: what a program reads back
    info = model.parameter_table()["viscous"]["c"]
    assert info["function"] == {"kind": "linear", "condition": "current", "intercept": 1.0, "slope": 2.0}
