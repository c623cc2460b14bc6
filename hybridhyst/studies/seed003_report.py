"""Seed 003's Tables 2–4, the data-efficiency curve and their figures, from the study's training runs
(``TrainingRuns.get``: each run's held-out predictions and what ``hybridhyst.report.collect`` reads of it)."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
import torch

from ..analysis import mae, rmse
from ..nets import build_net
from .seed003_actuator import case_name, case_pairs

__all__ = ["MODELS", "architecture_table", "efficiency_figure", "efficiency_table", "holdout_figure", "holdout_table",
           "lambda_table", "run_summary"]

# Seed 003 Table 4 (RMSE in µm on the hold-out voltage-frequency cases), quoted as reference.
PAPER_TABLE4 = {"physics": [8.531, 5.259, 7.832, 15.747], "mlp": [2.262, 3.283, 6.078, 11.325],
                "std_pinn": [2.317, 3.187, 4.063, 15.645], "lstm": [2.469, 3.550, 4.470, 5.183],
                "hybrid": [2.161, 3.029, 3.920, 14.629]}
PAPER_CASES = [(20.0, 2.0), (40.0, 1.0), (80.0, 0.2), (100.0, 20.0)]  # (V, Hz) of Figs. 17-20 / Table 4
# Seed 003 Table 2 (architecture: trainable parameters, RMSE µm, MAE µm) and Table 3 (λ_phys: RMSE µm).
PAPER_TABLE2 = {"2x32": (1217, 10.229, 8.494), "3x64": (8641, 9.954, 8.352), "4x64": (12801, 10.253, 8.778),
                "4x128": (50177, 9.906, 8.259), "6x128": (83201, 10.324, 8.425), "8x128": (116225, 10.405, 8.474)}
PAPER_TABLE3 = {0.0: 10.0502, 1e-4: 10.0510, 1e-3: 10.0415, 1e-2: 10.0050, 1e-1: 11.5178, 1.0: 12.5342}
MODELS = {"physics": "physics (DE nominal)", "mlp": "MLP", "lstm": "LSTM", "std_pinn": "Std-PINN",
          "hybrid": "Hybrid-PINN", "hybrid_dynamics": "Hybrid in the loop"}




def _label(a: float, f: float) -> str:
    return f"{a:g} V, {f:g} Hz"


def _mean_sd(values) -> str:
    v = np.asarray(values, dtype=float)
    if not np.isfinite(v).any():
        return "—"
    return f"{np.nanmean(v):.4g} ± {np.nanstd(v, ddof=1) if len(v) > 1 else 0.0:.2g}"


def _case_rmse(result: dict, key: str = "y_pred") -> dict[str, float]:
    """RMSE [µm] per held-out record of a run (``key``: the prediction or the nominal's ``y_nominal``)."""
    return {p["record"]: rmse(p[key], p["y"]) for p in result["test"]}


def _pooled(result: dict, key: str = "y_pred") -> tuple[float, float]:
    pred = np.concatenate([p[key] for p in result["test"]])
    y = np.concatenate([p["y"] for p in result["test"]])
    return rmse(pred, y), mae(pred, y)


NET_INPUTS = 5  # the residual network's inputs: normalised (t, u, u̇) and the two conditions (amplitude, frequency)


def _inference_ms(hidden, repeats: int = 200) -> float:
    """Mean forward time [ms] of a tanh MLP of widths ``hidden`` for one sample (seed 003's single-sample
    inference), timed on a network of the residual's shape (the time does not depend on the weights)."""
    net = build_net("mlp", NET_INPUTS, 1, list(hidden), "tanh").double()
    feats = torch.zeros(1, 1, NET_INPUTS, dtype=torch.float64)
    with torch.no_grad():
        net(feats)
        start = time.perf_counter()
        for _ in range(repeats):
            net(feats)
    return (time.perf_counter() - start) / repeats * 1e3


def lambda_table(runs, o: dict) -> tuple[pd.DataFrame, float]:
    """Table 3 analogue (λ_phys × seeds, 4x128) and the adopted λ_phys (``adopted_lambda``: ``best_val``, the
    lowest mean validation RMSE, or a value)."""
    rows, val_means = [], {}
    for lam in [float(x) for x in o["lambdas"]]:
        res = [runs.get("hybrid", "4x128", lam, s) for s in o["seeds"]]
        pooled = [_pooled(r) for r in res]
        val_means[lam] = float(np.mean([r["val"]["rmse"] for r in res]))
        rows.append({"λ_phys": lam, "RMSE µm": _mean_sd([p[0] for p in pooled]),
                     "MAE µm": _mean_sd([p[1] for p in pooled]),
                     "val RMSE µm": _mean_sd([r["val"]["rmse"] for r in res]),
                     "physics loss": _mean_sd([r["phys_loss"] for r in res]),
                     "time ms": _mean_sd([_inference_ms(r["hidden"]) for r in res]),
                     "train s": float(np.mean([r["train_s"] for r in res])),
                     "paper RMSE µm": PAPER_TABLE3.get(lam, float("nan"))})
    adopted = o["adopted_lambda"]
    lam = min(val_means, key=val_means.get) if adopted == "best_val" else float(adopted)
    return pd.DataFrame(rows), lam


def architecture_table(runs, o: dict, lam: float) -> pd.DataFrame:
    """Table 2 analogue: the residual architectures at the adopted λ_phys, first seed."""
    rows = []
    for hidden in o["architectures"]:
        r = runs.get("hybrid", hidden, lam, o["seeds"][0])
        paper = PAPER_TABLE2.get(hidden, (float("nan"),) * 3)
        rows.append({"architecture": hidden, "parameters": r["n_parameters"], "RMSE µm": _pooled(r)[0],
                     "MAE µm": _pooled(r)[1], "val RMSE µm": r["val"]["rmse"], "training s": r["train_s"],
                     "inference ms": _inference_ms(r["hidden"]), "paper parameters": paper[0],
                     "paper RMSE µm": paper[1], "paper MAE µm": paper[2]})
    return pd.DataFrame(rows)


def holdout_table(runs, o: dict, lam: float) -> tuple[pd.DataFrame, dict]:
    """Table 4 analogue: RMSE per held-out case of every model (this study, then seed 003's), and the runs."""
    s = o["seeds"][0]
    hold = {"hybrid": runs.get("hybrid", "4x128", lam, s)}
    kinds = ("mlp", "lstm", "std_pinn") + (("hybrid_dynamics",) if o.get("in_the_loop", True) else ())
    hold.update({k: runs.get(k, None, None, s) for k in kinds})
    cases = case_pairs(o["test_cases"])
    rows = []
    for kind in (k for k in MODELS if k in hold or k == "physics"):
        r, key = (hold["hybrid"], "y_nominal") if kind == "physics" else (hold[kind], "y_pred")
        per = _case_rmse(r, key)
        rows.append({"model": MODELS[kind], "source": "this study",
                     **{_label(*c): per[case_name(c)] for c in cases}, "pooled": _pooled(r, key)[0]})
    for kind in PAPER_TABLE4:
        paper = dict(zip(PAPER_CASES, PAPER_TABLE4[kind]))
        rows.append({"model": MODELS[kind], "source": "seed 003 Table 4",
                     **{_label(*c): paper.get(c, float("nan")) for c in cases}, "pooled": float("nan")})
    return pd.DataFrame(rows), hold


def efficiency_table(runs, o: dict, lam: float) -> pd.DataFrame:
    """Held-out RMSE of every model against the fraction of training windows kept (first seed)."""
    s = o["seeds"][0]
    rows = []
    for frac in sorted(float(f) for f in o["fractions"]):
        hybrid = runs.get("hybrid", "4x128", lam, s, frac)
        row = {"fraction": frac, "windows": hybrid["n_windows"], MODELS["physics"]: _pooled(hybrid, "y_nominal")[0],
               MODELS["hybrid"]: _pooled(hybrid)[0]}
        row.update({MODELS[k]: _pooled(runs.get(k, None, None, s, frac))[0] for k in ("mlp", "lstm", "std_pinn")})
        rows.append(row)
    return pd.DataFrame(rows)


def run_summary(tables, runs) -> dict:
    """The headline numbers of the training tables for summary.json."""
    arch_table, lam_table, eff_table = tables["architecture"], tables["lambda"], tables["efficiency"]
    ours = tables["holdout"][tables["holdout"]["source"] == "this study"].set_index("model")
    physics, hybrid = float(ours.loc[MODELS["physics"], "pooled"]), float(ours.loc[MODELS["hybrid"], "pooled"])
    return {"adopted_lambda_phys": tables["lam"],
            "holdout_pooled_rmse_um": {m: float(v) for m, v in ours["pooled"].items()},
            "holdout_rmse_um": {m: {c: float(v) for c, v in row.items() if c not in ("source", "pooled")}
                                for m, row in ours.iterrows()},
            "hybrid_vs_physics_improvement_pct": 100 * (1 - hybrid / physics),
            "in_the_loop_vs_parallel_pooled": (float(ours.loc[MODELS["hybrid_dynamics"], "pooled"]) / hybrid
                                               if MODELS["hybrid_dynamics"] in ours.index else None),
            "architecture_rmse_um": dict(zip(arch_table["architecture"], map(float, arch_table["RMSE µm"]))),
            "lambda_rmse_um": dict(zip(map(str, lam_table["λ_phys"]), lam_table["RMSE µm"])),
            "data_efficiency_rmse_um": {c: [float(v) for v in eff_table[c]] for c in eff_table.columns},
            "training_runs": len(runs.used),
            "training_s": float(sum(r["train_s"] for r in runs.used.values()))}



# -- figures ---------------------------------------------------------------------------------------------
def holdout_figure(hold: dict, o: dict):
    """Held-out cases (cf. seed 003 Figs. 17-20): loops (top) and tracking error (bottom)."""
    import matplotlib.pyplot as plt

    cases = case_pairs(o["test_cases"])
    fig, axes = plt.subplots(2, len(cases), figsize=(2.6 * len(cases), 4.6), squeeze=False)
    styles = {"physics": ("tab:red", "--"), "hybrid": ("tab:blue", "-"), "hybrid_dynamics": ("tab:purple", "-"),
              "lstm": ("tab:green", "-"), "mlp": ("tab:orange", "-")}
    for j, case in enumerate(cases):
        for kind, (color, ls) in styles.items():
            if kind not in hold and kind != "physics":
                continue
            r, key = (hold["hybrid"], "y_nominal") if kind == "physics" else (hold[kind], "y_pred")
            p = next(p for p in r["test"] if p["record"] == case_name(case))
            if kind == "physics":
                axes[0, j].plot(p["x"], p["y"], color="0.6", lw=2, label="measured")
            if kind in ("physics", "hybrid", "hybrid_dynamics"):
                axes[0, j].plot(p["x"], p[key], color=color, ls=ls, lw=1, label=MODELS[kind])
            axes[1, j].plot(p["t"] * case[1], p[key] - p["y"], color=color, ls=ls, lw=0.8, label=MODELS[kind])
        axes[0, j].set_title(_label(*case), fontsize=9)
        axes[0, j].set_xlabel("u [V]")
        axes[1, j].set(xlabel="t · f [cycles]")
    axes[0, 0].set_ylabel("x [µm]")
    axes[1, 0].set_ylabel("x̂ − x [µm]")
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def efficiency_figure(table: pd.DataFrame):
    """Held-out RMSE against the fraction of training windows (cf. seed 003 Fig. 16)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import ScalarFormatter

    fig, ax = plt.subplots(figsize=(5.2, 3.6))
    for kind in ("hybrid", "mlp", "lstm", "std_pinn"):
        ax.semilogy(100 * table["fraction"], table[MODELS[kind]], "o-", label=MODELS[kind])
    ax.semilogy(100 * table["fraction"], table[MODELS["physics"]], "k--", label=MODELS["physics"])
    ax.set(xlabel="training data [%]", ylabel="held-out RMSE [µm]")
    ax.yaxis.set_major_formatter(ScalarFormatter())
    ax.yaxis.set_minor_formatter(ScalarFormatter())
    ax.tick_params(axis="y", which="minor", labelsize=7)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
