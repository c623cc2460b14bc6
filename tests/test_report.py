"""``hybridhyst.report`` and ``hybridhyst-report`` on synthetic run directories written by hand, the comparison
report's loops, and what hybridhyst-fit's report says; the loop figure and its other callers:
``tests/test_report_loops.py``.

The tree: three configurations × 3 seeds (physics, hybrid-mlp λ=0.1, lstm), a λ_phys sweep of hybrid-mlp
(λ = 0 and 1, one seed each), a training-fraction sweep (hybrid-mlp at 0.5, two seeds), one failed job
and one unreadable ``metrics.json``; every successful run has a small ``predictions.parquet``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest

from hybridhyst.cli import report as report_cli
from hybridhyst.report import collect_runs, condition_table, summary_table, write_report

matplotlib.use("Agg")


CONDITIONS = ("1 Hz", "2 Hz")
# name, module, residual, hidden, lambda_phys, train_fraction, test RMSE per seed, (1 Hz, 2 Hz) factors
CONFIGS = [
    ("physics", "physics", None, None, 0.0, 1.0, [0.5, 0.6, 0.7], (0.8, 1.2)),
    ("hybrid-mlp", "hybrid", "mlp", [128] * 4, 0.1, 1.0, [0.2, 0.25, 0.3], (0.8, 1.2)),
    ("lstm", "lstm", None, [64, 64], 0.0, 1.0, [0.3, 0.32, 0.34], (1.5, 0.5)),
    ("hybrid-mlp", "hybrid", "mlp", [128] * 4, 0.0, 1.0, [0.4], (0.8, 1.2)),
    ("hybrid-mlp", "hybrid", "mlp", [128] * 4, 1.0, 1.0, [0.35], (0.8, 1.2)),
    ("hybrid-mlp", "hybrid", "mlp", [128] * 4, 0.1, 0.5, [0.45, 0.55], (0.8, 1.2)),
]
HYBRID = "hybrid-mlp (λ=0.1, train=1)"


def _info(name, module, residual, hidden, lam, fraction, seed) -> dict:
    return {"module": module, "name": name, "residual": residual, "hidden": hidden, "lambda_phys": lam,
            "seed": seed, "train_fraction": fraction, "n_parameters": 1000 + 10 * len(hidden or []),
            "train_time_s": 10.0 + seed, "epochs": 5, "data": "brfd", "model": "bouc_wen",
            "units": {"x": "in", "F": "kip", "t": "s"}, "experiment": None}


def _scores(rmse: float) -> dict:
    return {"rmse": rmse, "mae": 0.8 * rmse, "nrmse": rmse / 2.0, "n": 100}


def _predictions(rmse: float) -> pd.DataFrame:
    t = np.linspace(0.0, 1.0, 40)
    frames = []
    for i, condition in enumerate(CONDITIONS):
        x = np.sin(2 * np.pi * (i + 1) * t)
        y = 2.0 * x + 0.5 * np.cos(2 * np.pi * (i + 1) * t)
        frames.append(pd.DataFrame({"record": f"rec {condition}", "split": "test", "condition": condition, "t": t,
                                    "x": x, "y": y, "y_pred": y + rmse, "y_nominal": np.nan}))
    return pd.concat(frames, ignore_index=True)


def _write_run(path: Path, config, seed: int, rmse: float) -> None:
    name, module, residual, hidden, lam, fraction, _, factors = config
    path.mkdir(parents=True)
    per_condition = {c: _scores(rmse * f) for c, f in zip(CONDITIONS, factors)}
    metrics = {"status": "ok", "test": {**_scores(rmse), "per_condition": per_condition},
               "val": _scores(rmse + 0.01), "train": _scores(rmse / 2),
               "info": _info(name, module, residual, hidden, lam, fraction, seed), "physics": {}}
    (path / "metrics.json").write_text(json.dumps(metrics))
    (path / "config.yaml").write_text("seed: 0\n")
    _predictions(rmse).to_parquet(path / "predictions.parquet", index=False)


def _write_tree(root: Path, configs=CONFIGS, bad: bool = True) -> Path:
    job = 0
    for config in configs:
        for seed, rmse in enumerate(config[6]):
            _write_run(root / "multirun" / "2024-01-01" / "12-00-00" / str(job), config, seed, rmse)
            job += 1
    if bad:
        failed = root / "multirun" / "2024-01-01" / "12-00-00" / str(job)
        failed.mkdir()
        info = _info("hybrid-lstm", "hybrid", "lstm", [32], 0.1, 1.0, 0)
        (failed / "metrics.json").write_text(json.dumps(
            {"status": "failed", "error": "loss is NaN at epoch 3", "info": info}))
        invalid = root / "multirun" / "2024-01-01" / "12-00-00" / str(job + 1)
        invalid.mkdir()
        (invalid / "metrics.json").write_text('{"status": "ok", "test": ')
    return root / "multirun"


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    return _write_tree(tmp_path_factory.mktemp("runs"))


@pytest.fixture(scope="module")
def written(tree, tmp_path_factory) -> Path:
    return write_report([tree], tmp_path_factory.mktemp("out") / "report", title="Synthetic comparison")


def _mean_std(values: list[float]) -> tuple[float, float]:
    mean = sum(values) / len(values)
    return mean, math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))


def test_collect_runs_reads_every_run_directory(tree):
    runs = collect_runs([tree])
    assert len(runs) == 15
    assert runs["status"].value_counts().to_dict() == {"ok": 13, "failed": 1, "invalid": 1}
    assert runs["path"].str.endswith("/10").sum() == 1  # natural order: job 10 after job 9
    assert list(runs["path"].str.rsplit("/", n=1).str[-1]) == [str(i) for i in range(15)]
    failed = runs[runs["status"] == "failed"].iloc[0]
    assert failed["error"] == "loss is NaN at epoch 3" and failed["name"] == "hybrid-lstm"
    invalid = runs[runs["status"] == "invalid"].iloc[0]
    assert invalid["error"].startswith("invalid metrics.json")
    ok = runs[runs["status"] == "ok"]
    assert ok["unit_F"].eq("kip").all() and ok["predictions"].notna().all()
    assert ok["test_rmse"].tolist()[:3] == [0.5, 0.6, 0.7]


def test_summary_means_and_std_over_seeds(tree):
    summary = summary_table(collect_runs([tree])).set_index("configuration")
    assert summary.index.is_unique and len(summary) == 6
    assert list(summary["test_rmse_mean"]) == sorted(summary["test_rmse_mean"])
    hybrid = summary.loc[HYBRID]
    mean, std = _mean_std([0.2, 0.25, 0.3])
    assert hybrid["n_seeds"] == 3 and hybrid["arch"] == "4×128" and hybrid["lambda_phys"] == 0.1
    assert hybrid["test_rmse_mean"] == pytest.approx(mean) and hybrid["test_rmse_std"] == pytest.approx(std)
    assert hybrid["test_mae_mean"] == pytest.approx(0.8 * mean) and hybrid["test_mae_std"] == pytest.approx(0.8 * std)
    assert hybrid["test_nrmse_mean"] == pytest.approx(mean / 2)
    assert hybrid["val_rmse_mean"] == pytest.approx(mean + 0.01)
    assert hybrid["train_time_s_mean"] == pytest.approx(11.0) and hybrid["n_parameters"] == 1040
    lstm = summary.loc["lstm"]
    assert lstm["arch"] == "2×64" and lstm["test_rmse_std"] == pytest.approx(_mean_std([0.3, 0.32, 0.34])[1])
    single = summary.loc["hybrid-mlp (λ=1, train=1)"]
    assert single["n_seeds"] == 1 and math.isnan(single["test_rmse_std"])
    assert pd.isna(summary.loc["physics", "arch"])


def test_condition_table_means_and_best(tree):
    runs = collect_runs([tree])
    table = condition_table(runs)
    assert list(table.index) == list(CONDITIONS)
    assert table.loc["1 Hz", HYBRID] == pytest.approx(0.8 * 0.25)
    assert table.loc["2 Hz", "lstm"] == pytest.approx(0.5 * 0.32)
    assert table.loc["2 Hz", "physics"] == pytest.approx(1.2 * 0.6)
    assert table.loc["1 Hz", "best"] == HYBRID and table.loc["2 Hz", "best"] == "lstm"


def test_write_report_files_tables_and_figures(written):
    out = written.parent
    text = written.read_text()
    assert written.name == "report.md"
    assert text.splitlines()[0].startswith("_Generated by `hybridhyst-report ") and "multirun" in text.splitlines()[0]
    assert "# Synthetic comparison" in text and "test RMSE [kip]" in text
    mean, std = _mean_std([0.2, 0.25, 0.3])
    assert f"{mean:.4g} ± {std:.4g}" in text
    assert "0.35 ± —" in text  # single seed
    assert f"**{0.5 * 0.32:.4g}**" in text and f"**{0.8 * 0.25:.4g}**" in text
    failed_section = text.split("## Failed and invalid runs")[1]
    assert "loss is NaN at epoch 3" in failed_section and "invalid metrics.json" in failed_section
    for name in ("loops", "error_per_condition", "lambda_phys", "data_efficiency"):
        png = out / "figures" / f"{name}.png"
        assert png.read_bytes()[:4] == b"\x89PNG" and f"](figures/{name}.png)" in text
    summary = pd.read_csv(out / "summary.csv")
    assert summary.loc[summary["configuration"] == HYBRID, "test_rmse_mean"].item() == pytest.approx(mean)
    per_condition = pd.read_csv(out / "per_condition.csv", index_col="condition")
    assert per_condition.loc["2 Hz", "best"] == "lstm"


def test_no_sweep_figures_when_nothing_varies(tmp_path):
    root = _write_tree(tmp_path, configs=[CONFIGS[0], CONFIGS[2]], bad=False)
    path = write_report(root, tmp_path / "out")
    assert (tmp_path / "out" / "figures" / "loops.png").exists()
    assert (tmp_path / "out" / "figures" / "error_per_condition.png").exists()
    assert not (tmp_path / "out" / "figures" / "lambda_phys.png").exists()
    assert not (tmp_path / "out" / "figures" / "data_efficiency.png").exists()
    assert "lambda_phys.png" not in path.read_text() and "None: every run" in path.read_text()


def test_cli_writes_default_report_dir(tmp_path, capsys):
    root = _write_tree(tmp_path, configs=[CONFIGS[2]], bad=False)
    report_cli.main([str(root)])
    assert capsys.readouterr().out.strip() == str(root / "report" / "report.md")
    assert (root / "report" / "summary.csv").exists()


@pytest.mark.parametrize("case", ["missing", "empty"])
def test_cli_bad_directory_exits_2_with_one_line(tmp_path, capsys, monkeypatch, case):
    monkeypatch.delenv("HYBRIDHYST_TRACEBACK", raising=False)
    target = tmp_path / "nothing_here"
    if case == "empty":
        (target / "sub").mkdir(parents=True)
    with pytest.raises(SystemExit) as exc:
        report_cli.main([str(target), "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1
    assert ("does not exist" if case == "missing" else "no run directory") in err
    assert not (tmp_path / "out").exists()


def _panels(fig) -> list:
    return [ax for ax in fig.axes if ax.get_visible()]


def _legend(fig) -> list[str]:
    return [t.get_text() for t in fig.legends[0].get_texts()]


def test_comparison_report_loops_come_from_the_loop_figure(tree, tmp_path, drawn):
    from hybridhyst.report.figures import loops_figure

    runs = collect_runs([tree])
    summary = summary_table(runs)
    notes: list[str] = []
    assert loops_figure(runs, summary, list(CONDITIONS), tmp_path / "loops.png", notes) == tmp_path / "loops.png"
    (fig,) = drawn
    panels = _panels(fig)
    assert len(panels) == len(CONDITIONS) and notes == []
    truth = _predictions(0.0)
    for ax, condition in zip(panels, CONDITIONS):
        assert ax.get_xlabel() == "displacement x [in]" and ax.get_ylabel() == "force y [kip]"
        assert ax.get_title() == condition
        rows = truth[truth["condition"] == condition]
        measured = ax.get_lines()[0]
        np.testing.assert_allclose(measured.get_xydata(), rows[["x", "y"]].to_numpy())
    assert _legend(fig)[0] == "measured" and set(_legend(fig)[1:]) <= set(summary["configuration"])


# -- hybridhyst-fit's report says what was done (issue 36) -------------------------------------------------------
TINY_FIT = ["+split.select.frequency_hz=1.0", "fit.steps=2", "fit.lbfgs_steps=1", "fit.samples_per_cycle=16",
            "model.sigma0=5.0", "model.Fc=2.0", "progress=false"]


def _fit(tmp_path, *overrides):
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli import fit
    from hybridhyst.cli.common import CONF_DIR

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("fit", overrides=[f"run_dir={tmp_path}", *TINY_FIT, *overrides])
    return fit.run(cfg), (tmp_path / "report.md").read_text()


def test_the_fit_report_states_the_grid_it_used_not_the_one_asked_for():
    """Records at 500 Hz loaded at 1 and 3 Hz hold 500 and 167 samples per cycle: unthinned, the report says so
    (before: "about 256 samples per loading cycle (every sample)" when nothing was thinned)."""
    from hybridhyst.cli.fit import _per_cycle
    from hybridhyst.cli.fit_report import grid_words
    from hybridhyst.data import Record

    t = np.arange(1000) * 0.002
    records = [Record(f"f{f:g}", t, np.sin(2 * np.pi * f * t), t, conditions={"frequency_hz": f}) for f in (1.0, 3.0)]
    every = {"f1": 1, "f3": 1}
    per_cycle = _per_cycle(records, every, "frequency_hz")
    assert per_cycle == pytest.approx({"f1": 500.0, "f3": 500.0 / 3})
    assert grid_words(every, per_cycle) == "167–500 samples per loading cycle (every sample)"
    thinned = {"f1": 4, "f3": 2}
    assert grid_words(thinned, _per_cycle(records, thinned, "frequency_hz")) == \
        "83–125 samples per loading cycle (one measured sample in 2 or 4, depending on the record)"
    assert grid_words({"a": 1, "b": 1}, {"a": None, "b": None}) == "every sample"


def test_the_fit_starts_from_a_global_search_by_default_and_says_which_start_it_used(tmp_path):
    """``fit.start=identify`` (the default) runs identify's batched search on the fit's grid first, so two Adam
    steps and one L-BFGS iteration end near the search's optimum; from the config's values (``fit.start=model``)
    the same descent ends far above it. The summary, report and terminal say which start was used, and the report
    states the grids as they were (16 samples per cycle of 1024 Hz records: one in 64)."""
    searched, text = _fit(tmp_path / "identify", "fit.identify={pop: 12, generations: 8, restarts: 3}",
                          "evaluate.samples_per_cycle=null", "evaluate.downsample=1")
    start = searched["fit"]["start"]
    assert start["start"] == "identify" and start["search"] == "cma" and math.isfinite(start["rmse"])
    assert searched["rmse"]["train"] <= start["rmse"] * 1.001  # the descent went on from the search's point
    assert "Started from a global search (fit.start=identify: cma + lm" in text
    assert "samples, 16 samples per loading cycle (one measured sample in 64)" in text
    assert "scored on 1024 samples per loading cycle (every sample)." in text
    local, text = _fit(tmp_path / "model", "fit.start=model")
    assert local["fit"]["start"] == {"start": "model"} and "Started from the model config's values" in text
    assert searched["rmse"]["train"] < 0.8 * local["rmse"]["train"]
    assert "scored on 256 samples per loading cycle (one measured sample in 4)." in text


def test_the_fit_from_a_global_search_escapes_the_local_minimum_descent_from_the_config_ends_in(tmp_path):
    """MR-damper loops (the test bed's scipy generator, 2 N noise) of a damper far from conf/model/mr_damper.yaml's
    lab-sized values: gradient descent from those values ends in a local minimum (before: ``hybridhyst-fit``'s
    only start; about 180 N RMSE here, n at 4.6 and γ < 0), from identify's global search near the noise."""
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli import fit
    from hybridhyst.cli.common import CONF_DIR
    from hybridhyst.testbed.generators import mr_damper

    truth = (8.0, 0.2, 400.0, 0.08, 0.06, 1.5)  # c, k, kappa, beta, gamma, n: inside the default search box
    rng, rows = np.random.default_rng(3), []
    for amp, f in ((5.0, 1.0), (10.0, 0.5), (10.0, 2.0), (7.5, 1.0)):
        t = np.arange(0.0, 2 / f, 1 / 400)
        force = mr_damper(t, amp, f, *truth) + rng.normal(0.0, 2.0, len(t))
        rows.append(pd.DataFrame({"record": f"a{amp}_f{f}", "t": t, "x_mm": amp * np.sin(2 * np.pi * f * t),
                                  "F_N": force, "amp_mm": amp, "frequency_hz": f}))
    pd.concat(rows).to_csv(tmp_path / "mr.csv", index=False)
    data = ["progress=false", "data=table", f"data.path={tmp_path / 'mr.csv'}", "data.record=record",
            "data.input=x_mm", "data.output=F_N", "data.units={t: s, x: mm, y: N}",
            "data.conditions=[amp_mm, frequency_hz]", "model=mr_damper", "split.held_out=[{amp_mm: [7.5]}]"]
    runs = {}
    for start in ("model", "identify"):
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            cfg = compose("fit", overrides=[f"run_dir={tmp_path / start}", *data, f"fit.start={start}"])
        runs[start] = fit.run(cfg)["rmse"]
    assert runs["identify"]["train"] < 0.1 * runs["model"]["train"], runs
    assert runs["identify"]["held_out"] < 0.1 * runs["model"]["held_out"], runs
