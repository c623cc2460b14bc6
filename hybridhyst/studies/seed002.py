"""Seed 002 as a study: loop metrics across underpressure, their exponential trends, Bouc–Wen(-p) fits.

Seed 002 (Rodak & Zalewski 2020, ABS grains, quasi-static ±5° loops at 0–0.05 MPa) characterises each loop
by the equivalent loading / unloading / average stiffness, the torque at the amplitude and the dissipated
energy (``analysis.loop_metrics``), fits exponential rise-to-maximum trends of them against underpressure
(Figs. 9–11) and fits a Bouc–Wen model at each pressure by Monte Carlo sampling (Table 2), then the B–W–p
model with parameters as exponential functions of p (eqs. 5–13). The measured loops are not published, so:

* reference data: seed 002 Table 1 (its metrics, quoted below) — shown beside, never used as a model check
  (Table 2's parameters diverge: γ + β < 0 in every row, docs/units.md);
* hybridhyst's loops: seed 001's modified Bouc–Wen law for the ABS mixture (``load_vpptd``) driven at
  seed 002's amplitude and cycle period;
* fits to those loops at each pressure: Monte Carlo (seed 002) next to ``identify``; then the B–W–p model
  (``compositions.bouc_wen_p``) from the per-pressure path, refined jointly on all pressures.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd
import torch

from ..analysis import TrendFit, fit_trend, r2, relative_error, rmse
from ..analysis import loop_metrics as measure_loop
from ..identify import Box, RecordsProblem, SearchSpace, identify, monte_carlo, output_jacobian
from ..identify.refine import levenberg_marquardt
from ..physics.compositions.seed002 import TABLE2_FITS, bouc_wen_p
from ..physics.effects import EFFECTS
from ..physics.effects.bouc_wen_p import BoucWenNormalised
from ..physics.models import Constitutive
from ..progress import progress as progress_bar
from ..report.figures import draw_loops
from ..simulate import simulate
from ..synth import PRESSURES as TABLE1_GRID
from ..synth import load_vpptd
from . import resolve_options
from .output import StudyOutput

__all__ = ["loop_metrics"]

REQUIRED = ("mixture", "pressures", "amplitude_deg", "frequency_hz", "cycles", "samples_per_cycle", "noise_sd",
            "loading_window", "unloading_window", "bounds", "monte_carlo", "identify", "continuation_lm_steps",
            "joint_lm_steps")
FREE = ("omega", "xi", "alpha", "gamma", "beta")  # A = 1 and n = 1.48 fixed in the per-pressure fits
METRICS = {"loading_stiffness": "k_eq_l [Nm/deg]", "unloading_stiffness": "k_eq_u [Nm/deg]",
           "average_stiffness": "k_eq_a [Nm/deg]", "peak_response": "M_max [Nm]",
           "dissipated_energy": "E_d [Nm·deg]"}
# Seed 002, Table 1: measured metrics of the ABS-grain damper at p = 0 … 0.05 MPa (energy printed "Nm/deg").
TABLE1_P = (0.0, 0.005, 0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.045, 0.05)
TABLE1 = {
    "loading_stiffness": (0.72, 1.59, 2.03, 2.69, 3.20, 3.27, 3.55, 3.69, 3.79, 3.93, 3.83),
    "unloading_stiffness": (2.67, 5.92, 7.13, 9.98, 11.47, 11.78, 12.25, 12.74, 12.72, 13.06, 12.63),
    "average_stiffness": (1.69, 3.75, 4.58, 6.34, 7.33, 7.53, 7.90, 8.21, 8.26, 8.50, 8.23),
    "peak_response": (7.00, 10.14, 11.50, 14.96, 17.60, 17.56, 19.18, 19.64, 19.98, 20.58, 20.60),
    "dissipated_energy": (18.13, 32.28, 41.55, 44.38, 45.86, 50.99, 50.02, 52.85, 52.64, 52.41, 54.06),
}
# Seed 002, Table 2: Monte Carlo Bouc–Wen fits per pressure (γ, β, R², error [%]; n = 1.48 in every row).
TABLE2 = {"gamma": (24.01, 12.88, 11.00, 10.98, 9.00, 9.05, 9.04, 10.43, 10.82, 10.33, 10.8),
          "beta": (-44.00, -21.25, -16.00, -13.92, -14.00, -13.64, -14.78, -15.07, -15.07, -13.62, -15.00),
          "r2": (0.857, 0.902, 0.931, 0.950, 0.962, 0.970, 0.976, 0.979, 0.981, 0.983, 0.984),
          "error_pct": (19.2, 18.1, 14.7, 13.5, 13.3, 16.1, 15.6, 13.5, 13.4, 12.9, 12.2)}


def _options(options: dict) -> dict:
    opts = resolve_options(options, REQUIRED, "vpptd_loop_metrics")
    p = [float(v) for v in opts["pressures"]]
    if len(p) < 4 or len(set(p)) != len(p) or any(not 0.0 <= v <= 0.1 for v in p):
        raise ValueError(f"seed002 study: pressures {p} must be at least 4 distinct underpressures in [0, 0.1] MPa "
                         "(an exponential trend has 3 coefficients)")
    if max(opts["unloading_window"] + opts["loading_window"]) > float(opts["amplitude_deg"]):
        raise ValueError("seed002 study: the metric windows must lie inside the amplitude "
                         f"({opts['amplitude_deg']} deg); seed 002 uses <1, 3> and <5, 3.5> deg at ±5°")
    if set(opts["bounds"]) != set(FREE):
        raise ValueError(f"seed002 study: bounds must give [low, high] for each of {list(FREE)}")
    if int(opts["cycles"]) < 2:
        raise ValueError("seed002 study: cycles must be >= 2 (the last, stabilised cycle is measured)")
    return {**opts, "pressures": sorted(p)}


def _loops(opts: dict, noise_sd: float):
    return load_vpptd(mixtures=opts["mixture"], pressures=opts["pressures"], cycles=int(opts["cycles"]),
                      samples_per_cycle=int(opts["samples_per_cycle"]), noise_sd=noise_sd, seed=int(opts["seed"]),
                      frequency_hz=float(opts["frequency_hz"]), amplitude_deg=float(opts["amplitude_deg"]),
                      substeps=1)


def _last_cycle(a, opts: dict) -> np.ndarray:
    return np.asarray(a)[-(int(opts["samples_per_cycle"]) + 1):]


def _metrics(source: str, x_rows, y_rows, opts: dict) -> pd.DataFrame:
    """Seed 002's metrics of the last cycle of each loop, one row per pressure."""
    rows = []
    for p, x, y in zip(opts["pressures"], x_rows, y_rows):
        m = measure_loop(_last_cycle(x, opts), _last_cycle(y, opts), tuple(opts["loading_window"]),
                         tuple(opts["unloading_window"]))
        rows.append({"source": source, "p [MPa]": p, **{k: getattr(m, k) for k in METRICS}})
    return pd.DataFrame(rows)


