"""Seed 002 study, reduced: loop metrics of hybridhyst's loops, Table 1 trends, Bouc–Wen(-p) fits vs Monte Carlo."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from hybridhyst.analysis import fit_trend
from hybridhyst.studies.seed002 import TABLE1

STUDY = "vpptd_loop_metrics"


def test_table1_is_self_consistent_and_rises_to_a_maximum(reduced_study):
    """k_eq_a is the mean of k_eq_l and k_eq_u to Table 1's rounding; each metric fits y0 + a(1 − e^(−bp))."""
    summary, _ = reduced_study
    k_mean = 0.5 * (np.array(TABLE1["loading_stiffness"]) + np.array(TABLE1["unloading_stiffness"]))
    assert np.abs(k_mean - TABLE1["average_stiffness"]).max() <= 0.0051
    r2 = {k.split(" | ")[1]: v for k, v in summary["trend_r2"].items() if k.startswith("seed 002 Table 1")}
    assert len(r2) == 5 and min(r2.values()) > 0.98, r2


def test_metrics_of_the_seed001_abs_loops(reduced_study):
    """Seed 002's windows on the ABS law at ±5°, p = 0 and 0.05 MPa (regression values of the definitions:
    a wrong branch, window or loop orientation changes them by far more than the tolerance)."""
    summary, _ = reduced_study
    m = {k: np.array(v) for k, v in summary["metrics"]["seed 001 ABS model"].items()}
    assert m["average_stiffness"] == pytest.approx(0.5 * (m["loading_stiffness"] + m["unloading_stiffness"]))
    assert (m["loading_stiffness"][[0, -1]], m["unloading_stiffness"][[0, -1]]) == (
        pytest.approx([0.515, 1.487], abs=0.01), pytest.approx([2.86, 10.38], abs=0.05))
    assert m["peak_response"][[0, -1]] == pytest.approx([6.02, 19.44], abs=0.1)
    assert m["dissipated_energy"][[0, -1]] == pytest.approx([62.1, 226.9], abs=0.5)
    assert all(np.all(np.diff(v) > 0) for v in m.values())  # every metric rises with underpressure


def test_table2_diverges_and_the_fits_beat_monte_carlo(reduced_study):
    summary, run_dir = reduced_study
    assert summary["table2_all_diverge"]
    per = pd.read_csv(run_dir / "per_pressure.csv")
    err = per.pivot(index="p [MPa]", columns="method", values="error [%]")
    assert (err["identify"] < 20).all() and (err["identify"] < err["Monte Carlo (uniform)"]).all()
    bwp = summary["bwp"]
    # the reduced budget (CMA-ES pop 32 x 20 generations, 15 LM steps) leaves the joint fit short of the full
    # study's (min R² 0.991, max error 9.4 %, re-run 2026-11-27): since cma's CMA-ES replaced the hand-written
    # one the reduced run ended at R² 0.975, 15.8 % (it was 0.992, 9.1 %), and with the start fitted to the path by
    # the loops' sensitivities (issue 36) at 0.982, 13.5 %; a broken joint fit ends far below both
    assert bwp["min_R2"] > 0.97 and bwp["max_error_pct"] < 17.0 and bwp["coordinates"] == 19
    assert {"metrics.png", "loops.png"} <= {p.name for p in run_dir.glob("*.png")}


# the continuation path of the full run (path.csv of 2026-11-27, 5 digits): γ and β nearly cancel along it
PATH = {"omega": [6.3422, 10.289, 14.083, 18.083, 22.556, 25.425, 28.237, 31.41, 34.479, 36.61, 39.042],
        "xi": [0.056926, 0.042227, 0.035383, 0.032916, 0.030053, 0.030665, 0.029443, 0.028934, 0.029178, 0.030131,
               0.030359],
        "alpha": [0.013178, 0.0063023, 0.0039516, 0.002726, 0.0019467, 0.0016712, 0.0014671, 0.0012794, 0.0011403,
                  0.0010828, 0.0010169],
        "beta": [-59.396, -115.53, -198.04, -299.72, -429.5, -560.82, -744.61, -915.75, -949.21, -966.26, -974.44],
        "gamma": [62.7, 120.63, 204.18, 306.88, 437.65, 568.88, 752.49, 923.62, 957.09, 973.81, 981.78]}


