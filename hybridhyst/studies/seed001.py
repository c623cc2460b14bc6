"""Seed 001 as a study: the modified Bouc–Wen VPPTD model identified from loops, free vibration, forced rig.

For each ABS/NBR mixture: noisy torque–angle loops (±10°, 0.79 Hz) of Table 1's model (``load_vpptd``)
at a few underpressures; ``identify.identify`` fits the modified Bouc–Wen law with every parameter a
polynomial in p (the degrees and the search box are options, the same for every mixture) to all of them
jointly. Raw Bouc–Wen parameters are not identifiable (docs/units.md), so the identified model is
compared with Table 1's through responses: loops at every pressure 0.01 … 0.09 MPa (fitted and held out),
peak torque, the identifiable combinations (``identifiable_combinations``), the rig's free-vibration
frequency (Table 2, by FFT and by turning points) and its forced response at 0.3 Hz under a fast step and
a slow half-sine sweep of underpressure (§5.2, Figs. 10–14; ``forced_response``).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pandas as pd
import torch

from ..analysis import rmse
from ..identify import identify
from ..physics.compositions.seed001 import (
    MIXTURES,
    PARAMETER_PATHS,
    TABLE1,
    TABLE2_HZ,
    modified_bouc_wen,
    parameter_functions,
)
from ..progress import progress as progress_bar
from ..simulate import simulate
from ..synth import PRESSURES as TABLE1_GRID
from ..synth import forced_response, free_vibration_frequencies, identifiable_combinations, load_vpptd
from . import resolve_options
from .output import StudyOutput
from .seed001_figures import MODELS, SAMPLES_PER_CYCLE, SCHEDULES, write_figures

__all__ = ["vpptd_dynamics"]

REQUIRED = ("mixtures", "noise_sd", "fit_pressures", "fit_cycles", "eval_pressures", "identify", "box",
            "sign_free", "free_vibration", "forced")
FORCED_KEYS = ("frequency_hz", "amplitude_deg", "duration_s", "dt", "step_mpa", "ramp_s", "sweep_peak_mpa",
               "steady_cycles")
COMBINATIONS = {"elastic_k": "αk", "hysteretic_k0": "(1−α)kA", "hysteretic_torque": "F_h", "Ms": "M_s", "c": "c"}


def _options(options: dict) -> dict:
    opts = resolve_options(options, REQUIRED, "vpptd_dynamics")
    unknown = [m for m in opts["mixtures"] if m not in MIXTURES]
    if unknown or not opts["mixtures"]:
        raise ValueError(f"seed001 study: mixtures {unknown or '[]'} invalid; choose from {list(MIXTURES)}")
    if set(opts["box"]) != set(PARAMETER_PATHS):
        raise ValueError(f"seed001 study: box must give [[low, high], ...] per power of p for each of "
                         f"{list(PARAMETER_PATHS)}; got {sorted(opts['box'])}")
    if not set(opts["sign_free"]) <= set(PARAMETER_PATHS):
        raise ValueError(f"seed001 study: sign_free {list(opts['sign_free'])} must name parameters of "
                         f"{list(PARAMETER_PATHS)}")
    missing = [k for k in FORCED_KEYS if k not in opts["forced"]]
    if missing or len(opts["forced"]["step_mpa"]) < 2:
        raise ValueError(f"seed001 study: forced needs {list(FORCED_KEYS)} with at least two step_mpa levels; "
                         f"missing {missing}")
    for key in ("fit_pressures", "eval_pressures"):
        if not opts[key] or any(not 0 <= float(p) <= 0.09 for p in opts[key]):
            raise ValueError(f"seed001 study: {key} must be underpressures in Table 1's range 0 … 0.09 MPa")
    return opts


def _start_model(box: dict, sign_free=()):
    """The modified Bouc–Wen law with polynomials of the box's degrees, started at the box centres.

    The parameters named in ``sign_free`` (Table 1's names) are declared real-valued on this model: their
    effect's domain (the viscous c ≥ 0) would otherwise make every search member with a negative value at a
    fitted pressure simulate nothing (``SearchSpace.values``), and Table 1 prints c < 0 for ABS at every p
    (experiments/vpptd_dynamics/README.md, "Readings of the paper"): the identification could not reach the
    law that made the data.
    """
    centres = {k: [0.5 * (float(lo) + float(hi)) for lo, hi in v] for k, v in box.items()}
    model = modified_bouc_wen(coefficients=centres).double()
    for name in sign_free:
        effect, param = PARAMETER_PATHS[name]
        specs = model.effects[effect].param_specs
        reach = max(abs(b) for b in specs[param].bounds)
        specs[param] = replace(specs[param], constraint="real", bounds=(-reach, reach))
    return model


def _bounds(box: dict) -> dict[str, tuple[float, float]]:
    return {f"{'.'.join(PARAMETER_PATHS[k])}.c{i}": (float(lo), float(hi))
            for k, v in box.items() for i, (lo, hi) in enumerate(v)}


def _identify(mixture: str, opts: dict) -> dict:
    """Joint fit of every fitting pressure of one mixture; returns the identified functions and diagnostics."""
    records = load_vpptd(mixtures=[mixture], pressures=list(opts["fit_pressures"]), cycles=int(opts["fit_cycles"]),
                         noise_sd=float(opts["noise_sd"]), seed=opts["seed"])
    res = identify(_start_model(opts["box"], opts["sign_free"]), records, bounds=_bounds(opts["box"]),
                   noise_sd=float(opts["noise_sd"]), seed=opts["seed"], jacobian="fd", progress=opts["progress"],
                   **opts["identify"])
    return {"coefficients": parameter_functions(res.model), "rmse": res.rmse, "per_record": res.per_record,
            "wall_s": res.wall_s, "identifiable": len(res.identifiable), "coordinates": len(res.x)}


def _loops(mixture: str, coefficients: dict, opts: dict) -> dict:
    """Evaluation loops (3 cycles) at every evaluation pressure: data, Table 1 (noise-free) and identified."""
    pressures = list(opts["eval_pressures"])
    data = load_vpptd(mixtures=[mixture], pressures=pressures, noise_sd=float(opts["noise_sd"]), seed=opts["seed"])
    truth = load_vpptd(mixtures=[mixture], pressures=pressures)
    with torch.no_grad():
        fitted = simulate(modified_bouc_wen(coefficients=coefficients).double(), data.records, backend="fast")
    return {"pressures": pressures, "x": [r.x for r in data.records], "data": [r.y for r in data.records],
            "Table 1": [r.y for r in truth.records], "identified": [y[:, 0].double().numpy() for y in fitted]}


def _loop_rows(mixture: str, loops: dict, fit_pressures) -> list[dict]:
    """RMSE and steady-loop (last cycle) peak torque per pressure."""
    rows = []
    last = slice(-SAMPLES_PER_CYCLE - 1, None)
    for i, p in enumerate(loops["pressures"]):
        peak_t1 = float(np.abs(loops["Table 1"][i][last]).max())
        peak_id = float(np.abs(loops["identified"][i][last]).max())
        rows.append({"mixture": mixture, "p [MPa]": p,
                     "role": "fitted" if any(math.isclose(p, q) for q in fit_pressures) else "held out",
                     "RMSE vs data [Nm]": rmse(loops["identified"][i], loops["data"][i]),
                     "RMSE vs Table 1 [Nm]": rmse(loops["identified"][i], loops["Table 1"][i]),
                     "peak torque Table 1 [Nm]": peak_t1, "peak torque identified [Nm]": peak_id,
                     "peak difference [%]": 100 * (peak_id - peak_t1) / peak_t1})
    return rows


def _combination_rows(mixture: str, coefficients: dict, pressures) -> list[dict]:
    t1 = identifiable_combinations(modified_bouc_wen(mixture).double(), pressures)
    fit = identifiable_combinations(modified_bouc_wen(coefficients=coefficients).double(), pressures)
    rows = []
    for i, p in enumerate(pressures):
        row = {"mixture": mixture, "p [MPa]": float(p)}
        for key, label in COMBINATIONS.items():
            row[f"{label} T1"], row[f"{label} id"] = float(t1[key][i]), float(fit[key][i])
        rows.append(row)
    return rows


def _free_vibration(mixture: str, coefficients: dict, opts: dict) -> pd.DataFrame:
    """Free-vibration frequency per pressure: Table 1 and identified rig, FFT and turning points."""
    fv = opts["free_vibration"]
    kw = {"pressures": list(opts["eval_pressures"]), "duration": float(fv["duration_s"]), "dt": float(fv["dt"])}
    frame = pd.DataFrame({"mixture": mixture, "p [MPa]": kw["pressures"]})
    for model, coeffs in zip(MODELS, (None, coefficients)):
        for method, label in (("fft", "FFT"), ("turning_points", "turning points")):
            frame[f"{model} {label} [Hz]"] = free_vibration_frequencies(mixture, method=method, coefficients=coeffs,
                                                                        **kw)[1]
    return frame


def _schedules(forced: dict) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """Time grid, the two underpressure schedules (fast steps; half-sine sweep) and the step times [s]."""
    t = np.arange(int(round(float(forced["duration_s"]) / float(forced["dt"]))) + 1) * float(forced["dt"])
    levels = [float(v) for v in forced["step_mpa"]]
    switch = [float(forced["duration_s"]) * i / len(levels) for i in range(1, len(levels))]
    step = np.full_like(t, levels[0])
    for ts, before, after in zip(switch, levels[:-1], levels[1:]):
        step += (after - before) * np.clip((t - ts) / float(forced["ramp_s"]), 0.0, 1.0)
    sweep = float(forced["sweep_peak_mpa"]) * np.sin(np.pi * t / t[-1])
    return t, np.stack([step, sweep]), switch


def _extrapolated(forced: dict) -> str:
    """A note naming the step levels outside Table 1's fitted range, where both models are extrapolated."""
    lo, hi = min(TABLE1_GRID), max(TABLE1_GRID)
    outside = [float(v) for v in forced["step_mpa"] if not lo <= float(v) <= hi]
    return (f" (p = {', '.join(f'{p:g}' for p in outside)} MPa lies outside Table 1's fitted range {lo:g}–{hi:g} MPa: "
            "both models are extrapolated there, as in the sweep's first and last cycles)" if outside else "")


def _amplitude(y: np.ndarray, t: np.ndarray, end: float, seconds: float) -> float:
    """Half the peak-to-peak of ``y`` over the ``seconds`` before ``end``."""
    window = y[(t > end - seconds) & (t <= end)]
    return 0.5 * float(window.max() - window.min())


def _forced(mixture: str, coefficients: dict, forced: dict) -> dict:
    """Both schedules on both models: φ₂, steady amplitudes per step level and amplitudes per cycle."""
    t, schedules, switch = _schedules(forced)
    phi1 = float(forced["amplitude_deg"]) * np.sin(2 * np.pi * float(forced["frequency_hz"]) * t)
    period = 1.0 / float(forced["frequency_hz"])
    window = int(forced["steady_cycles"]) * period
    ends = [*switch, float(t[-1])]
    out = {"t": t, "phi1": phi1, "pressure": schedules, "rows": [], "cycles": []}
    for model, coeffs in zip(MODELS, (None, coefficients)):
        y = forced_response(mixture, t, schedules, amplitude_deg=forced["amplitude_deg"],
                            frequency_hz=forced["frequency_hz"], coefficients=coeffs)[..., 0]
        out[model] = y
        row = {"mixture": mixture, "model": model}
        for level, end in zip(forced["step_mpa"], ends):
            row[f"φ₂ at {float(level):g} MPa [deg]"] = _amplitude(y[0], t, end, window)
            row[f"twist at {float(level):g} MPa [deg]"] = _amplitude(y[0] - phi1, t, end, window)
        out["rows"].append(row)
        for j, schedule in enumerate(SCHEDULES):
            for k in range(1, int(round(t[-1] / period))):  # cycle 0 is the start-up from rest
                inside = (t > k * period) & (t <= (k + 1) * period)
                out["cycles"].append({"mixture": mixture, "model": model, "schedule": schedule, "cycle": k,
                                      "t mid [s]": (k + 0.5) * period, "p [MPa]": float(schedules[j][inside].mean()),
                                      "φ₂ amplitude [deg]": _amplitude(y[j], t, (k + 1) * period, period),
                                      "twist amplitude [deg]": _amplitude(y[j] - phi1, t, (k + 1) * period, period)})
    return out


def vpptd_dynamics(options: dict, out: StudyOutput) -> dict:
    """Identify, compare loops and combinations, free vibration (Table 2), forced rig (Figs. 10–14)."""
    opts = _options(options)
    results = {}
    for mixture in progress_bar(opts["mixtures"], "seed 001 mixtures", enabled=opts["progress"]):
        start = time.perf_counter()
        ident = _identify(mixture, opts)
        coefficients = ident["coefficients"]
        loops = _loops(mixture, coefficients, opts)
        results[mixture] = {
            "ident": ident, "loops": loops, "loop_rows": _loop_rows(mixture, loops, opts["fit_pressures"]),
            "combinations": _combination_rows(mixture, coefficients, opts["eval_pressures"]),
            "free_vibration": _free_vibration(mixture, coefficients, opts),
            "forced": _forced(mixture, coefficients, opts["forced"]), "wall_s": time.perf_counter() - start}
    return _report(out, opts, results)


def _identification_table(results: dict) -> pd.DataFrame:
    rows = []
    for mixture, r in results.items():
        loops = pd.DataFrame(r["loop_rows"])
        held = loops.loc[loops["role"] == "held out", "RMSE vs Table 1 [Nm]"]
        rows.append({"mixture": mixture, "coordinates": r["ident"]["coordinates"],
                     "identifiable directions": r["ident"]["identifiable"],
                     "identify wall [s]": r["ident"]["wall_s"], "RMSE fitted loops [Nm]": r["ident"]["rmse"],
                     "max RMSE vs Table 1, fitted p [Nm]": loops.loc[loops["role"] == "fitted",
                                                                     "RMSE vs Table 1 [Nm]"].max(),
                     "max RMSE vs Table 1, held-out p [Nm]": held.max() if len(held) else math.nan,
                     "max abs. peak difference [%]": loops["peak difference [%]"].abs().max()})
    return pd.DataFrame(rows)


def _table2(frames: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for mixture, f in frames.groupby("mixture", sort=False):
        low, high = TABLE2_HZ[mixture]
        row = {"mixture": mixture, "Table 2 [Hz]": f"{low:.2f}–{high:.2f}"}
        inside = True
        for col in [c for c in f.columns if c.endswith("[Hz]")]:
            row[col.replace(" [Hz]", "")] = f"{f[col].min():.3f}–{f[col].max():.3f}"
            if "FFT" in col:
                inside &= bool(((f[col] >= low - 0.03) & (f[col] <= high + 0.03)).all())
        row["FFT within Table 2 ± 0.03 Hz"] = "yes" if inside else "no"
        rows.append(row)
    return pd.DataFrame(rows)


def _sweep_table(cycles: pd.DataFrame) -> pd.DataFrame:
    """Twist amplitude of the sweep in its first cycle, at peak pressure and in its last cycle."""
    rows = []
    for (mixture, model), c in cycles.groupby(["mixture", "model"], sort=False):
        row = {"mixture": mixture, "model": model}
        for name, pick in (("first cycle", c.iloc[0]), ("peak p", c.loc[c["p [MPa]"].idxmax()]),
                           ("last cycle", c.iloc[-1])):
            row[f"{name}: p [MPa]"] = pick["p [MPa]"]
            row[f"{name}: twist [deg]"] = pick["twist amplitude [deg]"]
        rows.append(row)
    return pd.DataFrame(rows)


def _report(out: StudyOutput, opts: dict, results: dict) -> dict:
    fit_p = ", ".join(f"{p:g}" for p in opts["fit_pressures"])
    settings = ", ".join(f"{k}={v}" for k, v in opts["identify"].items())
    degrees = ", ".join(f"{k} {len(v) - 1}" for k, v in opts["box"].items())
    out.text(f"Data: `load_vpptd` loops (±10°, 0.79 Hz, 570 samples per cycle) of seed 001 Table 1's model with "
             f"{opts['noise_sd']} Nm Gaussian torque noise. Identification: {opts['fit_cycles']} cycles at p = "
             f"{fit_p} MPa per mixture, fitted jointly (`identify({settings})`); every parameter a polynomial in "
             f"p of degree {degrees}. Evaluation: 3 cycles at p = "
             f"{', '.join(f'{p:g}' for p in opts['eval_pressures'])} MPa (\"held out\": not fitted).")
    out.table("identification", _identification_table(results), "Identification per mixture (RMSE over all "
              "samples; the noise floor is the noise sd)")
    loops = pd.DataFrame([row for r in results.values() for row in r["loop_rows"]])
    out.csv("loops", loops, "RMSE and steady-loop peak torque per mixture and pressure.")
    combos = pd.DataFrame([row for r in results.values() for row in r["combinations"]])
    shown = combos[combos["p [MPa]"].isin([min(opts["eval_pressures"]), max(opts["eval_pressures"])])]
    out.table("combinations", shown, "Identifiable combinations (invariant under the Bouc–Wen rescalings) at the "
              "lowest and highest pressure, Table 1 (T1) and identified (id): elastic stiffness αk and initial "
              "hysteretic stiffness (1−α)kA [Nm/deg], hysteretic torque F_h = (1−α)Dk(A/(β+γ))^(1/n) [Nm], dry "
              "friction M_s [Nm], viscous c [Nm·s/deg]")
    out.csv("combinations_all", combos, "identifiable combinations at every evaluation pressure.")
    functions = pd.DataFrame([{"mixture": m, "parameter": k, "Table 1 (c0, c1, …)": str(TABLE1[m][k]),
                               "identified (c0, c1, …)": str([float(f"{c:.4g}") for c in fit])}
                              for m, r in results.items() for k, fit in r["ident"]["coefficients"].items()])
    out.csv("functions", functions, "raw parameter functions, Table 1 and identified (not identifiable one by one).")
    fv = pd.concat([r["free_vibration"] for r in results.values()], ignore_index=True)
    out.table("table2", _table2(fv), "Seed 001 Table 2: free-vibration frequency range over the evaluation "
              "pressures [Hz], Table 1's and the identified damper on the rig (I = 0.51), FFT and turning points")
    out.csv("free_vibration", fv, "free-vibration frequency per mixture and pressure.")
    step = pd.DataFrame([row for r in results.values() for row in r["forced"]["rows"]])
    levels = " → ".join(f"{float(v):g}" for v in opts["forced"]["step_mpa"])
    out.table("forced_step", step, f"Forced rig, φ₁ = {opts['forced']['amplitude_deg']}° sin(2π·"
              f"{opts['forced']['frequency_hz']} Hz·t), fast steps p = {levels} MPa ({opts['forced']['ramp_s']} s "
              f"ramps): steady amplitude of φ₂ and of the damper twist φ₂ − φ₁ over the last "
              f"{opts['forced']['steady_cycles']} cycles of each level{_extrapolated(opts['forced'])}")
    cycles = pd.DataFrame([row for r in results.values() for row in r["forced"]["cycles"]])
    out.table("forced_sweep", _sweep_table(cycles[cycles["schedule"] == "sweep"]), f"Forced rig, half-sine sweep "
              f"p = {opts['forced']['sweep_peak_mpa']}·sin(πt/T): twist amplitude in the first cycle after the "
              "start-up, at peak pressure and in the last cycle")
    out.csv("forced_cycles", cycles, "amplitudes of φ₂ and of the twist per excitation cycle, both schedules.")
    write_figures(out, results, fv, cycles)
    return _summary(opts, results, loops, fv, step)


def _summary(opts: dict, results: dict, loops: pd.DataFrame, fv: pd.DataFrame, step: pd.DataFrame) -> dict:
    summary = {"noise_sd": float(opts["noise_sd"]), "mixtures": {}, "published_hz": {}, "identification": {},
               "free_vibration": {}, "forced_step": step.to_dict(orient="records")}
    for mixture, r in results.items():
        f = fv[fv["mixture"] == mixture]
        mine = loops[loops["mixture"] == mixture]
        summary["mixtures"][mixture] = {"pressure_mpa": [float(p) for p in f["p [MPa]"]],
                                        "frequency_hz": [float(v) for v in f["Table 1 FFT [Hz]"]]}
        summary["published_hz"][mixture] = list(TABLE2_HZ[mixture])
        summary["free_vibration"][mixture] = {c: [float(v) for v in f[c]] for c in f.columns if c.endswith("[Hz]")}
        summary["identification"][mixture] = {
            "rmse_fit": float(r["ident"]["rmse"]), "per_record": r["ident"]["per_record"],
            "rmse_vs_table1": [float(v) for v in mine["RMSE vs Table 1 [Nm]"]],
            "rmse_vs_data": [float(v) for v in mine["RMSE vs data [Nm]"]],
            "peak_difference_pct": [float(v) for v in mine["peak difference [%]"]],
            "wall_s": float(r["ident"]["wall_s"]), "mixture_wall_s": float(r["wall_s"]),
            "identifiable": int(r["ident"]["identifiable"]), "coordinates": int(r["ident"]["coordinates"]),
            "coefficients": r["ident"]["coefficients"]}
    return summary
