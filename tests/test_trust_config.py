"""Config mistakes end in one line that names the key and the fix, with exit code 2 (issue 36).

Each case is one mistake a user makes on the command line, run in-process where the process would run it: Hydra's
composition through ``hydra_entry`` (a malformed override, an unknown key or group option), the app's ``run``
through ``guarded`` (a value the app cannot use). The checks of the command line's overrides
(``hybridhyst.cli.overrides``) read them from the Hydra run: ``hydra_run`` sets up the ``HydraConfig`` that
``@hydra.main`` would. Two subprocesses check the real entry point end to end.
"""

from __future__ import annotations

import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from omegaconf import open_dict

from hybridhyst.cli.common import CONF_DIR, guarded, hydra_entry
from hybridhyst.cli.overrides import check_overrides

ROOT = Path(__file__).resolve().parents[1]
TRAIN = ["logger=none", "trainer.enable_progress_bar=false", "nominal_init.start=none"]


def _compose(app: str, overrides, hydra_cfg: bool = False):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name=app, overrides=list(overrides), return_hydra_config=hydra_cfg)


@contextmanager
def hydra_run(app: str, tmp_path: Path, overrides):
    """The task config of ``hybridhyst-<app> <overrides>`` with ``HydraConfig`` set as in the app's Hydra run (its
    overrides, its run directory ``tmp_path``); reset afterwards."""
    cfg = _compose(app, overrides, hydra_cfg=True)
    with open_dict(cfg):
        cfg.hydra.runtime.output_dir = str(tmp_path)
    before = HydraConfig.instance().cfg
    HydraConfig.instance().set_config(cfg)
    task = cfg.copy()
    with open_dict(task):
        del task["hydra"]
    try:
        yield task
    finally:
        HydraConfig.instance().cfg = before


def _one_line(call, capsys) -> str:
    """The single ``error: ...`` line ``call()`` ends with (exit code 2)."""
    with pytest.raises(SystemExit) as exc:
        call()
    assert exc.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


def _run_module(app: str):
    import importlib

    return importlib.import_module(f"hybridhyst.cli.{app}").run


def _mistake(stage: str, app: str, overrides, tmp_path, capsys, monkeypatch) -> str:
    """The one-line error of ``hybridhyst-<app> <overrides>``: ``compose`` (Hydra's composition, via
    ``hydra_entry``), ``run`` (``guarded(run, cfg)`` on a config composed with the compose API) or ``hydra``
    (the same inside a Hydra run, where the command line's overrides are checked)."""
    extra = [*TRAIN, f"run_dir={tmp_path}"] if app == "train" else ["progress=false", f"run_dir={tmp_path}"]
    if stage == "compose":
        monkeypatch.setattr(sys, "argv", [f"hybridhyst-{app}", *overrides])  # read back for a cut-short override
        return _one_line(lambda: hydra_entry(lambda: _compose(app, [*extra, *overrides])), capsys)
    if stage == "run":
        cfg = _compose(app, [*extra, *overrides])
        return _one_line(lambda: guarded(_run_module(app), cfg), capsys)
    with hydra_run(app, tmp_path, [*extra, *overrides]) as cfg:
        return _one_line(lambda: guarded(_run_module(app), cfg), capsys)


# -- mistakes that ended in a message naming no key, a traceback, or nothing at all -----------------------------------
# (stage, app, overrides, [texts of the one line: the key, what is wrong, the fix])
NAMED_NOW = {
    "fit-steps-not-a-number": ("hydra", "fit", ["fit.steps=abc"],
                               ["config key fit.steps must be a whole number, got 'abc': give fit.steps=<int>"]),
    "max-epochs-not-a-number": ("run", "train", ["trainer.max_epochs=abc"],
                                ["config key trainer.max_epochs must be a whole number, got 'abc'",
                                 "trainer.max_epochs=<int>"]),
    "max-epochs-not-a-number-in-a-run": ("hydra", "train", ["trainer.max_epochs=abc"],
                                         ["config key trainer.max_epochs must be a whole number, got 'abc'"]),
    "model-parameter-not-a-number": ("hydra", "fit", ["model.c=abc"],
                                     ["config key model.c must be a number, got 'abc': give model.c=<number>"]),
    "max-epochs-below-minus-one": ("run", "train", ["trainer.max_epochs=-5"],
                                   ["trainer.max_epochs must be >= 0, got -5", "give trainer.max_epochs=<epochs>"]),
    "max-epochs-minus-one-without-a-stopping-rule": ("run", "train", ["trainer.max_epochs=-1"],
                                                     ["trainer.max_epochs=-1 (no limit) trains without end",
                                                      "'+trainer.extra.max_steps=<steps>'"]),
    "plus-key-the-app-never-reads": ("hydra", "fit", ["+fit.stepz=10"],
                                     ["config key fit.stepz (added with '+') is not one hybridhyst-fit reads",
                                      "did you mean fit.steps? give fit.steps=10"]),
    "negative-sign-smoothing-velocity": ("run", "fit", ["model=coulomb_viscous", "model.effects.coulomb.v_s=-0.05"],
                                         ["effect 'coulomb' (coulomb): parameter v_s", "needs a value > 0, got -0.05",
                                          "give v_s a value > 0"]),
    "negative-damping-coefficient": ("run", "fit", ["model.c=-6.7"],
                                     ["effect 'viscous': parameter c (viscous coefficient)",
                                      "needs a value >= 0, got -6.7", "give c a value >= 0"]),
    "unquoted-mapping-split-by-the-shell": ("compose", "fit", ["data.units={t:", "s,", "x:", "deg,", "y:", "Nm}"],
                                            ["override 'data.units={t:' is cut short",
                                             "quote the whole override: 'data.units={t: s, x: deg, y: Nm}'"]),
}


