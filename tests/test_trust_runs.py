"""Runs a user can trust (issue 36): no code runs from a run file, interrupted runs say so, one run per run directory.

Each case is one parametrize id of a section (``code``, ``interruption``, ``concurrency``); ``scripts/trust_matrix.py``
counts them. A code case plants a file that would create ``PWNED`` in the test's folder if anything ran it, and
asserts a one-line refusal and no ``PWNED``.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from hybridhyst import runs
from hybridhyst.cli import train
from hybridhyst.cli.common import CONF_DIR, guarded
from hybridhyst.training.config import instantiate

SMOKE = ["experiment=smoke", "logger=none", "nominal_init.start=none"]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


class Plant:
    """Unpickling this creates ``path`` (what a malicious checkpoint or state dict would do)."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (Path.touch, (Path(self.path),))


def _compose(overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=overrides)


def _train(tmp: Path, name: str, *overrides) -> tuple[dict, Path]:
    """A smoke training run (2 epochs unless ``overrides`` say otherwise) into ``tmp/name``."""
    cfg = _compose([*SMOKE, "trainer.max_epochs=2", *overrides])
    OmegaConf.update(cfg, "run_dir", str(tmp / name), force_add=True)
    return train.run(cfg), tmp / name


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """One finished smoke training run."""
    tmp = tmp_path_factory.mktemp("finished")
    _train(tmp, "run")
    return tmp / "run"


def _cli(args, cwd, timeout=240) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=ENV)


# -- code from files -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["checkpoint_with_code", "copied_run_best_path_elsewhere",
                                  "model_config_target_torch_load", "model_config_nested_target",
                                  "data_config_target_read_pickle", "nominal_state_with_code",
                                  "discovered_model_of_unfinished_run", "hydra_callback_in_run_dir_model_config"])
def test_code(case, request, tmp_path):
    pwned = tmp_path / "PWNED"
    finished = request.getfixturevalue("finished") if case in ("copied_run_best_path_elsewhere",
                                                                "nominal_state_with_code") else None
    if case == "checkpoint_with_code":
        ckpt = tmp_path / "evil.ckpt"
        torch.save({"state_dict": {}, "x": Plant(pwned)}, ckpt)
        with pytest.raises(ValueError, match="not loaded"):
            _train(tmp_path, "run", f"ckpt_path={ckpt}")
    elif case == "copied_run_best_path_elsewhere":
        # a copied run directory, resumed untouched: its last.ckpt names the original's best.ckpt, which now holds
        # code; the copy's own best.ckpt is read instead
        original = tmp_path / "original"
        shutil.copytree(finished, original)
        state = torch.load(original / "checkpoints" / "last.ckpt", weights_only=True)
        for cb_state in state["callbacks"].values():
            if "best_model_path" in cb_state:
                cb_state["best_model_path"] = str(original / "checkpoints" / "best.ckpt")
        torch.save(state, original / "checkpoints" / "last.ckpt")
        copy = tmp_path / "copy"
        shutil.copytree(original, copy)
        torch.save({"state_dict": Plant(pwned)}, original / "checkpoints" / "best.ckpt")
        cfg = _compose([*SMOKE, "trainer.max_epochs=3", f"ckpt_path={copy / 'checkpoints' / 'last.ckpt'}"])
        OmegaConf.update(cfg, "run_dir", str(tmp_path / "resumed"), force_add=True)
        result = train.run(cfg)
        assert result["status"] == "ok"
        assert result["info"]["evaluated"] == "best"
    elif case in ("model_config_target_torch_load", "model_config_nested_target", "data_config_target_read_pickle"):
        evil = tmp_path / "evil.pt"
        torch.save(Plant(pwned), evil)
        cfg = _compose(SMOKE)
        node = {"_target_": "torch.load", "f": str(evil), "weights_only": False}
        if case == "model_config_target_torch_load":
            cfg.model = OmegaConf.create(node)
            target = cfg.model
        elif case == "model_config_nested_target":
            model = OmegaConf.to_container(_compose([*SMOKE, "model=coulomb_viscous"]).model)
            first = next(iter(model["effects"]))
            model["effects"][first]["c"] = node
            cfg.model = OmegaConf.create(model)
            target = cfg.model
        else:
            cfg.data = OmegaConf.create({"_target_": "pandas.read_pickle", "filepath_or_buffer": str(evil)})
            target = cfg.data
        with pytest.raises(ValueError, match="not one of hybridhyst's builders"):
            instantiate(target, _convert_="all")
    elif case == "nominal_state_with_code":
        run = tmp_path / "shared_run"
        shutil.copytree(finished, run)
        torch.save({"c": Plant(pwned)}, run / "model.pt")
        with pytest.raises(ValueError, match="not loaded"):
            _train(tmp_path, "run", f"nominal_state={run}")
    elif case == "discovered_model_of_unfinished_run":
        # a discovery killed while writing: model.pt and model/discovered.yaml, no discovery.json, no complete.json
        run = tmp_path / "killed_discovery"
        (run / "model").mkdir(parents=True)
        (run / "model.pt").write_bytes(b"")
        model = OmegaConf.to_container(_compose([*SMOKE, "model=coulomb_viscous"]).model)
        (run / "model" / "discovered.yaml").write_text(OmegaConf.to_yaml(model))
        out = _cli([sys.executable, "-m", "hybridhyst.cli.simulate", f"hydra.searchpath=[file://{run}]",
                    "model=discovered", f"hydra.run.dir={tmp_path / 'sim'}"], cwd=tmp_path)
        assert out.returncode == 2, out.stderr[-2000:]
        assert "did not finish" in out.stderr and "complete.json" in out.stderr
        assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    elif case == "hydra_callback_in_run_dir_model_config":
        # a shared run directory whose model config sets a Hydra callback (Hydra builds those before any app code)
        run = tmp_path / "shared_run"
        (run / "model").mkdir(parents=True)
        (run / "model.pt").write_bytes(b"")
        runs.mark_complete(run, "discover")
        (run / "model" / "discovered.yaml").write_text(
            f"# @package _global_\nhydra:\n  callbacks:\n    x:\n      _target_: pathlib.Path.touch\n"
            f"      self: {pwned}\n")
        out = _cli([sys.executable, "-m", "hybridhyst.cli.simulate", f"hydra.searchpath=[file://{run}]",
                    "model=discovered", f"hydra.run.dir={tmp_path / 'sim'}"], cwd=tmp_path)
        assert out.returncode == 2 and "sets Hydra's own settings" in out.stderr, out.stderr[-2000:]
    assert not pwned.exists()


