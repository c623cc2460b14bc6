"""The Hydra apps: ``run(cfg)`` on tiny settings, the files they write, and the exit-code-2 error path."""

from __future__ import annotations

import importlib
import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from hybridhyst.cli import fit, simulate
from hybridhyst.cli.common import CONF_DIR, atomic_write, guarded, write_json

ROOT = Path(__file__).resolve().parents[1]

# 1 Hz BRFD tests at 36 lb: train on 0.5 and 1.5 in, hold out 1 in; 16 samples per cycle, two Adam steps
# and one L-BFGS iteration. The Dahl stiffness starts low so the coarse explicit grid stays stable.
TINY_FIT = [
    "+split.select.frequency_hz=1.0",
    "fit.steps=2", "fit.lbfgs_steps=1", "fit.samples_per_cycle=16", "evaluate.samples_per_cycle=16",
    "model.sigma0=5.0", "model.Fc=2.0", "progress=false",
]


def _compose(name: str, tmp_path: Path, overrides: list[str]):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name=name, overrides=[f"run_dir={tmp_path}", *overrides])


def _cli(module: str, tmp_path: Path, *overrides: str) -> subprocess.CompletedProcess:
    env = dict(os.environ)  # PYTHONPATH names this checkout (conftest.py)
    env.pop("HYBRIDHYST_TRACEBACK", None)
    cmd = [sys.executable, "-m", module, f"hydra.run.dir={tmp_path}", "progress=false", *overrides]
    return subprocess.run(cmd, check=False, capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path)


def test_simulate_sine_writes_summary_and_predictions(tmp_path):
    cfg = _compose("simulate", tmp_path, ["input.cycles=1", "input.samples_per_cycle=32", "progress=false"])
    summary = simulate.run(cfg)
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["records"]["sine"]["samples"] == 33 == summary["records"]["sine"]["samples"]
    assert {"model", "input", "outputs", "records", "wall_s"} <= set(on_disk)
    table = pd.read_csv(tmp_path / "predictions.csv")
    assert list(table.columns) == ["record", "t", "input", *on_disk["outputs"]]
    assert len(table) == 33 and table[on_disk["outputs"][0]].abs().max() > 0
    assert (tmp_path / "config.yaml").exists()


def test_simulate_on_bundled_records_reports_rmse(tmp_path, capsys):
    select = "input.select={kind: characterisation, tension_lb: 36, frequency_hz: 2.0}"
    cfg = _compose("simulate", tmp_path, ["input.kind=data", select, "input.downsample=16", "model.sigma0=5.0",
                                          "progress=false"])
    summary = simulate.run(cfg)
    (name, info), = summary["records"].items()
    assert name == "char_2Hz_36lb_0.5in" and info["samples"] == 225
    assert 0 < info["rmse"] < 10
    # the terminal says what was simulated, each record's error in the data's unit, and where the results are
    out = capsys.readouterr().out
    assert f"{name}: 225 samples, RMSE {info['rmse']:.4g} kip" in out and "predictions.csv" in out
    # every sample unless told otherwise (thinning interpolates a control between the samples kept)
    every = simulate.run(_compose("simulate", tmp_path / "every", ["input.kind=data", select, "progress=false"]))
    assert every["records"][name]["samples"] == 16 * 224 + 1


def test_simulate_free_vibration_needs_an_oscillator(tmp_path):
    cfg = _compose("simulate", tmp_path, ["input.kind=free_vibration", "progress=false"])
    with pytest.raises(ValueError, match="free_vibration needs an oscillator model"):
        simulate.run(cfg)