# -- mistakes that were one line already (kept so) ----------------------------------------------------------------
ALREADY_CLEAN = {
    "misspelt-key-override": ("compose", "fit", ["split.selct.tension_lb=30"],
                              ["split.selct", "did you mean split.select?"]),
    "unknown-group-option": ("compose", "fit", ["model=nosuch"], ["model/nosuch", "options of 'model':",
                                                                  "dahl_friction"]),
    "deleted-needed-key": ("hydra", "fit", ["~split.held_out"],
                           ["config key split.held_out is missing", "'+split.held_out=<value>'"]),
    "unset-mandatory-value": ("run", "fit", ["data=table", "data.path=x.csv"],
                              ["config key split.held_out needs a value (??? in the config)",
                               "split.held_out=[{<condition>: [<values>]}]"]),
    "mapping-where-a-list-is-held": ("compose", "fit", ["split.held_out={amplitude_in: [0.5]}"],
                                     ["split.held_out holds a list: give one"]),
    "list-where-a-mapping-is-held": ("compose", "discover", ["split.select=[{tension_lb: 30}]"],
                                     ["split.select holds a mapping", "'~split.select' '+split.select="]),
    "interpolation-that-does-not-resolve": ("run", "discover", ["title=${nope}"],
                                            ["config key title: its interpolation does not resolve",
                                             "set title=<value>"]),
    "unknown-effect-name": ("run", "fit", ["model=coulomb_viscous", "model.effects.coulomb.effect=coulomg"],
                            ["effect 'coulomb': unknown effect 'coulomg' (did you mean 'coulomb'?)"]),
    "misspelt-effect-parameter": ("run", "fit", ["model=coulomb_viscous", "+model.effects.coulomb.Fcc=1.0"],
                                  ["effect 'coulomb' (coulomb) has no parameter(s) ['Fcc']", "did you mean Fc"]),
    "unknown-structure": ("run", "fit", ["model=coulomb_viscous", "model.structure=nosuch"],
                          ["unknown structure 'nosuch'", "'constitutive'"]),
    "experiment-for-another-app": ("hydra", "fit", ["experiment=boucwen_discovery"],
                                   ["experiment boucwen_discovery is for hybridhyst-discover, not hybridhyst-fit",
                                    "run it with hybridhyst-discover experiment=boucwen_discovery"]),
}


CASES = {**NAMED_NOW, **ALREADY_CLEAN}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_config_mistake_is_one_line_with_the_key_and_the_fix(case, tmp_path, capsys, monkeypatch):
    """The 21 cases: the 10 that were not named before this change (NAMED_NOW) and the 11 that were (ALREADY_CLEAN)."""
    stage, app, overrides, expected = CASES[case]
    message = _mistake(stage, app, overrides, tmp_path, capsys, monkeypatch)
    assert all(text in message for text in expected), message


# -- what must keep working -----------------------------------------------------------------------------------------
# every '+key' the README, the experiments and the scripts use, and the free-form mappings the apps read (as the
# shell passes them: without the quotes)
DOCUMENTED_PLUS = [
    ("train", ["+skip_finished=true"]),
    ("train", ["trainer.max_epochs=-1", "+trainer.extra.max_steps=3", "trainer.devices=auto"]),
    ("train", ["+loss.normalise=false", "+datamodule.label_conditions=[tension_lb]"]),
    ("fit", ["+split.select.frequency_hz=1.0"]),
    ("fit", ["~split.held_out", "+split.held_out={frequency_hz: [0.5]}"]),
    ("fit", ["data=table", "data.path=x.csv", "+data.read_options.header=0", "data.units={t: s, x: in, y: kip}"]),
    ("discover", ["~split.select", "+split.select=[{kind: characterisation, tension_lb: 30}, {kind: earthquake}]"]),
    ("simulate", ["model=vpptd_rig", "+conditions.pressure_mpa=0.05", "input.duration_s=20"]),
    ("identify", ["+identify.bounds.hysteresis.n=[1.0, 4.0]", "hydra.searchpath=[file:///tmp]"]),
]


