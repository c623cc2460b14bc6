"""PNG figures (matplotlib, Agg backend, 100 dpi, ≤ 8 in wide and, up to two rows of panels, 5 in tall).

``draw_loops`` / ``write_loops`` is the package's one hysteresis-loop figure (measured vs model response
against the excitation, axes labelled with the data's units); fit, identify, discovery, the training
callback and the comparison report all draw their loops with it.

The comparison-report figures return the written path, or None when there is nothing to draw (no
predictions, no sweep); the caller then leaves the figure out of the report.
"""

from __future__ import annotations

import json
import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..files import atomic_write
from ..units import UNIT_QUANTITY
from .tables import configuration_labels

__all__ = ["Loop", "axis_label", "data_efficiency_figure", "draw_loops", "error_per_condition_figure", "lambda_figure",
           "loops_figure", "sweeps", "write_loops"]

DPI = 100
_PREDICTION_COLUMNS = ["record", "split", "condition", "x", "y", "y_pred"]


def _short(condition) -> str:
    """A tick label: the condition's values only ("kind=earthquake, amplitude_in=0.585" -> "earthquake,
    0.585"), wrapped to short lines."""
    values = ", ".join(part.split("=", 1)[-1] for part in str(condition).split(", "))
    return textwrap.fill(values, 16)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    """Write ``fig`` as PNG atomically and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda p: fig.savefig(p, format="png", dpi=DPI))
    _pyplot().close(fig)
    return path


def _ylabel(unit: str | None) -> str:
    return f"test RMSE [{unit}]" if unit else "test RMSE"


def _test_predictions(path: str, notes: list[str]) -> pd.DataFrame | None:
    """The test split of one ``predictions.parquet``; a file that cannot be read adds a note instead."""
    try:
        frame = pd.read_parquet(path, columns=_PREDICTION_COLUMNS)
    except Exception as exc:  # any reader error (pyarrow, missing column) is reported, never fatal
        notes.append(f"`{path}` could not be read ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})")
        return None
    frame = frame[frame["split"] == "test"]
    return frame.assign(condition=frame["condition"].astype(str))


def _best_runs(runs: pd.DataFrame, summary: pd.DataFrame, limit: int) -> list[tuple[str, str]]:
    """(configuration label, predictions path) of the seed with the lowest *validation* RMSE (training
    RMSE without validation records; never the test error, which would flatter the figure) of the best
    ``limit`` configurations that have predictions, in summary order."""
    with_predictions = runs[(runs["status"] == "ok") & runs["predictions"].notna()].copy()
    with_predictions["_choice"] = with_predictions["val_rmse"].fillna(with_predictions["train_rmse"])
    with_predictions["_choice"] = with_predictions["_choice"].fillna(with_predictions["test_rmse"])
    best = with_predictions.loc[with_predictions.groupby("config")["_choice"].idxmin()]
    path = dict(zip(best["config"], best["predictions"]))
    chosen = [(label, path[key]) for label, key in zip(summary["configuration"], summary["config"]) if key in path]
    return chosen[:limit]


def _legend_below(fig, handles: list, labels: list[str]) -> None:
    """One legend for the whole figure, below the panels (none without labels)."""
    if not labels:
        fig.tight_layout()
        return
    ncol = min(len(labels), 3)
    rows = math.ceil(len(labels) / max(ncol, 1))
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, min(0.07 * rows, 0.35), 1, 1))


# -- the hysteresis-loop figure: every loop plot of the package is drawn here -----------------------------

# a channel without a unit that names its quantity (hybridhyst.units.UNIT_QUANTITY) is labelled by its role
_ROLE = {"x": "excitation", "y": "response", "t": "time"}
_PALETTE = ("C3", "C0", "C2", "C1", "C4", "C5", "C6", "C8", "C9")


@dataclass
class Loop:
    """One panel of ``draw_loops``: measured response ``y`` against excitation ``x`` (arrays of shape
    ``(time,)``; NaN breaks the line, ``y=None`` draws no measurement), with the units of the channels
    (``{"x": "deg", "y": "Nm"}``) and what the panel is titled by (its conditions, else its name).

    A ``hybridhyst.data.Record`` has these fields too and is drawn as it is.
    """

    x: np.ndarray
    y: np.ndarray | None
    name: str = ""
    conditions: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)


def axis_label(channel: str, unit: str | None) -> str:
    """Axis label of a record channel: the quantity its unit measures, the channel and the unit,
    e.g. ``axis_label("x", "deg") == "angle x [deg]"``, ``axis_label("y", "kip") == "force y [kip]"``;
    without a known quantity the channel's role (``"response y [1]"``), without a unit no brackets."""
    quantity = UNIT_QUANTITY.get(unit or "") or _ROLE.get(channel, "channel")
    return f"{quantity} {channel} [{unit}]" if unit else f"{quantity} {channel}"