def test_fit_tiny_run_writes_report_summary_and_figure(tmp_path, capsys):
    summary = fit.run(_compose("fit", tmp_path, TINY_FIT))
    out = capsys.readouterr().out  # the terminal summary: both errors in the data's unit, the values, the report
    assert f"RMSE training {summary['rmse']['train']:.4g} kip, held-out {summary['rmse']['held_out']:.4g} kip" in out
    assert "dahl.sigma0 = " in out and "kip/in" in out and "report.md" in out and "2 adam" in out
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert {"parameters", "rmse", "per_record", "wall_s", "split", "fit"} <= set(on_disk)
    assert set(on_disk["rmse"]) == {"train", "held_out"}
    assert on_disk["split"]["held_out"] == ["char_1Hz_36lb_1in"]
    assert set(on_disk["per_record"]) == {"char_1Hz_36lb_0.5in", "char_1Hz_36lb_1.5in", "char_1Hz_36lb_1in"}
    dahl = on_disk["parameters"]["dahl"]
    assert dahl["sigma0"]["unit"] == "kip/in" and dahl["sigma0"]["value"] > 0
    assert summary["fit"]["steps"]["adam"] == 2
    # each part's sub-steps are reported (simulate_resolved, from the fit's; a held-out record that needs more:
    # tests/test_simulate.py, tests/test_validation.py)
    assert all(s >= summary["fit"]["substeps"] for s in on_disk["evaluate"]["substeps"].values())
    assert set(on_disk["evaluate"]["substeps"]) == {"train", "held_out"}
    assert summary["reference"] is None  # a different protocol than the reference numbers'
    report = (tmp_path / "report.md").read_text()
    assert "char_1Hz_36lb_1in" in report and "loop.png" in report
    assert (tmp_path / "loop.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(pd.read_parquet(tmp_path / "predictions.parquet")) > 0
    # one L-BFGS iteration cannot converge: the report and the terminal say so
    assert summary["fit"]["converged"] is False and ", converged" not in out
    assert "Not converged: L-BFGS reached fit.lbfgs_steps (1)" in report and "Not converged" in out


def test_fit_loop_figure_takes_named_records_and_refuses_unknown_ones(tmp_path):
    summary = fit.run(_compose("fit", tmp_path, [*TINY_FIT, "report.loop_records=char_1Hz_36lb_0.5in"]))
    assert summary["loop_records"] == ["char_1Hz_36lb_0.5in"]
    assert "the records of report.loop_records: char_1Hz_36lb_0.5in.*" in (tmp_path / "report.md").read_text()
    with pytest.raises(ValueError, match="report.loop_records"):
        fit.run(_compose("fit", tmp_path, [*TINY_FIT, "report.loop_records=[nope]"]))


def test_fit_rejects_a_held_out_value_no_record_has(tmp_path):
    cfg = _compose("fit", tmp_path, ["split.held_out=[{amplitude_in: [0.75]}]"])
    with pytest.raises(ValueError, match="matches no record"):
        fit.run(cfg)


def test_cli_value_error_is_one_line_and_exit_code_2(tmp_path):
    proc = _cli("hybridhyst.cli.fit", tmp_path, "data.name=brfdd")
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: unknown built-in dataset 'brfdd'; did you mean 'brfd'?"), proc.stderr
    assert not (tmp_path / "summary.json").exists()


def test_simulate_rejects_an_unknown_input_kind(tmp_path):
    with pytest.raises(ValueError, match="unknown input.kind 'square'"):
        simulate.run(_compose("simulate", tmp_path, ["input.kind=square"]))


def test_guarded_turns_value_error_into_exit_2(capsys):
    def boom(cfg):
        raise ValueError("record 'a': column 'y'\nhas 3 NaN values")

    with pytest.raises(SystemExit) as exc:
        guarded(boom, OmegaConf.create({}))
    assert exc.value.code == 2
    assert capsys.readouterr().err == "error: record 'a': column 'y' has 3 NaN values\n"


def test_atomic_writes_replace_whole_files(tmp_path):
    path = write_json(tmp_path / "s.json", {"a": float("nan"), "b": [1.5]})
    assert json.loads(path.read_text()) == {"a": None, "b": [1.5]}
    atomic_write(path, "x")
    assert path.read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]  # no temp files left behind


