"""The short Markdown report and the loop figure of ``hybridhyst-fit``, generated from its summary.

(Comparison tables across run directories belong to ``hybridhyst.report``; this file only renders one
fit run.)
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..identify.gradient import TOLERANCE
from ..report.figures import Loop, write_loops
from .common import atomic_write, resolution_note

__all__ = ["convergence_note", "loop_caption", "write_loop_figure", "write_report"]


def write_loop_figure(path: Path, frames: list[pd.DataFrame], units: dict[str, str], titles: list[str]) -> Path:
    """Response–excitation loops of held-out records, measured vs model, one panel each, as PNG (``write_loops``).

    Each frame has columns x, y (measured) and y_model, on the evaluation grid; ``units`` ``{"x", "y"}``.
    """
    loops = [Loop(f["x"].to_numpy(float), f["y"].to_numpy(float), name=t, units=units) for f, t in zip(frames, titles)]
    return write_loops(path, loops, {"model": [f["y_model"].to_numpy(float) for f in frames]})


def loop_caption(shown: list[str], held_out: list[str], chosen: bool) -> str:
    """What ``loop.png`` shows: the held-out records (the worst first, at most ``MAX_LOOPS``) or those chosen."""
    if chosen:
        return f"the records of report.loop_records: {', '.join(shown)}"
    if len(shown) < len(held_out):
        return f"the {len(shown)} held-out records with the largest RMSE of {len(held_out)}, the worst first"
    return "the held-out record" if len(shown) == 1 else "every held-out record, the worst first"


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return "" if value is None else str(value)


def _grid(evaluate: dict) -> str:
    factors = sorted(set(evaluate["decimation"].values()))
    every = ("every sample" if factors == [1] else f"one measured sample in {' or '.join(map(str, factors))}"
             + (", depending on the record" if len(factors) > 1 else ""))
    per_cycle = evaluate.get("samples_per_cycle")
    return f"about {per_cycle} samples per loading cycle ({every})" if per_cycle else every


def convergence_note(fit: dict) -> str:
    """One sentence on whether the fit converged (L-BFGS stopped by itself, or why not)."""
    if fit.get("converged") is True:
        return (f"Converged: L-BFGS stopped by itself (an iteration changed the loss by at most {TOLERANCE:g}, "
                "relative).")
    change = fit.get("last_change")
    fell = f"; the loss still fell by {100 * change:.2g} % in the last step" if (change or 0) > 0 else ""
    if fit.get("converged") is None:
        return f"Convergence not checked: no L-BFGS iterations after Adam (fit.lbfgs_steps=0){fell}."
    if fit.get("stop") == "non-finite":
        return (f"Not converged: L-BFGS ended after {fit['steps'].get('lbfgs')} iterations on a step whose "
                "simulation diverged (the best point is kept); try more sub-steps (fit.max_substeps) or a smaller "
                "fit.lr.")
    return (f"Not converged: L-BFGS reached fit.lbfgs_steps ({fit['steps'].get('lbfgs')}) before the loss stopped "
            f"changing{fell}; raise fit.lbfgs_steps before trusting these values.")


def _parameter_lines(parameters: dict) -> list[str]:
    lines = ["| effect | parameter | value | unit |", "|---|---|---|---|"]
    for effect, params in parameters.items():
        for name, info in params.items():
            value = _fmt(info["value"]) + (" (fixed)" if info.get("fixed") else "")
            lines.append(f"| {effect} | {name} | {value} | {info['unit']} |")
    return lines


def _record_lines(summary: dict, names: list[str], unit: str) -> list[str]:
    keys = sorted({k for n in names for k in summary["conditions"].get(n, {})})
    lines = ["| record | " + " | ".join(keys) + f" | RMSE [{unit}] |", "|---" * (len(keys) + 2) + "|"]
    for n in names:
        cond = summary["conditions"].get(n, {})
        cells = " | ".join(_fmt(cond.get(k)) for k in keys)
        lines.append(f"| {n} | {cells} | {summary['per_record'][n]:.3f} |")
    return lines


def _reference_lines(summary: dict, unit: str) -> list[str]:
    ref = summary.get("reference")
    model = summary.get("model") or "this model"
    lines = [f"| model | held-out RMSE [{unit}] |", "|---|---|",
             f"| **{model} (this run)** | **{summary['rmse']['held_out']:.3f}** |"]
    if ref:
        lines += [f"| {name} (reference) | {value:.2f} |" for name, value in ref["held_out_rmse"].items()]
        lines += ["", f"Reference numbers: {ref['source']}."]
    return lines


def write_report(path: Path, summary: dict) -> Path:
    """``report.md``: data and split, fitted parameters with units, held-out RMSE per record, the
    comparison with the reference numbers, and the loop figure."""
    unit = summary["units"].get("y", "")
    fit = summary["fit"]
    steps = ", ".join(f"{k} {v}" for k, v in fit["steps"].items())
    lines = [
        f"# Fit report: {summary.get('model', '')}",
        "",
        f"Training records ({len(summary['split']['train'])}): {', '.join(summary['split']['train'])}.  ",
        f"Held-out records ({len(summary['split']['held_out'])}): {', '.join(summary['split']['held_out'])}.",
        "",
        " ".join(filter(None, [
            f"Fit: {fit['loss']} loss by gradient descent through `simulate` ({steps}; {fit['evaluations']} "
            f"simulations) on {fit['samples']} decimated samples in {fit['wall_s']:.1f} s; whole run "
            f"{summary['wall_s']:.1f} s.", convergence_note(fit), resolution_note(fit, "fit")])),
        "",
        "## Fitted parameters",
        "",
        *_parameter_lines(summary["parameters"]),
        "",
        "## Held-out error per condition",
        "",
        *_record_lines(summary, summary["split"]["held_out"], unit),
        "",
        (f"Pooled RMSE (records weighted by their full-rate length): train {summary['rmse']['train']:.3f} "
         f"{unit}, held out {summary['rmse']['held_out']:.3f} {unit}, scored on {_grid(summary['evaluate'])}."),
        "",
        *_reference_lines(summary, unit),
        "",
        (f"![loops](loop.png)  \n*Response–excitation loops, measured (grey) and model (red): "
         f"{summary['loop_caption']}.*"),
        "",
    ]
    return atomic_write(path, "\n".join(lines))