def _table1() -> pd.DataFrame:
    return pd.DataFrame({"source": "seed 002 Table 1", "p [MPa]": TABLE1_P, **TABLE1})


def _bouc_wen(values: dict) -> Constitutive:
    """Seed 002's eqs. (1)–(2) with constant parameters, A = 1 and n = 1.48 fixed (the B–W–p structure)."""
    return Constitutive({"inertia": EFFECTS["inertia"](m=1.0, fixed=["m"]),
                         "hysteresis": BoucWenNormalised(**values, A=1.0, n=1.48, fixed=["A", "n"])},
                        units={"x": "deg", "F": "Nm", "t": "s"}, name="bouc_wen_seed002").double()


def _quality(model, records) -> list[dict]:
    """R², relative error [%] and RMSE [Nm] of ``model``'s response on each record."""
    with torch.no_grad():
        ys = [y[:, 0].numpy() for y in simulate(model, records, backend="fast")]
    return [{"R2": r2(y, r.y), "error [%]": 100 * relative_error(y, r.y), "RMSE [Nm]": rmse(y, r.y)}
            for y, r in zip(ys, records)]


def _per_pressure(opts: dict, records, progress: bool):
    """Monte Carlo (seed 002: uniform in the box; and log-uniform where hybridhyst's box is on a log scale) and
    ``identify`` at each pressure; returns the table and identify's values at each pressure."""
    bounds = {f"hysteresis.{k}": tuple(float(b) for b in v) for k, v in opts["bounds"].items()}
    start = {k: 0.5 * (lo + hi) for k, (lo, hi) in opts["bounds"].items()}
    rows, fits = [], []
    for i, rec in enumerate(progress_bar(records, "per-pressure fits", enabled=progress)):
        space = SearchSpace(_bouc_wen(start), bounds)
        problem = RecordsProblem(space, [rec])
        runs = []
        for name, box in (("Monte Carlo (uniform)", Box(space.lower, space.upper)), ("Monte Carlo (log box)", space)):
            t0 = time.perf_counter()
            mc = monte_carlo(problem.cost, box, samples=int(opts["monte_carlo"]["samples"]), progress=False,
                             batch=int(opts["monte_carlo"]["batch"]), seed=int(opts["seed"]) + i)
            runs.append((name, dict(zip(space.names, mc.x.tolist())), mc.evaluations, time.perf_counter() - t0))
        fit = identify(_bouc_wen(start), rec, bounds=bounds, fisher=False, progress=False, seed=int(opts["seed"]),
                       **opts["identify"])
        runs.append(("identify", fit.x, fit.evaluations, fit.wall_s))
        for name, x, evals, wall in runs:
            values = {k.split(".")[1]: v for k, v in x.items()}
            rows.append({"p [MPa]": rec.conditions["pressure_mpa"], "method": name,
                         **_quality(_bouc_wen(values), [rec])[0], "evaluations": evals, "wall [s]": wall, **values})
        fits.append({k.split(".")[1]: v for k, v in fit.x.items()})
    return pd.DataFrame(rows), fits


