"""docs/own-data.md ("Your own measurements"): the example CSV, and the documented commands composed and run on it
(reduced: a few optimiser steps; the full discover command is marked slow)."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate

from hybridhyst.cli.common import CONF_DIR, guarded, torch_settings

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "own_data"
TRAINING = ["p0.01", "p0.02", "p0.03", "p0.04", "p0.06", "p0.07", "p0.08"]


def readme_commands(page: Path = ROOT / "docs" / "own-data.md") -> dict[str, list[str]]:
    """{app: overrides} of the commands in the first bash block of the guide ``page`` (a second command of one
    app: "app:2")."""
    block = page.read_text(encoding="utf-8").split("```bash\n", 1)[1].split("```", 1)[0]
    commands: dict[str, list[str]] = {}
    for command in block.replace("\\\n", " ").splitlines():
        words = shlex.split(command, comments=True)
        if words and words[0].startswith("hybridhyst-"):
            app = words[0].removeprefix("hybridhyst-")
            n = sum(1 for key in commands if key.split(":")[0] == app)
            commands[f"{app}:{n + 1}" if n else app] = words[1:]  # a second command of one app: "train:2"
    return commands


COMMANDS = readme_commands()


def example_script(path: Path):
    """An example folder's generator script as a module (its ``main(out)`` writes the example file)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _compose(app: str, tmp_path: Path, *extra: str):
    """The documented command of ``app`` (the data path made absolute) plus ``extra`` overrides."""
    overrides = [o.replace("examples/own_data/", f"{EXAMPLE}/") for o in COMMANDS[app]]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(app.split(":")[0], overrides=[f"run_dir={tmp_path}", *overrides, *extra])


def test_the_readme_documents_every_app():
    assert {key.split(":")[0] for key in COMMANDS} == {"identify", "fit", "discover", "train"}
    for app, overrides in COMMANDS.items():
        assert "data=table" in overrides and any(o.startswith("model=vpptd_algebraic") for o in overrides), app


def test_the_example_is_what_make_example_writes(tmp_path):
    written = example_script(EXAMPLE / "make_example.py").main(tmp_path / "loops.csv")
    assert written.read_bytes() == (EXAMPLE / "damper_loops.csv").read_bytes()
    assert (EXAMPLE / "damper_loops.csv").stat().st_size < 300_000


@pytest.mark.parametrize("app", sorted(COMMANDS))
def test_the_documented_options_load_the_example(app, tmp_path):
    records = instantiate(_compose(app, tmp_path).data, _convert_="all")
    assert records.names == [f"p{p / 100:.2f}" for p in range(1, 10)]
    assert [r.conditions["pressure_mpa"] for r in records] == pytest.approx([p / 100 for p in range(1, 10)])
    r = records[0]
    assert len(r) == 501 and r.units == {"t": "s", "x": "deg", "y": "Nm"}
    assert r.dt == pytest.approx(0.005) and max(r.x) == pytest.approx(10.0, abs=0.01)


def test_identify_recovers_the_constants_at_one_pressure(tmp_path):
    from hybridhyst.cli import identify

    cfg = _compose("identify", tmp_path, "progress=false", "identify.fisher=false", "identify.pop=16",
                   "identify.generations=10", "identify.restarts=2", "identify.lm_steps=10", "noise_sd=0.2")
    summary = identify.run(cfg)
    # noise_sd is the data's noise level, reported beside the RMSE; noise is added only by add_noise
    assert summary["records"] == ["p0.03"] and summary["noise_sd"] == 0.2 and summary["rmse"] < 0.25
    truth = {"viscous.c": 6.7, "stiffness.k": 0.65, "cubic.k3": 0.0055, "friction.Fc": 9.5}  # x1.25 at 0.03 MPa
    for name, value in truth.items():
        assert summary["coordinates"][name] == pytest.approx(1.25 * value, rel=0.05), name