def test_cli_missing_data_file_is_one_line_naming_the_file(tmp_path):
    missing = tmp_path / "nope.csv"
    proc = _cli("hybridhyst.cli.simulate", tmp_path, "input.kind=data", "data=table", f"data.path={missing}")
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "nope.csv" in lines[0], proc.stderr


# -- one split convention; dataset defaults travel with the data config ------------------------------------------
def test_data_group_brings_its_defaults_and_table_brings_neutral_ones(tmp_path):
    brfd = _compose("discover", tmp_path, [])
    assert brfd.split.select == {"tension_lb": 36} and brfd.split.held_out == [{"kind": "earthquake"}]
    assert brfd.thinning.downsample == 16 and list(brfd.discover.conditions) == ["amplitude_in"]
    table = _compose("discover", tmp_path, ["data=table"])
    assert table.split.select is None and table.split.val is None and table.title is None
    assert OmegaConf.is_missing(table.split, "held_out") and table.thinning.downsample == 1
    assert table.discover.conditions is True and table.discover.label_conditions is None
    bw = _compose("discover", tmp_path, ["experiment=boucwen_discovery"])  # experiments still override
    assert bw.split.held_out == [{"split": "test"}] and bw.split.select is None and bw.discover.conditions is False
    for app in ("fit", "train"):
        cfg = _compose(app, tmp_path, [])
        assert cfg.split.select == {"kind": "characterisation", "tension_lb": 36}
        assert cfg.split.held_out == [{"amplitude_in": [1.0]}]
        neutral = _compose(app, tmp_path, ["data=table"])
        assert neutral.split.select is None and OmegaConf.is_missing(neutral.split, "held_out")
    assert _compose("identify", tmp_path, []).split.select == {"mixture": "1:3", "pressure_mpa": 0.05}
    assert _compose("identify", tmp_path, ["data=table"]).split.select is None


def test_held_out_is_a_list_of_queries_and_a_single_mapping_is_one(tmp_path):
    listed = _compose("fit", tmp_path, ["split.held_out=[{frequency_hz: [0.5]}]"])
    single = _compose("fit", tmp_path, ["~split.held_out", "+split.held_out={frequency_hz: [0.5]}"])
    assert fit.load_split(listed)[1].names == fit.load_split(single)[1].names == [
        "char_0.5Hz_36lb_0.5in", "char_0.5Hz_36lb_1.5in", "char_0.5Hz_36lb_1in"]
    assert fit._reference(_compose("fit", tmp_path, [])) is not None  # the reference protocol, list form
    with pytest.raises(ValueError, match="no held-out records"):
        fit.load_split(_compose("fit", tmp_path, ["split.held_out=null"]))
    with pytest.raises(ValueError, match="names no condition"):
        fit.load_split(_compose("fit", tmp_path, ["split.held_out=[{}]"]))