def _title(loop) -> str:
    """The panel title: the loop's condition values ("pressure_mpa=0.05, mixture=1:3"), else its name."""
    conditions = loop.operating if hasattr(loop, "operating") else getattr(loop, "conditions", None) or {}
    text = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in conditions.items())
    return textwrap.fill(text or str(getattr(loop, "name", "")), 44)


def _curve(values) -> np.ndarray:
    """A channel as a float array of shape (time,): tensors are detached, (time, channel) gives its first."""
    if hasattr(values, "detach"):
        values = values.detach().cpu().numpy()
    a = np.asarray(values, dtype=float)
    return a[:, 0] if a.ndim == 2 else a.reshape(-1)


def draw_loops(loops, predictions: dict | None = None, *, units: dict | None = None, styles: dict | None = None,
               measured: str = "measured", columns: int = 3):
    """The hysteresis-loop figure: measured response against excitation and the model outputs, one panel
    per loop (a grid of at most ``columns`` columns), returned as an open matplotlib ``Figure``.

    Parameters
    ----------
    loops : sequence of ``Loop`` or ``hybridhyst.data.Record`` (anything with ``x``, ``y``, ``name``,
        ``conditions``, ``units``); one panel each, titled by its condition values (else its name).
    predictions : ``{label: [one entry per loop]}``; an entry is the model's response on the loop's own
        ``x`` (shape ``(time,)``, or ``(time, channel)`` of which the first is drawn), an ``(x, y)`` pair on
        another grid, or None (nothing drawn in that panel).
    units : ``{"x": unit, "y": unit}`` for every panel, overriding the loops' own ``units``.
    styles : ``{label: matplotlib line keywords}`` for some prediction labels (default: colours C3, C0, C2,
        ... in label order, solid).
    measured : legend label of the measured loop.

    Axis labels name the quantity, the channel and its unit (``axis_label``); one legend below the panels.
    """
    loops = list(loops)
    if not loops:
        raise ValueError("draw_loops: no loops to draw; pass at least one record")
    predictions = dict(predictions or {})
    for label, entries in predictions.items():
        if len(entries) != len(loops):
            raise ValueError(f"draw_loops: prediction {label!r} has {len(entries)} entries for {len(loops)} loops; "
                             "give one per loop (None where there is none)")
    plt = _pyplot()
    cols = max(1, min(len(loops), int(columns)))
    rows = math.ceil(len(loops) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=({1: 5.0, 2: 7.0}.get(cols, 8.0), 3.4 if rows == 1 else 2.5 * rows),
                             dpi=DPI, squeeze=False)
    style = {label: {"color": _PALETTE[i % len(_PALETTE)], "lw": 0.9, **(styles or {}).get(label, {})}
             for i, label in enumerate(predictions)}
    handles: dict[str, object] = {}
    for i, (ax, loop) in enumerate(zip(axes.flat, loops)):
        x = _curve(loop.x)
        if loop.y is not None:
            handles[measured], = ax.plot(x, _curve(loop.y), color="0.55", lw=1.1)
        for label, entries in predictions.items():
            entry = entries[i]
            if entry is None:
                continue
            px, py = (_curve(entry[0]), _curve(entry[1])) if isinstance(entry, tuple) else (x, _curve(entry))
            handles[label], = ax.plot(px, py, **style[label])
        own = {**(getattr(loop, "units", None) or {}), **(units or {})}
        ax.set_xlabel(axis_label("x", own.get("x")), fontsize=8)
        ax.set_ylabel(axis_label("y", own.get("y")), fontsize=8)
        ax.set_title(_title(loop), fontsize=7.5)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(loops):]:
        ax.set_visible(False)
    _legend_below(fig, list(handles.values()), list(handles))
    return fig