def _continuation(opts: dict, records, first: dict, progress: bool) -> pd.DataFrame:
    """Per-pressure fits along the pressures, each a Levenberg–Marquardt refinement (in the search box) of its
    neighbour's fit, so the parameters follow one smooth path instead of jumping between equivalent optima."""
    bounds = {f"hysteresis.{k}": tuple(float(b) for b in v) for k, v in opts["bounds"].items()}
    rows, values = [], first
    for i, rec in enumerate(progress_bar(records, "continuation", enabled=progress)):
        if i:
            space = SearchSpace(_bouc_wen(values), bounds)
            lm = levenberg_marquardt(RecordsProblem(space, [rec]).residuals, space, space.initial()[None],
                                     iters=int(opts["continuation_lm_steps"]), progress=False)
            values = {k.split(".")[1]: v for k, v in zip(space.names, lm.x.tolist())}
        rows.append({"p [MPa]": rec.conditions["pressure_mpa"], **values,
                     **_quality(_bouc_wen(values), [rec])[0]})
    return pd.DataFrame(rows)


def _path_sensitivities(opts: dict, records, path: pd.DataFrame) -> list[np.ndarray]:
    """At each point of the path, the loop's output Jacobian w.r.t. ``FREE`` (``(samples, 5)``, over √samples):
    J (θ − θ̂) is, to first order, the change of that pressure's response when its parameters move from θ̂ to θ."""
    bounds = {f"hysteresis.{k}": tuple(float(b) for b in v) for k, v in opts["bounds"].items()}
    out = []
    for i, rec in enumerate(records):
        space = SearchSpace(_bouc_wen({k: float(path[k].iloc[i]) for k in FREE}), bounds)
        J = output_jacobian(RecordsProblem(space, [rec]).predict, space.initial(), method="fd")
        names = [n.split(".")[1] for n in space.names]
        out.append(J[:, [names.index(k) for k in FREE]].numpy() / math.sqrt(J.shape[0]))
    return out


