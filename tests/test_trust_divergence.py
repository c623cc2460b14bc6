"""A simulation that diverged is never a silent success (issue 36): every app names the records whose simulated
response went non-finite and the sample it went from, exits with code 2, and with ``keep_going=true`` writes its
results anyway behind a warning, with nothing derived from a diverged response reported as a value.

The data: a linear oscillator m·ÿ + c·ẏ + k·y = u (k = 1e6 N/m, m = 2 kg: ω = 707 rad/s) driven by a force and
sampled at 1 kHz (ω·dt = 0.7: explicit RK4 is stable), and one record sampled once a second: ω·dt = 707, which no
explicit step of the 64 sub-steps per sample scoring tries can integrate (RK4 is stable to ω·h ≈ 2.8), whatever
the stiffness in identification's box (k/10 to 10k). In-process ``run(cfg)`` on Hydra-composed configs.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from hydra import compose, initialize_config_dir

from hybridhyst.analysis.finite import Diverged, DivergenceError, check_finite, nonfinite_records
from hybridhyst.cli.common import CONF_DIR, guarded

K, MASS, DAMPING = 1.0e6, 2.0, 10.0
FINE_DT, COARSE_DT = 1e-3, 1.0


def _oscillator_response(u: np.ndarray, dt: float) -> np.ndarray:
    """The true displacement under the force ``u`` (semi-implicit Euler at 100 sub-steps per sample)."""
    y, v, h, out = 0.0, 0.0, dt / 100, []
    for f in u:
        out.append(y)
        for _ in range(100):
            v += h * (f - DAMPING * v - K * y) / MASS
            y += h * v
    return np.asarray(out)


def _table(path: Path) -> Path:
    """Three 1 kHz records (amp 1, 2: training; 3: held out in the held-out case) and one sampled at 1 Hz (amp
    9: the coarse record that diverges)."""
    rows = []
    for name, amp, dt, n, f in (("fine_a", 1.0, FINE_DT, 300, 5.0), ("fine_b", 2.0, FINE_DT, 300, 5.0),
                                ("fine_c", 3.0, FINE_DT, 300, 5.0), ("coarse", 9.0, COARSE_DT, 40, 0.01)):
        t = np.arange(n) * dt
        u = 1e3 * amp * np.sin(2 * np.pi * f * t)
        y = _oscillator_response(u, dt) if dt == FINE_DT else u / K
        rows.append(pd.DataFrame({"record": name, "t": t, "u": u, "y": y, "amp": amp}))
    pd.concat(rows).to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def table(tmp_path_factory) -> Path:
    return _table(tmp_path_factory.mktemp("data") / "oscillator.csv")


DATA = ["data=table", "data.record=record", "data.input=u", "data.output=y", "data.conditions=[amp]",
        "data.units={t: s, x: N, y: m}", "model=linear_oscillator", f"model.effects.stiffness.k={K}",
        "progress=false"]
SMALL_SEARCH = "{pop: 8, generations: 2, restarts: 2, lm_steps: 3}"


# app, overrides, texts the error must hold (records and samples), the file the results go to
CASES = [
    pytest.param("simulate", ["model=linear_oscillator", "model.effects.stiffness.k=1e9", "progress=false",
                              "resolve=false"],  # (step doubling resolves it: tests/test_controls_cli.py)
                 ["1 of 1 record: 'sine' from sample"], "summary.json", id="simulate-stiff-spring-on-the-default-sine"),
    pytest.param("simulate", ["model=linear_oscillator", "model.effects.stiffness.k=1e9", "input.kind=free_vibration",
                              "progress=false"],
                 ["'free_vibration' from sample"], "summary.json",
                 id="simulate-stiff-spring-free-vibration-reports-no-frequency"),
    pytest.param("simulate", [*DATA, "input.kind=data", "input.downsample=1"],
                 ["1 of 4 records: 'coarse' from sample"], "summary.json",
                 id="simulate-diverges-on-one-of-several-records"),
    pytest.param("fit", [*DATA, "model.effects.stiffness.k=1e12", "split.held_out=[{amp: [3.0]}]",
                         "split.select={amp: [1.0, 2.0, 3.0]}", "fit.start=model", "fit.steps=0", "fit.lbfgs_steps=1",
                         "fit.resolve=false"],
                 ["3 of 3 records", "'fine_a' (train) from sample", "'fine_c' (held out) from sample"], "summary.json",
                 id="fit-training-records-diverge"),
    pytest.param("fit", [*DATA, "split.held_out=[{amp: [9.0]}]", "split.select={amp: [1.0, 9.0]}", "fit.start=model",
                         "fit.steps=2", "fit.lbfgs_steps=1"],
                 ["1 of 2 records: 'coarse' (held out) from sample"], "summary.json",
                 id="fit-held-out-record-diverges-training-records-do-not"),
    pytest.param("identify", [*DATA, f"identify={SMALL_SEARCH}", "identify.fisher=false", "identify.resolve=false",
                              "split.select={amp: [1.0, 9.0]}"],
                 ["1 of 2 records: 'coarse' from sample"], "summary.json", id="identify-every-search-member-diverges"),
    pytest.param("discover", [*DATA, "split.held_out=[{amp: [9.0]}]", "split.select={amp: [1.0, 2.0, 9.0]}",
                              "discover.candidates=[cubic_stiffness]", "discover.max_steps=1",
                              "discover.conditions=false", "discover.start_states=false", "discover.lm_steps=3",
                              "discover.identify={pop: 8, generations: 2, restarts: 2}",
                              "thinning.samples_per_cycle=null"],
                 ["1 of 3 records: 'coarse' (test) from sample"], "discovery.json",
                 id="discover-held-out-record-diverges"),
    pytest.param("train", [*DATA, "model.effects.stiffness.k=1e12", "split.held_out=[{amp: [3.0]}]",
                           "split.select={amp: [1.0, 2.0, 3.0]}", "module=physics", "nominal_init.start=none",
                           "trainer=smoke", "logger=none", "datamodule.window=64", "datamodule.warmup=8",
                           "datamodule.samples_per_cycle=null"],
                 ["'fine_a' (train) from sample"], "metrics.json", id="train-nominal-diverges"),
]


def _compose(app: str, run_dir: Path, overrides: list[str], table: Path):
    path = [f"data.path={table}"] if "data=table" in overrides else []
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(app, overrides=[f"run_dir={run_dir}", *overrides, *path])


def _run(app: str, cfg):
    import importlib

    return guarded(importlib.import_module(f"hybridhyst.cli.{app}").run, cfg)


@pytest.mark.parametrize(("app", "overrides", "named", "output"), CASES)
def test_a_diverged_simulation_is_an_error_naming_records_and_samples_unless_kept_going(
        app, overrides, named, output, table, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("HYBRIDHYST_TRACEBACK", raising=False)
    stopped = tmp_path / "stopped"
    with pytest.raises(SystemExit) as exc:
        _run(app, _compose(app, stopped, overrides, table))
    assert exc.value.code == 2
    err = capsys.readouterr().err
    line = [x for x in err.splitlines() if x.startswith("error: ")][-1]
    assert "diverged on" in line and "keep_going=true writes the results anyway" in line, line
    for text in named:
        assert text in line, line
    if (stopped / output).exists():  # nothing derived from the diverged run was written (train: its failure record)
        assert json.loads((stopped / output).read_text())["status"] == "failed"

    kept = tmp_path / "kept"
    result = _run(app, _compose(app, kept, [*overrides, "keep_going=true"], table))
    err = capsys.readouterr().err
    warning = [x for x in err.splitlines() if x.startswith("warning: ")]
    assert warning and "diverged on" in warning[-1] and "results written anyway (keep_going=true)" in warning[-1]
    written = json.loads((kept / output).read_text())
    assert written == json.loads(json.dumps(written))  # plain JSON
    diverged = written["diverged"] if app != "discover" else written["diverged"]["after"]
    assert diverged and all(isinstance(d["sample"], int) for d in diverged), written
    if "input.kind=free_vibration" in overrides:  # nothing derived from the diverged response is a value
        assert written["records"]["free_vibration"]["frequency_hz"] is None  # (before: 0.006 Hz)
    assert result is not None


def test_the_helper_names_the_first_non_finite_sample_of_each_record():
    y_ok, y_bad = np.zeros(10), np.r_[np.zeros(6), np.inf, np.nan, np.nan, np.nan]
    two_channels = torch.zeros(5, 2)
    two_channels[3, 1] = float("nan")
    times = [np.arange(10) * 0.5, np.arange(10) * 0.5, np.arange(5) * 0.1]
    found = nonfinite_records([y_ok, y_bad, two_channels], ["a", "b", "c"], times, ["train", "held_out", None])
    assert found == [Diverged("b", 6, 3.0, 10, "held_out"), Diverged("c", 3, pytest.approx(0.3), 5, None)]
    assert check_finite([y_ok], ["a"]) == []
    with pytest.raises(DivergenceError) as exc:
        check_finite([y_ok, y_bad], ["a", "b"], [None, np.arange(10) * 0.5], splits="test", hint="raise x.substeps")
    assert str(exc.value) == ("the simulation diverged on 1 of 2 records: 'b' (test) from sample 6 (t = 3 s); raise "
                              "x.substeps; keep_going=true writes the results anyway")
    assert isinstance(exc.value, ValueError) and exc.value.diverged[0].record == "b"
    said = []
    assert check_finite([y_bad], ["b"], keep_going=True, warn=said.append)[0].sample == 6
    assert said == ["warning: the simulation diverged on 1 of 1 record: 'b' from sample 6; results written anyway "
                    "(keep_going=true)"]


class _Clock:
    def __init__(self):
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now


def test_long_work_prints_a_plain_line_at_most_every_interval_when_stderr_is_not_a_terminal(monkeypatch):
    """With output redirected to a file the main job printed nothing for 21 minutes (the bar was off where stderr
    is no terminal). Now a plain line (what, step/total, elapsed) once work has run for ``INTERVAL_S``, at most one
    per ``INTERVAL_S`` over all bars, and a last one when such work ends; no carriage returns; short work silent."""
    import io

    import hybridhyst.progress as progress_module
    from hybridhyst.progress import INTERVAL_S, Lines, progress

    clock, err = _Clock(), io.StringIO()  # a StringIO is no terminal, like a file
    monkeypatch.setattr(progress_module, "time", clock)
    monkeypatch.setattr("sys.stderr", err)
    monkeypatch.setattr(Lines, "last_line", -float("inf"))
    for _ in progress(range(5), "short"):  # seconds of work: nothing
        clock.now += 1.0
    assert err.getvalue() == ""
    with progress(total=30, desc="rank candidates") as bar:
        for _ in range(30):
            clock.now += INTERVAL_S / 4
            bar.update(1)
            bar.set_postfix(cost="0.5")
    lines = err.getvalue().splitlines()
    assert "\r" not in err.getvalue() and len(lines) == 8, lines  # 75 s of work: 7 lines, one per 10 s, + the end
    assert lines[0] == "rank candidates: 4/30 (10 s, cost=0.5)" and lines[-1] == "rank candidates: done, 30/30 in 75 s"
    assert progress(range(3), "x", enabled=False).disable  # enabled=False: the silent bar, as before