def write_loops(path: Path, loops, predictions: dict | None = None, **options) -> Path:
    """``draw_loops(loops, predictions, **options)`` written to ``path`` as PNG (atomically); returns ``path``."""
    return _save(draw_loops(loops, predictions, **options), Path(path))


def _joined(parts: list[np.ndarray]) -> np.ndarray:
    """Arrays joined with a NaN between them, so that one line draws them as separate curves."""
    gaps = [np.full(1, np.nan)] * len(parts)
    return np.concatenate([a for pair in zip(parts, gaps) for a in pair][:-1]) if parts else np.empty(0)


def _records_loop(frame: pd.DataFrame, column: str) -> tuple[np.ndarray, np.ndarray]:
    """(x, ``column``) of every record of ``frame``, joined with NaN gaps."""
    records = [rec for _, rec in frame.groupby("record", sort=False)]
    return (_joined([rec["x"].to_numpy(float) for rec in records]),
            _joined([rec[column].to_numpy(float) for rec in records]))


def loops_figure(runs: pd.DataFrame, summary: pd.DataFrame, conditions: list[str], path: Path,
                 notes: list[str], max_conditions: int = 6, max_configurations: int = 6) -> Path | None:
    """Measured response y vs excitation x and the prediction of the best seed of the best
    configurations, one panel per held-out condition (at most ``max_conditions``), drawn by
    ``write_loops`` with the units of the runs.

    ``notes`` receives one line per ``predictions.parquet`` that could not be read.
    """
    frames = [(label, _test_predictions(p, notes)) for label, p in _best_runs(runs, summary, max_configurations)]
    frames = [(label, f) for label, f in frames if f is not None and not f.empty]
    present = {c for _, f in frames for c in f["condition"].unique()}
    shown = [c for c in conditions if c in present][:max_conditions]
    if not shown:
        return None
    unit = _first_unit(runs)
    units = {"x": unit["x"], "y": unit["F"]}
    loops, predictions = [], {label: [] for label, _ in frames}
    for condition in shown:
        measured = next(f for _, f in frames if condition in set(f["condition"]))
        x, y = _records_loop(measured[measured["condition"] == condition], "y")
        loops.append(Loop(x, y, name=condition, units=units))
        for label, frame in frames:
            part = frame[frame["condition"] == condition]
            predictions[label].append(_records_loop(part, "y_pred") if len(part) else None)
    colors = {label: f"C{i % 10}" for i, label in enumerate(summary["configuration"])}
    return write_loops(path, loops, predictions, styles={label: {"color": colors[label]} for label in predictions})


def _first_unit(runs: pd.DataFrame) -> dict[str, str]:
    """The units {quantity: unit} of the first successful run that states them."""
    ok = runs[runs["status"] == "ok"]
    return {q: next(iter(ok[f"unit_{q}"].dropna()), None) for q in ("x", "F")}