def _trend_start(path: pd.DataFrame, sensitivities: list[np.ndarray]) -> tuple[dict, pd.DataFrame]:
    """Seed 002's function kind for each parameter (eqs. 7–12) fitted to the path; A = 1 (a = 0).

    Each kind is first fitted to its parameter's path alone (``fit_trend``), then all of them together by least
    squares on the path's responses to first order, Σ_p |J_p (θ(p) − θ̂_p)|² (``_path_sensitivities``). γ and β
    are large and nearly cancel along the path (γ + β ≈ 3–8 against γ ≈ 60–980): fitted one by one, their
    trends miss the path by tens each, and where the misses do not cancel the start's γ + β or γ − β changes
    sign — a law that diverges on the loop (z grows without bound), from which the joint refinement cannot
    move. Weighted by the loops' sensitivities, the well-determined combinations are kept and the trends trade
    only along directions the loops hardly see.
    """
    from scipy.optimize import least_squares

    p = path["p [MPa]"].to_numpy()
    kinds = [TABLE2_FITS[name][0] for name in FREE]
    alone = [fit_trend(p, path[name].to_numpy(), kind) for name, kind in zip(FREE, kinds)]
    target = path[list(FREE)].to_numpy()

    def trends(c: np.ndarray) -> np.ndarray:  # (pressures, parameters)
        return np.stack([TrendFit(kind, *c[3 * j:3 * j + 3], r2=math.nan)(p) for j, kind in enumerate(kinds)], 1)

    def residuals(c: np.ndarray) -> np.ndarray:
        return np.concatenate([J @ d for J, d in zip(sensitivities, trends(c) - target)])

    start = np.array([v for t in alone for v in (t.y0, t.a, t.b)])
    c = least_squares(residuals, start, x_scale="jac").x
    fits, rows = {"A": ("exp_rise", 1.0, 0.0, 1.0)}, []
    for j, (name, kind) in enumerate(zip(FREE, kinds)):
        y0, a, b = (float(v) for v in c[3 * j:3 * j + 3])
        fits[name] = (kind, y0, a, b)
        rows.append({"parameter": name, "kind": kind, "y0": y0, "a": a, "b [1/MPa]": b,
                     "R2 (path)": r2(trends(c)[:, j], target[:, j]), "R2 (path), fitted alone": alone[j].r2})
    return fits, pd.DataFrame(rows)


def _joint(opts: dict, records, fits: dict, progress: bool):
    """B–W–p (19 coordinates) from the trend start, refined on all pressures by batched Levenberg–Marquardt."""
    model = bouc_wen_p(fits).double()
    with torch.no_grad():
        diverged = [r.conditions["pressure_mpa"] for r, y in zip(records, simulate(model, records, backend="fast"))
                    if not bool(torch.isfinite(y).all())]
    if diverged:
        raise ValueError(f"seed002 study: the B–W–p start (trends fitted to the path) diverges at p = {diverged} "
                         "MPa; Levenberg–Marquardt cannot refine from a non-finite cost")
    problem = RecordsProblem(SearchSpace(model), list(records))
    t0 = time.perf_counter()
    lm = levenberg_marquardt(problem.residuals, problem.space, problem.space.initial()[None],
                             iters=int(opts["joint_lm_steps"]), progress=progress)
    problem.space.to_model(lm.x)
    return model, {"evaluations": lm.evaluations * len(records), "wall_s": time.perf_counter() - t0,
                   "coordinates": problem.space.dim}


def _table2_check(opts: dict, x: np.ndarray, t: np.ndarray) -> pd.DataFrame:
    """Table 2's γ + β, and the angle of the first non-finite torque of the default B–W–p (fits to Table 2)."""
    w = 2 * math.pi * float(opts["frequency_hz"])
    inputs = np.stack([x, np.gradient(x, t), -(w**2) * x], axis=-1)
    with torch.no_grad():
        y = simulate(bouc_wen_p().double(), torch.as_tensor(np.repeat(inputs[None], len(TABLE1_P), 0)),
                     t=torch.as_tensor(t), conditions={"pressure_mpa": np.asarray(TABLE1_P)}, backend="fast",
                     substeps=8)[..., 0].numpy()
    bad = ~np.isfinite(y)
    return pd.DataFrame({"p [MPa]": TABLE1_P, "γ (Table 2)": TABLE2["gamma"], "β (Table 2)": TABLE2["beta"],
                         "γ + β": np.add(TABLE2["gamma"], TABLE2["beta"]),
                         "B–W–p (Table 2 fits): M non-finite from φ [deg]":
                             [float(x[row.argmax()]) if row.any() else math.nan for row in bad]})


def _trends(frames: list[pd.DataFrame]) -> pd.DataFrame:
    rows = []
    for frame in frames:
        for key, label in METRICS.items():
            fit = fit_trend(frame["p [MPa]"].to_numpy(), frame[key].to_numpy(), "exp_rise")
            rows.append({"source": frame["source"].iloc[0], "metric": label, "y0": fit.y0, "a": fit.a,
                         "b [1/MPa]": fit.b, "initial slope a·b": fit.a * fit.b, "R2": fit.r2})
    return pd.DataFrame(rows)


