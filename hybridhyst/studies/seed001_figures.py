"""Seed 001 study figures: steady loops per mixture, free-vibration frequency against underpressure (with
Table 2's range), the forced rig's amplitude per cycle and its time response."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..physics.compositions.seed001 import TABLE2_HZ
from .output import StudyOutput

MODELS = ("Table 1", "identified")
SCHEDULES = ("steps", "sweep")
SAMPLES_PER_CYCLE = 570  # load_vpptd's default resolution of the evaluation loops


def write_figures(out: StudyOutput, results: dict, fv: pd.DataFrame, cycles: pd.DataFrame) -> None:
    out.figure("loops", fig_loops(results), "Steady loops (last cycle): noisy data (dots), Table 1 (solid), "
               "identified (dashed)")
    out.figure("free_vibration", fig_free_vibration(fv), "Free-vibration frequency against underpressure; "
               "shaded: Table 2's published range")
    out.figure("forced", fig_forced(cycles, results), "Forced rig, amplitude per excitation cycle: φ₂ (circles) "
               "and the damper twist φ₂ − φ₁ (crosses), Table 1 (blue) and identified (orange, dashed); excitation "
               "amplitude (grey); underpressure on the right axis (green)")
    first = next(iter(results))
    out.figure("forced_trace", fig_trace(first, results[first]["forced"]), f"{first}: time response of the "
               "forced rig, φ₁ (grey), φ₂ of Table 1's model (blue) and of the identified one (orange, dashed)")


def pressure_axis(ax, t: np.ndarray, pressure: np.ndarray) -> None:
    """The underpressure schedule [MPa] on a right-hand axis (green)."""
    twin = ax.twinx()
    twin.plot(t, pressure, color="C2", lw=1.0)
    twin.set_ylim(-0.005, 0.1)
    twin.tick_params(labelsize=6, colors="C2")


def fig_loops(results: dict):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(2.7 * len(results) + 0.5, 2.8), squeeze=False)
    for ax, r in zip(axes[0], results.values()):
        loops = r["loops"]
        shown = sorted({0, len(loops["pressures"]) // 2, len(loops["pressures"]) - 1})
        last = slice(-SAMPLES_PER_CYCLE - 1, None)
        for j, i in enumerate(shown):
            x = loops["x"][i][last]
            ax.plot(x[::8], loops["data"][i][last][::8], ".", ms=1.5, color="0.6")
            ax.plot(x, loops["Table 1"][i][last], color=f"C{j}", lw=1.2, label=f"{loops['pressures'][i]:g} MPa")
            ax.plot(x, loops["identified"][i][last], "--", color="k", lw=0.8)
    return _finish_row(fig, axes, list(results), "φ [deg]", "M [Nm]")


def fig_free_vibration(fv: pd.DataFrame):
    import matplotlib.pyplot as plt

    mixtures = list(dict.fromkeys(fv["mixture"]))
    fig, axes = plt.subplots(1, len(mixtures), figsize=(2.5 * len(mixtures) + 0.5, 2.6), squeeze=False, sharey=True)
    for ax, mixture in zip(axes[0], mixtures):
        f = fv[fv["mixture"] == mixture]
        low, high = TABLE2_HZ[mixture]
        ax.axhspan(low, high, color="0.88")
        for j, model in enumerate(MODELS):
            ax.plot(f["p [MPa]"], f[f"{model} FFT [Hz]"], "o-" if j == 0 else "s--", ms=3, color=f"C{j}",
                    label=f"{model} FFT")
            ax.plot(f["p [MPa]"], f[f"{model} turning points [Hz]"], "^" if j == 0 else "v", ms=3, mfc="none",
                    color=f"C{j}", label=f"{model} turning points")
    return _finish_row(fig, axes, mixtures, "p [MPa]", "frequency [Hz]")


def _finish_row(fig, axes, titles, xlabel: str, ylabel: str):
    """One row of panels (one per mixture): titles, axis labels, the legend on the first panel."""
    for ax, title in zip(axes[0], titles):
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel(ylabel, fontsize=8)
    axes[0][0].legend(fontsize=6, loc="upper left")
    fig.tight_layout()
    return fig


def fig_forced(cycles: pd.DataFrame, results: dict):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 2, figsize=(8, 1.2 * len(results) + 0.4), squeeze=False, sharex=True)
    for row, (mixture, r) in zip(axes, results.items()):
        f = r["forced"]
        for ax, (j, schedule) in zip(row, enumerate(SCHEDULES)):
            ax.axhline(float(np.abs(f["phi1"]).max()), color="0.6", lw=0.8)
            for m, (model, style) in enumerate(zip(MODELS, ("-", "--"))):
                c = cycles[(cycles["mixture"] == mixture) & (cycles["model"] == model)
                           & (cycles["schedule"] == schedule)]
                ax.plot(c["t mid [s]"], c["φ₂ amplitude [deg]"], style, marker="o", ms=2.5, color=f"C{m}", lw=0.9)
                ax.plot(c["t mid [s]"], c["twist amplitude [deg]"], style, marker="x", ms=3, color=f"C{m}", lw=0.6)
            pressure_axis(ax, f["t"][::50], f["pressure"][j][::50])
            ax.set_title(f"{mixture}: {schedule}", fontsize=8)
            ax.tick_params(labelsize=7)
        row[0].set_ylabel("amplitude [deg]", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]", fontsize=8)
    fig.tight_layout()
    return fig


def fig_trace(mixture: str, f: dict):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 2.4), squeeze=False)
    s = slice(None, None, 20)  # 25 points per second: enough for 0.3 Hz, keeps the PNG small
    for ax, (j, schedule) in zip(axes[0], enumerate(SCHEDULES)):
        ax.plot(f["t"][s], f["phi1"][s], color="0.6", lw=0.6)
        ax.plot(f["t"][s], f["Table 1"][j][s], color="C0", lw=0.7)
        ax.plot(f["t"][s], f["identified"][j][s], "--", color="C1", lw=0.7)
        pressure_axis(ax, f["t"][s], f["pressure"][j][s])
        ax.set_title(f"{mixture}: {schedule}", fontsize=8)
        ax.set_xlabel("t [s]", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("φ [deg]", fontsize=8)
    fig.tight_layout()
    return fig
