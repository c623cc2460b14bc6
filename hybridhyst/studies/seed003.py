"""Seed 003 (Kou et al., Hybrid-PINN for a lever-amplified piezo actuator) on synthetic voltage sweeps.

The "measured" actuator is seed 003's nominal (``piezo_attenuation``, Table 1; x and h in µm, u in V) with
two rate dependences the nominal lacks, both named by seed 003: the Bouc–Wen gain (loop width, Sec. 4.5.3)
and the attenuation coefficient ξ (band-wise ξ, Sec. 4.3) rise with the drive frequency (``exp_rise``
parameter functions of ``frequency_hz``). Unipolar sine sweeps of two cycles, 0 … U ≤ 100 V at 0.1–50 Hz,
with Gaussian sensor noise; seed 003's Table 4 voltage–frequency cases are held out (``seed003_actuator``).

Protocol (seed 003 Secs. 3–4): differential evolution + Levenberg–Marquardt (``hybridhyst.identify``)
identifies the nominal on training sweeps; every network is then a ``hybridhyst-train`` run, launched as Hydra
multiruns over ``conf/experiment/piezo_hybrid_pinn_training.yaml`` and ``conf/sweep/*.yaml`` and read
back with ``hybridhyst.report.collect`` (``seed003_runs``). The Hybrid-PINN is ``HybridModule`` (the identified,
frozen nominal + a parallel tanh MLP residual with a zero-initialised last layer, data MSE + λ_phys ×
equation-of-motion residual); the baselines are the data-only MLP and LSTM, the standard PINN and the
identified nominal alone; next to the parallel Hybrid-PINN, the in-the-loop hybrid (``placement: dynamics``: a
small MLP force, with one latent state, inside the actuator's equation of motion, reading the drive frequency
and amplitude). Tables 1 (identified parameters), 2 (residual architecture), 3 (λ_phys, several seeds), 4
(held-out cases) and the data-efficiency curve (``seed003_report``).
"""

from __future__ import annotations

from ..data import RecordSet
from ..progress import progress as progress_bar
from . import resolve_options
from .seed003_actuator import (
    case_name,
    case_pairs,
    id_summary,
    identification_table,
    identify_nominal,
    paper_parameters,
    rate_figure,
    sample_times,
    sweep_records,
    true_actuator,
)
from .seed003_report import (
    architecture_table,
    efficiency_figure,
    efficiency_table,
    holdout_figure,
    holdout_table,
    lambda_table,
    run_summary,
)
from .seed003_runs import TrainingRuns, sweep_values, write_sweeps

__all__ = ["hybrid_pinn_piezo", "paper_parameters", "sample_times", "sweep_records", "true_actuator"]

_REQUIRED = ("amplitudes_v", "frequencies_hz", "val_cases", "test_cases", "cycles", "samples_per_cycle",
             "max_interval_s", "noise_um", "rate_gain", "xi_gain", "rate_corner_hz", "sigma_s_per_um", "truth_substeps",
             "identify", "train", "architectures", "lambdas", "seeds", "fractions", "adopted_lambda")


def _settings(options: dict) -> dict:
    """The experiment's options, with ``reduced_options`` applied when ``reduced``; checked."""
    o = resolve_options(options, _REQUIRED, "piezo_hybrid_pinn")
    cases = [(float(a), float(f)) for a in o["amplitudes_v"] for f in o["frequencies_hz"]]
    bad = [c for c in cases + case_pairs(o["val_cases"]) + case_pairs(o["test_cases"])
           if not (0 < c[0] <= 100 and 0.1 <= c[1] <= 50)]
    if bad:
        raise ValueError(f"sweep cases {bad} are outside seed 003's range (0-100 V, 0.1-50 Hz)")
    if not set(case_pairs(o["test_cases"])) or set(case_pairs(o["test_cases"])) & set(case_pairs(o["val_cases"])):
        raise ValueError("give at least one test case and keep validation and test cases apart")
    if not all(0 < float(f) <= 1 for f in o["fractions"]) or 1.0 not in [float(f) for f in o["fractions"]]:
        raise ValueError(f"fractions {o['fractions']} must lie in (0, 1] and include 1.0 (the full training set)")
    if o["adopted_lambda"] != "best_val" and float(o["adopted_lambda"]) not in [float(x) for x in o["lambdas"]]:
        raise ValueError(f"adopted_lambda must be 'best_val' or one of lambdas {o['lambdas']}")
    if "4x128" not in o["architectures"]:
        raise ValueError("architectures must include seed 003's adopted 4x128")
    return o



def _query(cases) -> list[dict]:
    return [{"amplitude_v": [a], "frequency_hz": [f]} for a, f in case_pairs(cases)]