# -- interruption ----------------------------------------------------------------------------------------------
def _wait_for(path: Path, timeout: float) -> None:
    end = time.monotonic() + timeout
    while not path.exists():
        if time.monotonic() > end:
            raise AssertionError(f"{path} did not appear within {timeout} s")
        time.sleep(0.2)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["train_sigterm", "train_sigint"])
def test_interruption_train(signum, tmp_path):
    """A training run stopped by a signal exits 128 + signum within seconds with one line, writes metrics.json
    with status failed, leaves a resumable state that a resumed run finishes from, and no completion marker."""
    run = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "hybridhyst.cli.train", *SMOKE, "trainer.max_epochs=100000",
                             f"hydra.run.dir={run}"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=ENV)
    try:
        _wait_for(run / "checkpoints" / "last.ckpt", 180)
        sent = time.monotonic()
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert time.monotonic() - sent < 20
    assert proc.returncode == 128 + signum, err[-2000:]
    last = [line for line in err.splitlines() if line.startswith("interrupted by")]
    assert last and signal.Signals(signum).name in last[0] and "ckpt_path=" in last[0]
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["status"] == "failed" and "interrupted" in metrics["error"]
    assert not (run / runs.COMPLETE).exists() and not (run / runs.LOCK).exists()
    state = run / "checkpoints" / "interrupted.ckpt"
    assert state.is_file()
    epoch = torch.load(state, weights_only=True)["epoch"]
    cfg = _compose([*SMOKE, f"trainer.max_epochs={epoch + 2}", f"ckpt_path={state}"])
    OmegaConf.update(cfg, "run_dir", str(tmp_path / "resumed"), force_add=True)
    assert train.run(cfg)["status"] == "ok"


def test_interruption_any_app(tmp_path, capsys):
    """Every app goes through ``guarded``: a SIGTERM mid-run is a one-line message and exit 143, the run
    directory released, no completion marker."""
    cfg = OmegaConf.create({"run_dir": str(tmp_path / "run"), "app": "simulate"})

    def app(cfg):
        runs.prepare_run_dir(cfg)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)
        raise AssertionError("not interrupted")

    with pytest.raises(SystemExit) as stop:
        guarded(app, cfg)
    assert stop.value.code == 143
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"interrupted by SIGTERM: no finished results in {tmp_path / 'run'} (no complete.json)"]
    assert not (tmp_path / "run" / runs.LOCK).exists() and not (tmp_path / "run" / runs.COMPLETE).exists()
    # a second signal while the app writes its last files and exits is ignored
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.mark.parametrize("case", ["sweep_sigterm", "report_killed_job"])
def test_interruption_sweep(case, tmp_path):
    """A multirun killed in its second job exits non-zero and never launches the third; hybridhyst-report lists the
    killed job as failed. A job killed without a chance to write (SIGKILL) is failed in the report too."""
    sweep = tmp_path / "sweep"
    if case == "sweep_sigterm":
        # job 1 trains until it is stopped; jobs 0 and 2 take seconds
        proc = subprocess.Popen([sys.executable, "-m", "hybridhyst.cli.train", "-m", *SMOKE,
                                 "trainer.max_epochs=2,100000,2", "hydra.sweep.subdir=${hydra.job.num}",
                                 f"hydra.sweep.dir={sweep}"],
                                cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
        try:
            _wait_for(sweep / "1" / "checkpoints" / "last.ckpt", 240)
            proc.send_signal(signal.SIGTERM)
            out, err = proc.communicate(timeout=60)
        finally:
            proc.kill()
        assert proc.returncode == 143, err[-2000:]
        assert "skip_finished" in err
        assert not (sweep / "2").exists()
    else:
        # job 0 finished; job 1 killed with SIGKILL: its config.yaml, no metrics.json
        _train(sweep, "0")
        (sweep / "1").mkdir()
        shutil.copy(sweep / "0" / "config.yaml", sweep / "1" / "config.yaml")
    out = _cli([sys.executable, "-m", "hybridhyst.cli.report", str(sweep), "--out", str(tmp_path / "report")],
               cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    report = (tmp_path / "report" / "report.md").read_text()
    failed = report.split("## Failed and invalid runs", 1)[1]
    assert "/1`" in failed and "failed" in failed
    assert "every run directory holds a successful run" not in report
    from hybridhyst.report import collect_runs

    rows = collect_runs(sweep)
    assert list(rows.loc[rows["status"] != "ok", "path"].map(lambda p: Path(p).name)) == ["1"]  # not .hydra/


# -- concurrency -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["second_run_while_first_lives", "lock_of_killed_run_taken_over",
                                  "rerun_replaces_tensorboard"])