def test_the_bwp_start_simulates_at_every_pressure(float64):
    """Issue 36: fitted one by one to this path, the exponential trends of γ and β miss it by tens each, and at
    0 MPa the start's γ − β turned negative: a law whose z grows without bound, from which the joint refinement
    could not move. Fitted by what each loop sees of the parameters (its output Jacobian), the start simulates
    at every pressure."""
    from hybridhyst.cli import study as study_cli
    from hybridhyst.cli.common import to_plain
    from hybridhyst.physics.compositions.seed002 import TABLE2_FITS, bouc_wen_p
    from hybridhyst.simulate import simulate
    from hybridhyst.studies.seed002 import FREE, _loops, _options, _path_sensitivities, _trend_start

    opts = _options({**to_plain(study_cli.compose_study(STUDY).study_options), "reduced": False, "seed": 0})
    records = _loops(opts, float(opts["noise_sd"])).records
    path = pd.DataFrame({"p [MPa]": opts["pressures"], **PATH})
    alone = {"A": ("exp_rise", 1.0, 0.0, 1.0), **{
        k: (TABLE2_FITS[k][0], *(lambda t: (t.y0, t.a, t.b))(fit_trend(path["p [MPa]"], path[k], TABLE2_FITS[k][0])))
        for k in FREE}}
    fits, table = _trend_start(path, _path_sensitivities(opts, records, path))

    def finite(fits) -> list[bool]:
        with torch.no_grad():
            return [bool(torch.isfinite(y).all()) for y in simulate(bouc_wen_p(fits).double(), records, backend="fast")]

    assert finite(alone) == [False] + [True] * 10  # the trends fitted one by one diverge at 0 MPa
    assert all(finite(fits))
    assert (table["R2 (path), fitted alone"] > 0.5).all() and np.isfinite(table[["y0", "a", "b [1/MPa]"]]).all().all()


def test_a_bwp_start_that_diverges_is_a_clear_error():
    """The joint refinement cannot move from a non-finite cost: a start that diverges says so (Table 2's fits)."""
    from hybridhyst.studies.seed002 import _joint
    from hybridhyst.synth import load_vpptd

    records = load_vpptd(mixtures="ABS", pressures=[0.0, 0.05], cycles=1, samples_per_cycle=100, frequency_hz=0.025,
                         amplitude_deg=5.0).records
    with pytest.raises(ValueError, match=r"diverges at p = \[0.0, 0.05\] MPa"):
        _joint({"joint_lm_steps": 1}, records, {}, False)


def test_bad_options_are_clear_errors():
    from hybridhyst.studies.seed002 import _options

    with pytest.raises(ValueError, match="missing option"):
        _options({"mixture": "ABS"})
    base = {k: None for k in ("mixture", "amplitude_deg", "frequency_hz", "samples_per_cycle", "noise_sd",
                              "monte_carlo", "identify", "continuation_lm_steps", "joint_lm_steps")}
    good = {**base, "pressures": [0.0, 0.01, 0.02, 0.05], "amplitude_deg": 5.0, "cycles": 2,
            "loading_window": [1.0, 3.0], "unloading_window": [3.5, 5.0],
            "bounds": {k: [0.0, 1.0] for k in ("omega", "xi", "alpha", "gamma", "beta")}}
    assert _options(good)["pressures"] == [0.0, 0.01, 0.02, 0.05]
    with pytest.raises(ValueError, match="at least 4 distinct"):
        _options({**good, "pressures": [0.0, 0.01, 0.02]})
    with pytest.raises(ValueError, match="inside the amplitude"):
        _options({**good, "amplitude_deg": 4.0})


@pytest.mark.slow
def test_full_study_fits_the_bwp_model_at_every_pressure(tmp_path):
    """The README's command (11 pressures, 20 000 Monte Carlo points each; about 2 minutes). Issue 36: it ended
    'the loop has non-finite samples' while the reduced run passed: the B–W–p start, each trend fitted to its
    parameter's path alone, diverged at 0 MPa, so the joint refinement could not move from it."""
    from hybridhyst.cli import study as study_cli

    cfg = study_cli.compose_study(STUDY, f"run_dir={tmp_path}", "progress=false")
    summary = study_cli.run(cfg)
    assert summary["pressures_mpa"] == list(cfg.study_options["pressures"])
    for source, metrics in summary["metrics"].items():
        assert all(np.isfinite(v).all() for v in metrics.values()), source
    bwp = summary["bwp"]
    assert bwp["coordinates"] == 19 and bwp["min_R2"] > 0.985 and bwp["max_error_pct"] < 12.0, bwp
    per = summary["per_pressure"]
    assert per["identify"]["mean_R2"] > 0.99 and per["identify"]["mean_error_pct"] < 10.0
    assert per["identify"]["mean_R2"] > max(per["Monte Carlo (uniform)"]["mean_R2"],
                                            per["Monte Carlo (log box)"]["mean_R2"])
    assert summary["table2_all_diverge"]
    start = pd.read_csv(tmp_path / "bwp_start.csv")
    assert np.isfinite(start[["y0", "a", "b [1/MPa]"]].to_numpy()).all()
