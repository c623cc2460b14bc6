"""Seed 003 study (experiments/piezo_hybrid_pinn): the reduced run and its option checks."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hybridhyst.cli import study as study_cli
from hybridhyst.cli.common import to_plain
from hybridhyst.physics.compositions.seed003 import TABLE1
from hybridhyst.report.collect import collect_runs
from hybridhyst.studies.seed003 import _settings, sample_times

NAME = "piezo_hybrid_pinn"


def _options(**overrides) -> dict:
    cfg = study_cli.compose_study(NAME)
    return {**to_plain(cfg.study_options), "reduced": False, **overrides}


def test_sample_times_keep_the_interval_below_the_limit():
    t = sample_times(0.1, cycles=2, samples_per_cycle=64, max_interval_s=1 / 32)
    assert len(t) == 2 * 320 and np.diff(t).max() == pytest.approx(1 / 32)
    t = sample_times(50.0, cycles=2, samples_per_cycle=64, max_interval_s=1 / 32)
    assert len(t) == 128 and t[-1] == pytest.approx(127 / (64 * 50.0))


@pytest.mark.parametrize("change, message", [
    ({"test_cases": [[150, 2]]}, "outside seed 003's range"),
    ({"val_cases": [[20, 2]]}, "validation and test cases apart"),
    ({"fractions": [0.1, 0.5]}, "include 1.0"),
    ({"adopted_lambda": 0.5}, "adopted_lambda"),
])
def test_bad_options_are_clear_errors(change, message):
    with pytest.raises(ValueError, match=message):
        _settings(_options(**change))


def test_reduced_study_recovers_the_nominal_and_ranks_the_models(tmp_path):
    summary = study_cli.run(study_cli.compose_study(NAME, f"run_dir={tmp_path}", "reduced=true", "progress=false"))

    # DE + LM on sweeps of the nominal itself recovers the identifiable Table 1 values
    rec = summary["identification"]["check"]["paper_parameters"]
    assert rec["d33"] == pytest.approx(TABLE1["d33"], rel=0.01)
    assert rec["xi"] == pytest.approx(TABLE1["xi"], rel=0.03)
    assert rec["c_eq"] == pytest.approx(TABLE1["c_eq"], rel=0.05)
    assert summary["identification"]["check"]["rmse_um"] < 0.35  # the 0.3 µm noise floor
    # ... and cannot reach the noise floor on the sweeps with the rate-dependent loop width it lacks
    assert summary["identification"]["fitted"]["rmse_um"] > 2 * summary["identification"]["check"]["rmse_um"]

    pooled = summary["holdout_pooled_rmse_um"]
    assert all(math.isfinite(v) for v in pooled.values()), pooled
    # the hybrid starts at the identified physics (zero-initialised residual) and its residual branch corrects
    # part of the frequency-dependent gain the nominal lacks; the data-only networks are far off after 2 epochs
    assert pooled["Hybrid-PINN"] < pooled["physics (DE nominal)"]
    assert pooled["Hybrid-PINN"] < 0.5 * min(pooled["MLP"], pooled["LSTM"], pooled["Std-PINN"])

    # every network was a hybridhyst-train run of a Hydra multirun, read back by hybridhyst.report.collect: the
    # hybrid (Tables 2-4 and the curve share its run) and the three baselines, once each
    runs = collect_runs(tmp_path / "runs")
    assert sorted(runs["name"]) == ["hybrid-mlp", "lstm", "mlp", "std-pinn"] and set(runs["status"]) == {"ok"}
    assert set(runs["experiment"]) == {NAME} and summary["training_runs"] == 4
    # the architecture and data-fraction sweeps of one point each are the λ_phys sweep's run: no process started
    assert sorted(p.stem for p in (tmp_path / "runs").glob("*.log")) == ["data_fraction_baselines", "lambda_phys"]
    hybrid = runs[runs["name"] == "hybrid-mlp"].iloc[0]
    assert hybrid["hidden"] == (128,) * 4 and hybrid["lambda_phys"] == 0.0 and hybrid["train_windows"] > 0

    assert json.loads((tmp_path / "summary.json").read_text())["study"] == NAME
    for name in ("identification.csv", "holdout.csv", "lambda_phys.csv", "architecture.csv", "data_efficiency.csv",
                 "rate_effect.png", "holdout_loops.png", "data_efficiency.png"):
        assert (tmp_path / name).exists(), name
    assert "Table 4 analogue" in (tmp_path / "results.md").read_text()


@pytest.mark.slow
def test_full_study_ranks_the_models_on_the_held_out_cases(tmp_path):
    """The README's command (every table's Lightning runs; 10 minutes or more on a 2-core machine), end to end:
    the nominal recovered on its own sweeps, every held-out RMSE finite, the hybrids ahead of the physics alone
    and of the data-only networks. Issue 36: two other studies' full runs failed while their reduced CI versions
    passed."""
    summary = study_cli.run(study_cli.compose_study(NAME, f"run_dir={tmp_path}", "progress=false"))
    check = summary["identification"]["check"]
    assert check["paper_parameters"]["d33"] == pytest.approx(TABLE1["d33"], rel=0.01)
    assert check["rmse_um"] < 0.35 < summary["identification"]["fitted"]["rmse_um"]
    pooled = summary["holdout_pooled_rmse_um"]
    assert all(math.isfinite(v) for v in pooled.values()), pooled
    best_hybrid = min(pooled["Hybrid-PINN"], pooled["Hybrid in the loop"])
    assert best_hybrid < pooled["physics (DE nominal)"] < pooled["Std-PINN"]
    assert best_hybrid < min(pooled["MLP"], pooled["LSTM"])
    for table in ("architecture_rmse_um", "data_efficiency_rmse_um"):
        values = [v for v in summary[table].values() if isinstance(v, float)] + [
            x for v in summary[table].values() if isinstance(v, list) for x in v]
        assert values and all(math.isfinite(v) for v in values), table


def test_the_hybrid_grid_gives_the_command_every_swept_value(tmp_path, monkeypatch):
    """``TrainingRuns.launch_hybrid``: the multirun's command carries every list of the grid, a fraction of 1.0
    alone included (``sweep=data_fraction`` would otherwise sweep its own five), and the same grid's runs are the
    keys that spare a process where the folder holds them."""
    from types import SimpleNamespace

    import pandas as pd

    from hybridhyst.studies import seed003_runs as sr

    calls = []
    monkeypatch.setattr(sr.subprocess, "run", lambda cmd, **kw: calls.append(cmd) or SimpleNamespace(returncode=0))
    monkeypatch.setattr(sr, "collect_runs", lambda folder: pd.DataFrame({"status": []}))
    runs = sr.TrainingRuns.__new__(sr.TrainingRuns)
    runs.folder, runs.base, runs.table, runs.used = tmp_path, [], None, {}
    monkeypatch.setattr(runs, "_finished", lambda *key: False)
    runs.launch_hybrid("one", "data_fraction", hidden=["4x128"], lambdas=[0.001], seeds=[0])
    assert {"sweep=data_fraction", "residual.hidden='4x128'", "loss.lambda_phys=0.001", "seed=0",
            "datamodule.train_fraction=1.0", "baseline=hybrid_mlp"} <= set(calls[-1]), calls[-1]
    runs.launch_hybrid("grid", "architectures", hidden=["2x64", "4x128"], lambdas=[0.0], seeds=[1],
                       fractions=[0.5, 1.0])
    assert {"residual.hidden='2x64','4x128'", "datamodule.train_fraction=0.5,1.0"} <= set(calls[-1]), calls[-1]
    asked = []
    monkeypatch.setattr(runs, "_finished", lambda *key: asked.append(key) or True)  # the folder holds them all
    runs.launch_hybrid("again", "architectures", hidden=["2x64", "4x128"], lambdas=[0.0], seeds=[1])
    assert len(calls) == 2 and asked == [("hybrid", "2x64", 0.0, 1, 1.0), ("hybrid", "4x128", 0.0, 1, 1.0)]