def test_concurrency(case, tmp_path):
    run = tmp_path / "run"
    if case == "second_run_while_first_lives":
        holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from hybridhyst import runs; "
                                   f"runs.claim({str(run)!r}); print('held', flush=True); time.sleep(120)"],
                                  stdout=subprocess.PIPE, text=True)
        try:
            assert holder.stdout.readline().strip() == "held"
            with pytest.raises(ValueError, match=f"in use by another run \\(process {holder.pid} on "):
                _train(tmp_path, "run")
            assert not (run / "metrics.json").exists()
            # on the command line it is refused before Hydra writes its record or log into the directory in use
            out = _cli([sys.executable, "-m", "hybridhyst.cli.train", *SMOKE, f"hydra.run.dir={run}"], cwd=tmp_path)
            assert out.returncode == 2 and "in use by another run" in out.stderr, out.stderr[-2000:]
            assert not (run / ".hydra").exists() and not (run / "train.log").exists()
        finally:
            holder.kill()
            holder.wait()
        result, _ = _train(tmp_path, "run")  # SIGKILL ended its hold: the directory is free at once
        assert result["status"] == "ok"
    elif case == "lock_of_killed_run_taken_over":
        run.mkdir()  # a lock file left by a run killed long ago (its text names a process that is gone)
        (run / runs.LOCK).write_text(json.dumps({"pid": 999999, "host": os.uname().nodename, "started": "x"}))
        result, _ = _train(tmp_path, "run")
        assert result["status"] == "ok" and (run / runs.COMPLETE).is_file()
    else:
        _train(tmp_path, "run", "logger=tensorboard")
        first = sorted((run / "tensorboard").rglob("events.*"))
        _train(tmp_path, "run", "logger=tensorboard")
        second = sorted((run / "tensorboard").rglob("events.*"))
        assert first and second and not set(first) & set(second)  # the first run's events are gone


# -- what a sweep's report says --------------------------------------------------------------------------------
def test_report_names_runs_that_kept_their_start(tmp_path):
    """A configuration whose seeds all kept their starting weights is named so in the report (its errors are the
    starting model's); one whose runs trained is not."""
    from hybridhyst.report import write_report

    scores = {"rmse": 0.3, "mae": 0.2, "nrmse": 0.1, "n": 10}
    for job, (name, restored) in enumerate([("kept", True), ("kept", True), ("kept", True), ("trained", False)]):
        run = tmp_path / "sweep" / str(job)
        run.mkdir(parents=True)
        info = {"module": "hybrid", "name": name, "seed": job, "units": {"F": "Nm"}}
        (run / "metrics.json").write_text(json.dumps({
            "status": "ok", "test": {**scores, "per_condition": {}}, "val": scores, "train": scores, "info": info,
            "physics": {}, "start": {"split": "val", "rmse": 0.3, "trained_rmse": 0.5, "restored": restored}}))
    report = write_report(tmp_path / "sweep", tmp_path / "report").read_text()
    kept = report.split("## Runs that kept their starting weights", 1)[1].split("##", 1)[0]
    assert "**kept**: all 3 successful run(s) kept their starting weights" in kept
    assert "**trained**" not in kept


def test_skip_finished_keeps_a_run_launched_without_the_flag(tmp_path):
    """A sweep launched without +skip_finished=true and re-launched with it keeps the jobs that finished (the flag
    itself is no part of the run's config)."""
    first, run = _train(tmp_path, "run")
    again, _ = _train(tmp_path, "run", "+skip_finished=true")
    assert again == json.loads((run / "metrics.json").read_text()) and again["wall_s"] == first["wall_s"]


@pytest.mark.parametrize("content", [b"", b"\x00garbage\xff" * 10], ids=["empty", "random_bytes"])
def test_a_file_that_is_no_torch_file_is_one_line(content, tmp_path):
    from hybridhyst.files import load_weights

    (tmp_path / "model.pt").write_bytes(content)
    with pytest.raises(ValueError, match="is not a torch file hybridhyst can read"):
        load_weights(tmp_path / "model.pt")