def loop_metrics(options: dict, out: StudyOutput) -> dict:
    """Run the study (see the module docstring); returns the summary written to ``summary.json``."""
    opts = _options(options)
    progress = bool(opts["progress"])
    clean, noisy = _loops(opts, 0.0), _loops(opts, float(opts["noise_sd"]))
    ref = _metrics(f"seed 001 {opts['mixture']} model", [r.x for r in clean], [r.y for r in clean], opts)
    per, fits = _per_pressure(opts, noisy.records, progress)
    path = _continuation(opts, noisy.records, fits[0], progress)
    start, functions = _trend_start(path, _path_sensitivities(opts, noisy.records, path))
    joint, cost = _joint(opts, noisy.records, start, progress)
    with torch.no_grad():
        bwp_y = [y[:, 0].numpy() for y in simulate(joint, clean.records, backend="fast")]
    bwp = _metrics("B–W–p fit", [r.x for r in clean], bwp_y, opts)
    quality = pd.DataFrame([{"p [MPa]": r.conditions["pressure_mpa"], **q}
                            for r, q in zip(noisy.records, _quality(joint, noisy.records))])
    return _report(out, opts, dict(table1=_table1(), ref=ref, bwp=bwp, per=per, path=path, functions=functions,
                                   quality=quality, cost=cost, noisy=noisy, joint=joint,
                                   check=_table2_check(opts, clean.records[0].x, clean.records[0].t)))


def _paper_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """Table 2's R² and error [%] (seed 002's Monte Carlo fits to its measured loops) beside each row."""
    paper = pd.DataFrame({"p [MPa]": TABLE1_P, "R2 (seed 002)": TABLE2["r2"], "error [%] (seed 002)":
                          TABLE2["error_pct"]})
    return frame.merge(paper, on="p [MPa]", how="left")


def _functions(model) -> pd.DataFrame:
    rows = []
    for k, fn in model.effects["hysteresis"].params.items():
        coef = {"y0": fn.y0, "a": fn.a, "b [1/MPa]": fn.b} if hasattr(fn, "b") else {"y0": fn.value}
        rows.append({"parameter": k, "kind": TABLE2_FITS[k][0] if k in TABLE2_FITS else "constant",
                     **{c: float(v.detach()) for c, v in coef.items()}})
    return pd.DataFrame(rows)


def _metrics_figure(frames: list[pd.DataFrame]):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(11, 6.2))
    p = np.linspace(0, max(f["p [MPa]"].max() for f in frames), 100)
    for ax, (key, label) in zip(axes.flat, METRICS.items()):
        for frame, style in zip(frames, ("ks", "o", "^")):
            line, = ax.plot(frame["p [MPa]"], frame[key], style, ms=4, label=frame["source"].iloc[0])
            ax.plot(p, fit_trend(frame["p [MPa]"].to_numpy(), frame[key].to_numpy())(p), "-", lw=1,
                    color=line.get_color())
        ax.set(xlabel="p [MPa]", title=label)
    axes.flat[-1].axis("off")
    axes.flat[-1].legend(*axes.flat[0].get_legend_handles_labels(), loc="center", title="lines: y0 + a(1 − e^(−b p))")
    fig.tight_layout()
    return fig


def _loops_figure(opts: dict, r: dict):
    """Last cycle at 0.01, 0.02 and 0.05 MPa: the noisy loop, identify per pressure and B–W–p jointly; the
    loading and unloading windows of the metrics shaded (as seed 002 Fig. 13)."""
    wanted = sorted({min(opts["pressures"], key=lambda q: abs(q - v)) for v in (0.01, 0.02, 0.05)})
    ident = r["per"][r["per"]["method"] == "identify"].set_index("p [MPa]")
    n = int(opts["samples_per_cycle"]) + 1
    records, per, joint = [], [], []
    for p in wanted:
        rec = r["noisy"].records[opts["pressures"].index(p)]
        with torch.no_grad():
            per.append(simulate(_bouc_wen(ident.loc[p, list(FREE)].to_dict()), [rec], backend="fast")[0][-n:, 0])
            joint.append(simulate(r["joint"], [rec], backend="fast")[0][-n:, 0])
        records.append(rec.slice(-n))
    fig = draw_loops(records, {"Bouc–Wen at this p (identify)": per, "B–W–p (all p jointly)": joint},
                     measured=f"seed 001 {opts['mixture']} loop + noise",
                     styles={"B–W–p (all p jointly)": {"ls": "--"}})
    for ax in fig.axes[:len(records)]:
        for lo, hi in (opts["loading_window"], opts["unloading_window"]):
            ax.axvspan(lo, hi, color="y", alpha=0.15)
    return fig