# -- a deleted or misspelt config key is one line naming it, in every app -----------------------------------------
def _one_line_error(run, cfg, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        guarded(run, cfg)
    assert exc.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


# (app, deleted key, [overrides deleting a key and adding a misspelt one], [names in that message])
KEY_CASES = [
    ("fit", "split.select", ["~split.held_out", "+split.held_ot=[{amplitude_in: [1.0]}]"],
     ["split.held_out", "split.held_ot"]),
    ("identify", "split.select", ["~noise_sd", "+noise_sdd=0.1"], ["noise_sd", "noise_sdd"]),
    ("identify", "identify.pop", ["~identify.lm_steps", "+identify.lmsteps=5"],
     ["identify.lm_steps", "identify.lmsteps"]),
    ("train", "split.val", ["~datamodule.window", "+datamodule.windw=64"], ["datamodule.windw", "datamodule.window"]),
    ("discover", "thinning.downsample", ["~discover.margin", "+discover.margn=0.05"],
     ["discover.margin", "discover.margn"]),
    ("simulate", "input.cycles", ["~simulation.method", "+simulation.methd=rk4"],
     ["simulation.method", "simulation.methd"]),
    ("study", "reduced", ["~reduced", "+reducd=true"], ["reduced", "reducd"]),
]


@pytest.mark.parametrize("app,deleted,misspelt,names", KEY_CASES, ids=[c[0] for c in KEY_CASES])
def test_a_deleted_or_misspelt_key_is_one_line_naming_it(app, deleted, misspelt, names, tmp_path, capsys):
    import importlib

    from hybridhyst.cli.study import compose_study

    run = importlib.import_module(f"hybridhyst.cli.{app}").run
    extra = ["logger=none", "trainer.enable_progress_bar=false"] if app == "train" else ["progress=false"]

    def composed(overrides):
        if app == "study":
            return compose_study("symmetric_damper", f"run_dir={tmp_path}", "progress=false", *overrides)
        return _compose(app, tmp_path, [*extra, *overrides])

    message = _one_line_error(run, composed([f"~{deleted}"]), capsys)
    assert f"config key {deleted} is missing" in message and f"'+{deleted}=" in message, message
    message = _one_line_error(run, composed(misspelt), capsys)
    assert all(name in message for name in names), message


def test_unset_values_interpolations_and_a_top_level_select_are_one_line(tmp_path, capsys):
    from hybridhyst.cli import discover, identify

    message = _one_line_error(discover.run, _compose("discover", tmp_path, ["data=table"]), capsys)
    assert "data.path" in message and "split.held_out" in message and "need a value" in message
    assert "(null: no held-out records)" in message
    # hybridhyst-fit scores only held-out records: its hint does not offer null
    message = _one_line_error(fit.run, _compose("fit", tmp_path, ["data=table", "data.path=x.csv"]), capsys)
    assert "split.held_out=[{<condition>: [<values>]}]" in message and "null" not in message, message
    message = _one_line_error(discover.run, _compose("discover", tmp_path, ["title=${nope}"]), capsys)
    assert message.startswith("error: config key title: its interpolation does not resolve")
    message = _one_line_error(identify.run, _compose("identify", tmp_path, ['+select={mixture: "1:3"}']), capsys)
    assert "split.select" in message
    # a key identify() does not take (it was silently ignored): the app and training's nominal_init share the check
    message = _one_line_error(identify.run, _compose("identify", tmp_path, ["+identify.popsize=8"]), capsys)
    assert "unknown config key identify.popsize: did you mean identify.pop?" in message


@pytest.mark.parametrize("app,override,expected", [
    ("fit", "split.selct.tension_lb=30", "did you mean split.select?"),
    # Hydra's "To append to your config use +split.held_outt=..." would add the misspelt key: left out
    ("discover", "split.held_outt=[{amplitude_in: [1.0]}]",
     "Could not override 'split.held_outt' (Key 'held_outt' is not in struct); did you mean split.held_out?"),
    ("fit", "split.held_out={amplitude_in: [0.5]}", "split.held_out holds a list: give one"),
    ("discover", "split.select=[{tension_lb: 30}]",
     "split.select holds a mapping; to give a list instead, delete the key first: '~split.select' '+split.select="),
    ("discover", "data=brfdd", "options of 'data': boucwen, brfd, table, vpptd"),
    # a key or a name that was renamed: the new one
    ("identify", "identify.method=de", "identify.method was renamed identify.search: give identify.search instead"),
    ("study", "experiment=seed001_vpptd_dynamics", "seed001_vpptd_dynamics was renamed vpptd_dynamics"),
    ("train", "loss=seed000", "loss=seed000 was renamed loss=pinn_recipe"),  # Hydra writes it loss/seed000
    # table's split.select is null: Hydra calls it missing
    ("fit", ("data=table", "~split.select"),
     "(or it is null: nothing to delete); to change it, drop '~split.select' and give split.select=<value> instead"),
    # a deleted key: only a key the command line added is offered as its misspelling (not discover.lm_steps)
    ("discover", "~discover.max_steps", "config key discover.max_steps is missing (deleted or misspelt); restore"),
    # ... and in a run the '+' key is checked first (hybridhyst.cli.overrides): a key the app would ignore
    ("discover", ("~discover.max_steps", "+discover.max_step=6"),
     "config key discover.max_step (added with '+') is not one hybridhyst-discover reads: it would be ignored; did "
     "you mean discover.max_steps?"),
])
def test_cli_composition_errors_are_one_line_and_exit_code_2(app, override, expected, tmp_path, capfd, monkeypatch):
    """The app's own ``main()`` with the command line in ``sys.argv``, in this process (a subprocess each cost
    ~5 s of imports; ``test_cli_value_error_is_one_line_and_exit_code_2`` and ``test_cli_missing_data_file...``
    keep the whole process path)."""
    from hydra.core.global_hydra import GlobalHydra

    overrides = [override] if isinstance(override, str) else list(override)
    monkeypatch.setattr(sys, "argv", [f"hybridhyst-{app}", f"hydra.run.dir={tmp_path}", "progress=false", *overrides])
    monkeypatch.delenv("HYBRIDHYST_TRACEBACK", raising=False)
    monkeypatch.chdir(tmp_path)
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    try:
        with pytest.raises(SystemExit) as exc:
            importlib.import_module(f"hybridhyst.cli.{app}").main()
    finally:  # a case that reaches the run leaves Hydra's logging (a handler on this test's captured stdout)
        GlobalHydra.instance().clear()
        for handler in set(root.handlers) - set(handlers):
            root.removeHandler(handler)
            handler.close()
        root.setLevel(level)
    lines = [line for line in capfd.readouterr().err.splitlines() if line.strip()]
    assert exc.value.code == 2 and len(lines) == 1, lines
    assert lines[0].startswith("error: ") and expected in lines[0], lines[0]


def test_what_an_app_says_reaches_the_runs_log_file_once_and_bars_stay_off_a_file(tmp_path, capsys):
    """Hydra's job log (``<run dir>/<app>.log``) held nothing: the apps print. ``say`` prints and writes the same
    text to the root logger's file handlers only (the terminal shows it once); an error goes to stderr and the
    log. A progress bar is no tqdm bar where stderr is no terminal (pytest captures it): a redirected log would
    fill with its carriage returns; it writes plain lines instead."""
    import logging

    from hybridhyst.cli.common import say
    from hybridhyst.progress import progress

    handler = logging.FileHandler(tmp_path / "app.log")
    logging.getLogger().addHandler(handler)
    try:
        say("discovery: added clearance\n  test RMSE 0.5 -> 0.3 kip")
        say("error: the split leaves no training record", error=True)
    finally:
        logging.getLogger().removeHandler(handler)
        handler.close()
    out = capsys.readouterr()
    assert out.out.count("added clearance") == 1 and out.err.count("no training record") == 1
    log = (tmp_path / "app.log").read_text()
    assert "added clearance" in log and "test RMSE 0.5 -> 0.3 kip" in log and "no training record" in log
    # no tqdm bar where stderr is no terminal: plain lines (tests/test_trust_divergence.py times them), no \r
    from hybridhyst.progress import Lines

    assert isinstance(progress(range(3), "rank candidates"), Lines)
    assert progress(range(3), "rank candidates", enabled=False).disable


def test_the_edge_line_groups_a_networks_weights():
    """Coordinates at an edge of the search box are named one by one, but a network's weights (a parameter function
    of kind neural: name[i]) as one entry with counts, so that the line stays readable."""
    from hybridhyst.cli.common import edge_line

    edges = {"viscous.c": "lower", **{f"kappa.net.head.weight[{i}]": ("lower" if i % 3 else "upper") for i in range(6)}}
    line = edge_line(edges, "identify.bounds")
    assert "viscous.c (lower edge)" in line
    assert "kappa.net.head.weight[...] (6 entries: 4 at the lower edge, 2 at the upper)" in line
    assert "weight[3]" not in line
    assert "head.bias[0] (upper edge)" in edge_line({"head.bias[0]": "upper"}, "identify.bounds")  # one: its name
