"""Seed 000 study (reduced_study): the 4-parameter VPPTD model by seed 000's PINN recipe and by identify."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from hybridhyst.studies.seed000 import pinn_identification, softplus_model

STUDY = "vpptd_pinn_identification"


def test_softplus_model_makes_all_four_parameters_positive():
    from torch.nn.utils import parametrize

    model = softplus_model()
    for effect, pname in [("viscous", "c"), ("stiffness", "k"), ("cubic", "k3"), ("friction", "Fc")]:
        fn = model.effects[effect].params[pname]
        assert parametrize.is_parametrized(fn, "value"), (effect, pname)
        assert model.effects[effect].param_specs[pname].constraint == "positive"


def test_bad_options_are_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="missing option"):
        pinn_identification({"reduced": False}, None)


def test_reduced_study_fits_both_pressures(reduced_study):
    """0.01 and 0.09 MPa, 1000 epochs: both methods reach the data's peak torque (about 18.6 and 38.3 Nm,
    seed 001's 1:3 loops) and the 4-parameter model's least-squares floor of about 1 Nm RMSE."""
    summary, run_dir = reduced_study
    fits = pd.read_csv(run_dir / "fits.csv")
    assert list(fits["p [MPa]"]) == [0.01, 0.01, 0.09, 0.09]
    for _, row in fits.iterrows():
        assert row["peak model [Nm]"] == pytest.approx(row["peak data [Nm]"], abs=1.0), row.to_dict()
    ident = fits[fits["method"] == "identify"].set_index("p [MPa]")
    pinn = fits[fits["method"] == "PINN"].set_index("p [MPa]")
    assert ident["RMSE [Nm]"].between(0.9, 1.2).all(), ident["RMSE [Nm]"]  # model-error floor
    assert (pinn["MAE [Nm]"] < ident["MAE [Nm]"]).all()  # the PINN minimises MAE, identify least squares
    assert (pinn["RMSE [Nm]"] < 1.6).all()
    # c in Nm·s/rad (φ̇ in rad/s) has the magnitude seed 000 quotes (6.7-8.3); in deg/s it would be ~0.1
    assert 7.5 < ident.loc[0.09, "c"] < 9.5 and 4.5 < ident.loc[0.01, "c"] < 6.5
    for name in ("c", "k", "Ms"):  # stiffer and more dissipative with underpressure (seed 000 Fig. 8)
        assert pinn.loc[0.09, name] > pinn.loc[0.01, name] and ident.loc[0.09, name] > ident.loc[0.01, name]
    assert summary["model_error_floor_rmse_nm"][1] < 1.2


def test_reduced_study_records_the_training_history(reduced_study):
    summary, run_dir = reduced_study
    steps = pd.read_csv(run_dir / "milestones.csv")
    start = steps[steps["epoch"] == 0]
    assert (start[["c", "k", "k2", "Ms"]].to_numpy() < 0.5).all()  # max(N(0, 0.1), 1e-6): near zero
    last = steps[steps["epoch"] == 1000]
    assert (last["loss [Nm]"] < 1.0).all() and (steps[steps["epoch"] == 1]["loss [Nm]"] > 5.0).all()
    units = pd.read_csv(run_dir / "units_check.csv")
    assert units["peak, φ̇ in rad/s [Nm]"].between(20.0, 45.0).all()
    assert (units["peak, φ̇ in deg/s [Nm]"] > 200.0).all()
    for name in ("trajectories", "loop_evolution", "parameters_vs_pressure", "final_loops"):
        assert (run_dir / f"{name}.png").stat().st_size < 150_000
    assert json.loads((run_dir / "summary.json").read_text())["reduced"] is True


@pytest.mark.slow
def test_full_study_fits_every_pressure(tmp_path):
    """The README's command (nine pressures, 2000 epochs each), end to end: every fit finite, identify at the
    4-parameter model's least-squares floor (about 1.0-1.1 Nm), both methods at the data's peak torque. Issue 36:
    two other studies' full runs failed for weeks while their reduced CI versions passed."""
    from hybridhyst.cli import study as study_cli

    cfg = study_cli.compose_study(STUDY, f"run_dir={tmp_path}", "progress=false")
    summary = study_cli.run(cfg)
    fits = pd.read_csv(tmp_path / "fits.csv")
    assert sorted(set(fits["p [MPa]"])) == list(cfg.study_options["pressures"])
    assert fits[["c", "k", "k2", "Ms", "RMSE [Nm]", "MAE [Nm]"]].notna().all().all()
    assert (fits[["c", "k", "k2", "Ms"]] > 0).all().all()  # softplus (PINN) and log boxes (identify)
    for _, row in fits.iterrows():
        assert row["peak model [Nm]"] == pytest.approx(row["peak data [Nm]"], abs=1.0), row.to_dict()
    ident = fits[fits["method"] == "identify"]
    assert ident["RMSE [Nm]"].between(0.9, 1.2).all(), ident["RMSE [Nm]"]
    assert (fits.loc[fits["method"] == "PINN", "RMSE [Nm]"] < 2.0).all()
    assert all(0.9 < v < 1.2 for v in summary["model_error_floor_rmse_nm"])