def _report(out: StudyOutput, opts: dict, r: dict) -> dict:
    lo, hi = min(TABLE1_GRID), max(TABLE1_GRID)
    outside = [p for p in opts["pressures"] if not lo <= p <= hi]
    note = (f" At p = {', '.join(f'{p:g}' for p in outside)} MPa, outside seed 001 Table 1's fitted range {lo:g}–"
            f"{hi:g} MPa, its polynomials are extrapolated." if outside else "")
    out.text(f"Loops: seed 001's modified Bouc–Wen law, mixture {opts['mixture']}, ±{opts['amplitude_deg']:g}° sine "
             f"at {opts['frequency_hz']:g} Hz, {opts['cycles']} cycles × {opts['samples_per_cycle']} samples; "
             f"metrics on the last cycle (noise-free), fits to the loops with {opts['noise_sd']:g} Nm noise.{note}")
    metrics = pd.concat([r["table1"], r["ref"], r["bwp"]], ignore_index=True)
    out.table("metrics", metrics.rename(columns=METRICS), "Loop metrics (seed 002's definitions) against "
              "underpressure: Table 1 (measured, reference), the seed 001 model's loops, the fitted B–W–p model")
    trends = _trends([r["table1"], r["ref"], r["bwp"]])
    out.table("trends", trends, "Exponential rise to maximum y = y0 + a(1 − e^(−b p)) fitted to each metric")
    out.figure("metrics", _metrics_figure([r["table1"], r["ref"], r["bwp"]]),
               "Metrics against underpressure with their rise-to-maximum fits (lines)")
    out.table("table2_check", r["check"], "Seed 002 Table 2 as printed: γ + β < 0 in every row, so z grows "
              "without bound on every loading branch; the composition's defaults (exponential fits to Table 2) "
              "diverge within the first degree of loading")
    out.table("per_pressure", _paper_columns(r["per"]), "Bouc–Wen fitted at each pressure (A = 1, n = 1.48): "
              "Monte Carlo (seed 002's method, uniform in the box) and hybridhyst's identify; error = relative "
              "RMS error sqrt(Σ(M − M̂)²/ΣM²)")
    out.table("path", r["path"], "Continuation: each pressure's fit started from its neighbour's (smooth path)")
    out.table("bwp_functions", _functions(r["joint"]), "B–W–p after the joint refinement (eqs. 7–13 kinds; "
              "started from the trend fits below)")
    out.table("bwp_start", r["functions"], "Start: seed 002's function kinds fitted to the continuation path, "
              "each pressure's misfit weighted by its loop's sensitivity to the parameters (R² against the path "
              "of this fit, and of each kind fitted to its parameter alone)")
    out.table("bwp_quality", _paper_columns(r["quality"]), "B–W–p (one model for all pressures) on the noisy loops")
    out.figure("loops", _loops_figure(opts, r), "Loops at 0.01, 0.02, 0.05 MPa (as seed 002 Fig. 13); shaded: "
               "the stiffness windows")
    per = r["per"].groupby("method")
    return {
        "pressures_mpa": opts["pressures"],
        "metrics": {src: {k: frame[k].tolist() for k in METRICS} for src, frame in metrics.groupby("source")},
        "trend_r2": {f"{row.source} | {row.metric}": row.R2 for row in trends.itertuples()},
        "table2_all_diverge": bool(r["check"].iloc[:, -1].notna().all()),
        "per_pressure": {m: {"mean_R2": g["R2"].mean(), "mean_error_pct": g["error [%]"].mean(),
                             "evaluations": int(g["evaluations"].sum()), "wall_s": g["wall [s]"].sum()}
                         for m, g in per},
        "bwp": {"mean_R2": r["quality"]["R2"].mean(), "min_R2": r["quality"]["R2"].min(),
                "mean_error_pct": r["quality"]["error [%]"].mean(),
                "max_error_pct": r["quality"]["error [%]"].max(), **r["cost"]},
    }