def test_fit_runs_and_holds_out_two_pressures(tmp_path):
    from hybridhyst.cli import fit

    summary = fit.run(_compose("fit", tmp_path, "progress=false", "fit.steps=3", "fit.lbfgs_steps=2"))
    assert summary["split"] == {"train": TRAINING, "held_out": ["p0.05", "p0.09"]}
    assert summary["units"] == {"x": "deg", "y": "Nm", "t": "s"} and 0 < summary["rmse"]["held_out"] < 50
    assert summary["conditions"]["p0.05"] == {"pressure_mpa": 0.05}
    assert summary["reference"] is None and (tmp_path / "report.md").exists()
    # loop.png draws every held-out record, the worst first: a miss is never hidden behind a good fit
    per_record = summary["per_record"]
    assert summary["loop_records"] == sorted(["p0.05", "p0.09"], key=lambda n: -per_record[n])
    assert "every held-out record, the worst first" in (tmp_path / "report.md").read_text()


def test_records_without_units_are_taken_in_the_models_and_the_app_says_so(tmp_path, capsys):
    """Without data.units nothing can be checked: the apps label everything in the model's units and say on the
    terminal that they assumed them (before: no unit anywhere, "RMSE 4.7 , held out 6.2 ,")."""
    from hybridhyst.cli import fit

    cfg = _compose("fit", tmp_path, "progress=false", "fit.steps=3", "fit.lbfgs_steps=2", "~data.units")
    summary = fit.run(cfg)
    out = capsys.readouterr().out
    assert "the records declare no units for input and response (data.units)" in out
    assert "taken to be the model 'vpptd_algebraic''s (input in deg, response in Nm)" in out
    assert summary["units"] == {"x": "deg", "y": "Nm", "t": "s"} and "Nm, held-out" in out


def test_discover_runs_and_prints_a_summary(tmp_path, capsys):
    from hybridhyst.cli import discover

    cfg = _compose("discover", tmp_path, "progress=false", "discover.conditions=false",
                   "discover.candidates=[stribeck]", "discover.max_steps=1", "discover.identify.pop=8",
                   "discover.identify.generations=3", "discover.lm_steps=5")
    report = discover.run(cfg)
    saved = json.loads((tmp_path / "discovery.json").read_text())
    assert saved["records"] == {"train": TRAINING, "val": [], "test": ["p0.05", "p0.09"]}
    assert report["before"]["test_rmse"] > 0
    out = capsys.readouterr().out.splitlines()
    first = next(i for i, line in enumerate(out) if line.startswith("discovery: added "))
    assert out[first + 1].startswith("  test RMSE ") and out[first + 1].endswith(" Nm")
    assert out[-1] == f"  report: {tmp_path / 'report.md'}"
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Discovery: vpptd_algebraic nominal on damper_loops")
    # no validation records: the report says which records the acceptance rule scored, never "validation RMSE"
    assert "No validation records" in text and "training RMSE" in text and "validation RMSE" not in text
    # the discovered model, values and all, is a config that every app selects by name
    reuse = f"'hydra.searchpath=[file://{tmp_path}]' model=discovered"
    assert out[-2] == f"  the discovered model in another app: {reuse}" and "model/discovered.yaml" in text
    with torch_settings("float64"):
        model = instantiate(_compose("identify", tmp_path / "again", *shlex.split(reuse)).model, _convert_="all")
    saved = torch.load(tmp_path / "model.pt")
    assert model.name == "vpptd_algebraic" and set(model.state_dict()) == set(saved)
    for key, value in model.state_dict().items():
        torch.testing.assert_close(value, saved[key], rtol=1e-12, atol=1e-12, msg=key)


def test_train_runs_with_the_pressure_as_a_network_input(tmp_path):
    from hybridhyst.cli import train

    metrics = train.run(_compose("train", tmp_path, "logger=none", "trainer.max_epochs=2",
                                 "trainer.enable_progress_bar=false"))
    assert metrics["status"] == "ok" and set(metrics["test"]["per_condition"]) == {
        "pressure_mpa=0.05", "pressure_mpa=0.09"}