def error_per_condition_figure(stats: pd.DataFrame, summary: pd.DataFrame, unit: str | None, path: Path,
                               max_configurations: int = 8) -> Path | None:
    """Grouped bars of the mean test RMSE per held-out condition (error bar: std over seeds), one bar
    per configuration (the best ``max_configurations``)."""
    if stats.empty:
        return None
    labels = [c for c in summary["configuration"] if c in set(stats["configuration"])][:max_configurations]
    conditions = list(dict.fromkeys(stats["condition"]))
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8.0, 4.5), dpi=DPI)
    width = 0.8 / len(labels)
    centres = np.arange(len(conditions))
    colors = {label: f"C{i % 10}" for i, label in enumerate(summary["configuration"])}
    for i, label in enumerate(labels):
        rows = stats[stats["configuration"] == label].set_index("condition").reindex(conditions)
        ax.bar(centres - 0.4 + (i + 0.5) * width, rows["rmse_mean"], width,
               yerr=rows["rmse_std"].fillna(0.0), capsize=2, color=colors[label], label=label,
               error_kw={"lw": 0.8})
    ax.set_xticks(centres, [_short(c) for c in conditions], fontsize=6.5)
    ax.set_ylabel(_ylabel(unit))
    ax.set_xlabel("held-out condition")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, ncol=2 if len(labels) > 4 else 1)
    fig.tight_layout()
    return _save(fig, path)


def sweeps(summary: pd.DataFrame, field: str) -> list[tuple[str, pd.DataFrame]]:
    """Groups of configurations equal in every setting except ``field``, with ≥ 2 values of it.

    Returns (label, summary rows sorted by ``field``) per sweep, in summary order; the label names the
    configuration without the swept setting.
    """
    groups: dict[str, list[int]] = {}
    for i, key in enumerate(summary["config"]):
        config = json.loads(key)
        if config.pop(field, None) is not None:
            groups.setdefault(json.dumps(config, sort_keys=True), []).append(i)
    found = [(key, summary.iloc[rows].sort_values(field)) for key, rows in groups.items()]
    found = [(key, rows) for key, rows in found if rows[field].nunique() > 1]
    labels = configuration_labels([json.loads(key) for key, _ in found])
    return [(label, rows) for label, (_, rows) in zip(labels, found)]


def _errorbar(ax, x, rows: pd.DataFrame, label: str, color: str) -> None:
    ax.errorbar(x, rows["test_rmse_mean"], yerr=rows["test_rmse_std"].fillna(0.0), marker="o", ms=4,
                capsize=3, lw=1.0, color=color, label=label)


def lambda_figure(summary: pd.DataFrame, unit: str | None, path: Path, max_sweeps: int = 6) -> Path | None:
    """Mean ± std test RMSE vs the physics-loss weight λ_phys on a log axis; λ = 0 is drawn at the left
    edge (a decade below the smallest positive λ) and labelled "0". None when no λ sweep exists."""
    found = sweeps(summary, "lambda_phys")[:max_sweeps]
    if not found:
        return None
    values = sorted({float(v) for _, rows in found for v in rows["lambda_phys"]})
    positive = [v for v in values if v > 0]
    zero_at = positive[0] / 10.0 if positive else 1.0
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2), dpi=DPI)
    for i, (label, rows) in enumerate(found):
        x = np.where(rows["lambda_phys"] > 0, rows["lambda_phys"], zero_at)
        _errorbar(ax, x, rows, label, f"C{i % 10}")
    ax.set_xscale("log")
    ax.set_xticks([v if v > 0 else zero_at for v in values], [f"{v:.4g}" for v in values],
                  fontsize=8, rotation=30 if len(values) > 6 else 0)
    ax.minorticks_off()
    return _finish_curve(fig, ax, "λ_phys (λ = 0 at the left edge)", unit, path)


def data_efficiency_figure(summary: pd.DataFrame, unit: str | None, path: Path, max_sweeps: int = 6) -> Path | None:
    """Mean ± std test RMSE vs the fraction of the training data used, one line per configuration.
    None when no configuration was run at two or more training fractions."""
    found = sweeps(summary, "train_fraction")[:max_sweeps]
    if not found:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2), dpi=DPI)
    for i, (label, rows) in enumerate(found):
        _errorbar(ax, rows["train_fraction"], rows, label, f"C{i % 10}")
    return _finish_curve(fig, ax, "training fraction", unit, path)


def _finish_curve(fig, ax, xlabel: str, unit: str | None, path: Path) -> Path:
    """Labels, grid and legend of a test-RMSE curve; saves the figure."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(_ylabel(unit))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)