def hybrid_pinn_piezo(options: dict, out) -> dict:
    """Seed 003's tables 1–4 and data-efficiency curve on synthetic piezo sweeps (module docstring)."""
    o = _settings(options)
    progress, seed = bool(options.get("progress", False)), int(options.get("seed", 0))
    root = out.dir / "runs"  # the sweeps, the identified nominal's training runs (a Hydra sweep folder)
    root.mkdir(parents=True, exist_ok=True)
    truth = true_actuator(o["rate_gain"], o["xi_gain"], o["rate_corner_hz"], o["sigma_s_per_um"])
    train_cases = [c for c in ((float(a), float(f)) for a in o["amplitudes_v"] for f in o["frequencies_hz"])
                   if c not in set(case_pairs(o["test_cases"]) + case_pairs(o["val_cases"]))]
    data = sweep_records(truth, train_cases + case_pairs(o["val_cases"]) + case_pairs(o["test_cases"]), seed=seed,
                         **_sweep_options(o))
    check, fitted, summary = _identification(o, data, train_cases, seed, progress)
    out.table("identification", identification_table(check, fitted, o),
              "Table 1 analogue: nominal parameters identified by differential evolution + LM (seed 003 units)")
    nominal = {"sigma": o["sigma_s_per_um"], **paper_parameters(fitted.x)}
    split = {"test": _query(o["test_cases"]), "val": _query(o["val_cases"])}
    runs = TrainingRuns(root, write_sweeps(data, root), nominal, split, o["train"])
    tables = _training_tables(runs, o, progress)
    lam = tables["lam"]
    out.table("lambda_phys", tables["lambda"], f"Table 3 analogue: λ_phys sensitivity, residual 4x128, seeds "
              f"{o['seeds']} (mean ± sd); adopted λ_phys = {lam:g} (lowest mean validation RMSE)")
    out.table("architecture", tables["architecture"], f"Table 2 analogue: residual architecture at λ_phys = "
              f"{lam:g}, seed {o['seeds'][0]} (RMSE/MAE pooled over the held-out cases)")
    out.table("holdout", tables["holdout"], "Table 4 analogue: RMSE [µm] on the held-out voltage–frequency "
              "cases (this study, then seed 003's Table 4)")
    out.table("data_efficiency", tables["efficiency"], "Data efficiency: held-out RMSE [µm] against the "
              "fraction of training windows kept (seeded random subset)")
    out.figure("rate_effect", rate_figure(truth, fitted, o),
               "What the nominal lacks: true and DE-identified sweeps to 100 V at 0.5 and 50 Hz (left); the "
               "true frequency-dependent Bouc–Wen gain and attenuation against the identified constants (right)")
    out.figure("holdout_loops", holdout_figure(tables["runs"], o),
               "Held-out cases (cf. seed 003 Figs. 17-20): loops (top) and tracking error x̂ − x (bottom)")
    out.figure("data_efficiency", efficiency_figure(tables["efficiency"]),
               "Held-out RMSE against the fraction of training windows (cf. seed 003 Fig. 16)")
    summary.update(run_summary(tables, runs))
    return summary


def _sweep_options(o: dict) -> dict:
    return {k: o[k] for k in ("cycles", "samples_per_cycle", "max_interval_s", "noise_um")} | {
        "substeps": o["truth_substeps"]}


def _identification(o: dict, data: RecordSet, train_cases, seed: int, progress: bool):
    """Seed 003 Sec. 4.3 twice: on sweeps of the nominal itself (a known answer), then on the training sweeps
    with the rate dependences. Returns both ``IdentificationResult`` and their summary."""
    ido = {**o["identify"], "substeps": o["train"]["substeps"], "seed": seed}
    use = o["identify"]
    cases = [c for c in train_cases if c[0] in use["amplitudes_v"] and c[1] in use["frequencies_hz"]]
    plain = sweep_records(true_actuator(0.0, 0.0, o["rate_corner_hz"], o["sigma_s_per_um"]), cases,
                          seed=seed + 1, **_sweep_options(o))
    check = identify_nominal(plain, o["sigma_s_per_um"], ido, progress)
    fitted = identify_nominal(RecordSet([data[case_name(c)] for c in cases]), o["sigma_s_per_um"], ido, progress)
    summary = {"identification": {"check": id_summary(check), "fitted": id_summary(fitted),
                                  "records": [case_name(c) for c in cases]}}
    return check, fitted, summary


def _training_tables(runs: TrainingRuns, o: dict, progress: bool) -> dict:
    """The training multiruns and their tables: Table 3 first (λ_phys × seeds; it chooses λ_phys), then Table 2
    (architectures), the data-efficiency curve of the hybrid and of the baselines (their full-data runs are
    Table 4's) and the in-the-loop hybrid."""
    s0, fraction_list = o["seeds"][0], sorted(float(f) for f in o["fractions"])
    fractions = sweep_values(fraction_list)
    in_the_loop = bool(o.get("in_the_loop", True))
    with progress_bar(total=4 + in_the_loop, desc="seed003 training sweeps", enabled=progress) as bar:
        runs.launch_hybrid("lambda_phys", "lambda_phys", hidden=["4x128"], lambdas=o["lambdas"], seeds=o["seeds"])
        bar.update()
        lam_table, lam = lambda_table(runs, o)
        runs.launch_hybrid("architectures", "architectures", hidden=o["architectures"], lambdas=[lam], seeds=[s0])
        bar.update()
        runs.launch_hybrid("data_fraction_hybrid", "data_fraction", hidden=["4x128"], lambdas=[lam], seeds=[s0],
                           fractions=fraction_list)
        bar.update()
        runs.launch("data_fraction_baselines", "mlp,lstm,std_pinn", "sweep=data_fraction", f"seed={int(s0)}",
                    f"datamodule.train_fraction={fractions}")
        bar.update()
        if in_the_loop:
            runs.launch("in_the_loop", "hybrid_dynamics", f"seed={int(s0)}")
            bar.update()
    hold, hold_runs = holdout_table(runs, o, lam)
    return {"lam": lam, "lambda": lam_table, "architecture": architecture_table(runs, o, lam), "holdout": hold,
            "runs": hold_runs, "efficiency": efficiency_table(runs, o, lam)}