@pytest.mark.parametrize("app,overrides", DOCUMENTED_PLUS, ids=[f"{a}:{' '.join(o)}" for a, o in DOCUMENTED_PLUS])
def test_documented_overrides_pass_the_check(app, overrides, tmp_path):
    with hydra_run(app, tmp_path, overrides) as cfg:
        check_overrides(cfg, app)


def _documented_commands() -> list[tuple[str, list[str]]]:
    """(app, overrides) of every command in the README's, docs/'s and the experiments' READMEs' code blocks (a
    sweep's first value; lines with shell variables left out)."""
    import re
    import shlex

    commands = []
    for readme in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
                   *sorted((ROOT / "experiments").glob("*/README.md"))]:
        for block in re.findall(r"```(?:bash|sh)?\n(.*?)```", readme.read_text(encoding="utf-8"), flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                try:
                    words = shlex.split(line, comments=True)
                except ValueError:
                    continue
                app = words[0].removeprefix("hybridhyst-") if words and words[0].startswith("hybridhyst-") else ""
                if app not in APPS or any("$" in w or "choice(" in w for w in words):
                    continue
                overrides = [w for w in words[1:] if w not in ("-m", "--multirun")]
                commands.append((app, [w.split(",")[0] if "," in w and not re.search(r"[\[{]", w) else w
                                       for w in overrides]))
    return commands


APPS = ("identify", "fit", "discover", "train", "simulate", "study")


def test_every_documented_command_passes_the_check(tmp_path):
    commands = _documented_commands()
    assert len(commands) > 20 and {app for app, _ in commands} == set(APPS)
    for app, overrides in commands:
        with hydra_run(app, tmp_path, overrides) as cfg:
            check_overrides(cfg, app)


def test_max_epochs_minus_one_is_lightnings_no_limit_with_a_stopping_rule():
    from hybridhyst.training.build import max_epochs

    cfg = _compose("train", [*TRAIN, "trainer.max_epochs=-1", "+trainer.extra.max_time=00:00:01:00"])
    assert max_epochs(cfg) == -1
    assert max_epochs(_compose("train", [*TRAIN, "trainer.max_epochs=0"])) == 0
    with pytest.raises(ValueError, match=r"config key trainer.max_epochs must be a whole number, got 2.5"):
        max_epochs(_compose("train", [*TRAIN, "trainer.max_epochs=2.5"]))


def test_an_app_inside_another_apps_run_is_not_checked_against_its_command_line(tmp_path):
    """A study runs other apps' ``run`` inside its own Hydra run: the study's overrides are not theirs."""
    with hydra_run("study", tmp_path, ["experiment=symmetric_damper", "+study_options.x=1"]):
        check_overrides(_compose("fit", ["+fit.stepz=10"]), "fit")


# -- the entry points, end to end (a subprocess each: ~5 s of imports) -------------------------------------------------
def _cli(app: str, tmp_path: Path, *overrides: str) -> str:
    env = dict(os.environ)  # PYTHONPATH names this checkout (conftest.py)
    env.pop("HYBRIDHYST_TRACEBACK", None)
    cmd = [sys.executable, "-m", f"hybridhyst.cli.{app}", f"hydra.run.dir={tmp_path}", "progress=false", *overrides]
    proc = subprocess.run(cmd, check=False, capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path)
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    return lines[0]


def test_cli_refuses_a_plus_key_it_would_ignore_and_text_for_a_number(tmp_path):
    message = _cli("fit", tmp_path, "+fit.stepz=10", "model=coulomb_viscous")
    assert "config key fit.stepz (added with '+')" in message and "did you mean fit.steps?" in message, message


def test_cli_names_the_whole_override_the_shell_cut_short(tmp_path):
    message = _cli("simulate", tmp_path, "data.units={t:", "s,", "x:", "deg,", "y:", "Nm}")
    assert "quote the whole override: 'data.units={t: s, x: deg, y: Nm}'" in message, message


@pytest.mark.parametrize("key,value,expected", [("lr", -0.1, "fit.lr must be > 0"), ("lr", 0, "fit.lr must be > 0"),
                                                ("steps", 5.5, "fit.steps must be a whole number"),
                                                ("steps", -5, "fit.steps must be >= 0")])
def test_fit_refuses_descent_settings_that_cannot_descend(key, value, expected):
    """A negative rate climbed the loss and ended "ok"; 5.5 steps was kept as 5.5 in config.yaml."""
    from omegaconf import OmegaConf

    from hybridhyst.cli.fit import _descent_settings

    fit = OmegaConf.create({"steps": 100, "lr": 0.05, "lbfgs_steps": 0, key: value})
    with pytest.raises(ValueError, match=expected):
        _descent_settings(fit)