@pytest.mark.parametrize("extra,expected", [
    (["discover.conditions=[pressure_mpaa]"],
     "no record has a condition 'pressure_mpaa' (did you mean 'pressure_mpa'?)"),
    (["split.held_out=[{pressure_mpa: [0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09]}]",
      "discover.conditions=[pressure_mpa]"], "takes 1 value(s) [0.01] on the training records"),
    (["split.held_out=[{pressure_mpa: [0.055]}]"], "held-out condition pressure_mpa=0.055 matches no record"),
    (["data.conditions=[]"], "held-out condition 'pressure_mpa' is not a condition of record set 'damper_loops'"),
    (["split.held_out=[{pressure_mpa: [0.05, 0.09]}, {pressure_mpa: [0.01, 0.02, 0.03, 0.04, 0.06, 0.07, 0.08]}]"],
     "leaves no training records"),
])
def test_discover_split_and_condition_mistakes_are_one_line(extra, expected, tmp_path, capsys):
    from hybridhyst.cli import discover

    with pytest.raises(SystemExit) as exc:
        guarded(discover.run, _compose("discover", tmp_path, "progress=false", *extra))
    assert exc.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and expected in lines[0], lines


def test_a_parameter_function_of_a_missing_condition_is_one_line(tmp_path, capsys):
    from hybridhyst.cli import fit

    cfg = _compose("fit", tmp_path, "progress=false",
                   "model.Ms={kind: linear, slope: 100.0, intercept: 8.5, condition: temperature_c}")
    with pytest.raises(SystemExit):
        guarded(fit.run, cfg)
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "condition 'temperature_c'" in err and "model" in err, err


@pytest.mark.parametrize("app", ["identify", "fit", "discover", "train"])
def test_data_units_other_than_the_models_are_one_line(app, tmp_path, capsys):
    """Nothing is converted: torque-angle loops labelled in rad (or with input and response swapped) for a law in
    deg and Nm stop before any fitting, in every app."""
    import importlib

    module = importlib.import_module(f"hybridhyst.cli.{app}")
    for units in ("{t: s, x: rad, y: Nm}", "{t: s, x: Nm, y: deg}"):
        cfg = _compose(app, tmp_path, f"data.units={units}")
        with pytest.raises(SystemExit) as exc:
            guarded(module.run, cfg)
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "works in input 'deg', response 'Nm'" in err and "nothing is converted" in err, err


@pytest.mark.slow
def test_the_documented_discover_command_finds_the_pressure_trends(tmp_path):
    """The documented command as it stands (about 20 s here): trends in pressure_mpa take the held-out RMSE to
    the noise level."""
    from hybridhyst.cli import discover

    report = discover.run(_compose("discover", tmp_path, "progress=false"))
    accepted = [s["effect"] for s in report["steps"] if s["accepted"]]
    assert any("pressure_mpa" in name for name in accepted), accepted
    assert report["after"]["test_rmse"] < 0.3 < report["before"]["test_rmse"]


def test_train_with_a_nominal_that_lacks_nothing_ends_at_the_noise(tmp_path):
    """The guide's second training command (every parameter linear in the pressure, slopes from 0): with its
    defaults (here 2 epochs) the identified start puts the held-out pressures within 2 × the 0.2 Nm noise,
    and metrics.json reports the identified nominal beside the hybrid."""
    from hybridhyst.cli import train

    cfg = _compose("train:2", tmp_path, "trainer.max_epochs=2", "logger=none", "predictions=false",
                   "trainer.enable_progress_bar=false", "nominal_init.progress=false")
    result = train.run(cfg)
    assert result["nominal"]["test"]["rmse"] < 0.25
    assert result["test"]["rmse"] < 2 * 0.2
