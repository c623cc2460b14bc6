"""The short Markdown report and the loop figure of ``hybridhyst-fit``, generated from its summary.

(Comparison tables across run directories belong to ``hybridhyst.report``; this file only renders one
fit run.)
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from ..analysis.finite import Diverged, divergence_message
from ..identify.gradient import TOLERANCE
from ..report.figures import Loop, write_loops
from .common import atomic_write, resolution_note

__all__ = ["convergence_note", "diverged_sentence", "grid_words", "loop_caption", "part_rmse", "start_sentence",
           "write_loop_figure", "write_report"]


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


def _count(v: float) -> str:
    return f"{v:.0f}" if v >= 10 else f"{v:.2g}"


def grid_words(decimation: dict, per_cycle: dict | None = None) -> str:
    """What a grid was, as it was made: the samples per loading cycle the records actually had (a range where
    they differ; ``per_cycle``: ``{record: samples per cycle or None}``) and whether they were thinned
    (``decimation``: ``{record: factor}``), e.g. "167–500 samples per loading cycle (every sample)" or "256
    samples per loading cycle (one measured sample in 2, 4 or 8, depending on the record)"."""
    factors = sorted(set(decimation.values()))
    if factors == [1]:
        thinned = "every sample"
    else:
        listed = ", ".join(map(str, factors[:-1])) + (" or " if len(factors) > 1 else "") + str(factors[-1])
        thinned = f"one measured sample in {listed}" + (", depending on the record" if len(factors) > 1 else "")
    cycles = [v for v in (per_cycle or {}).values() if v is not None]
    if not cycles:
        return thinned
    lo, hi = _count(min(cycles)), _count(max(cycles))
    span = lo if lo == hi else f"{lo}–{hi}"
    without = len(per_cycle) - len(cycles)
    also = f"; {without} record{'s' if without > 1 else ''} without a loading frequency" if without else ""
    return f"{span} samples per loading cycle ({thinned}{also})"


def part_rmse(summary: dict, part: str, unit: str = "", fmt: str = ".4g") -> str:
    """A part's pooled RMSE (``"0.8634 kip"``), or, where it is not finite, why: "not finite: diverged on 1 of 3
    records" (a diverged record is named, never dropped)."""
    value = summary["rmse"].get(part)
    if value is not None and math.isfinite(value):
        return f"{value:{fmt}}{unit}"
    names = summary["split"][part]
    gone = [d for d in summary.get("diverged") or [] if d["record"] in names]
    noun = "record" if len(names) == 1 else "records"
    return f"not finite: diverged on {len(gone)} of {len(names)} {noun}" if gone else "not finite"


def start_sentence(start: dict, unit: str = "") -> str:
    """Where gradient descent started (``fit.start``), in one sentence."""
    if start.get("start") != "identify":
        return ("Started from the model config's values (fit.start=model): a local descent, which can end in a local "
                "minimum.")
    edges = f"; at the edge of its box: {', '.join(start['at_bounds'])}" if start.get("at_bounds") else ""
    return (f"Started from a global search (fit.start=identify: {start['search']} + {start['refine']} on the training "
            f"records, as hybridhyst-identify; RMSE {start['rmse']:.4g}{unit}, {start['wall_s']:.2g} s{edges}).")


def diverged_sentence(summary: dict) -> str:
    """The records whose simulation diverged (kept going with ``keep_going=true``), each from its first
    non-finite sample; '' when none did."""
    gone = summary.get("diverged") or []
    if not gone:
        return ""
    message = divergence_message([Diverged(**d) for d in gone], len(summary["per_record"]),
                                 what="The fitted model's simulation", time_unit=summary["units"].get("t") or "s")
    return (f"{message}. The RMSE of a diverged record, and a pooled RMSE that includes one, is not a value (the "
            "results are written anyway: keep_going=true).")


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
        rmse = summary["per_record"][n]
        shown = f"{rmse:.3f}" if rmse is not None and math.isfinite(rmse) else "diverged"
        lines.append(f"| {n} | {cells} | {shown} |")
    return lines


def _reference_lines(summary: dict, unit: str) -> list[str]:
    ref = summary.get("reference")
    model = summary.get("model") or "this model"
    lines = [f"| model | held-out RMSE [{unit}] |", "|---|---|",
             f"| **{model} (this run)** | **{_value(summary['rmse']['held_out'])}** |"]
    if ref:
        lines += [f"| {name} (reference) | {value:.2f} |" for name, value in ref["held_out_rmse"].items()]
        lines += ["", f"Reference numbers: {ref['source']}."]
    return lines


def _value(v) -> str:
    return f"{v:.3f}" if v is not None and math.isfinite(v) else "not finite (diverged)"


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
            start_sentence(fit.get("start") or {}, f" {unit}".rstrip()),
            f"Fit: {fit['loss']} loss by gradient descent through `simulate` ({steps}; {fit['evaluations']} "
            f"simulations) on {fit['samples']} samples, {grid_words(fit['decimation'], fit.get('per_cycle'))}, in "
            f"{fit['wall_s']:.1f} s; whole run {summary['wall_s']:.1f} s.", convergence_note(fit),
            resolution_note(fit, "fit")])),
        *(["", diverged_sentence(summary)] if summary.get("diverged") else []),
        "",
        "## Fitted parameters",
        "",
        *_parameter_lines(summary["parameters"]),
        "",
        "## Held-out error per condition",
        "",
        *_record_lines(summary, summary["split"]["held_out"], unit),
        "",
        (f"Pooled RMSE (records weighted by their full-rate length): train "
         f"{part_rmse(summary, 'train', ' ' + unit, '.3f')}, held out "
         f"{part_rmse(summary, 'held_out', ' ' + unit, '.3f')}, scored on "
         f"{grid_words(summary['evaluate']['decimation'], summary['evaluate'].get('per_cycle'))}."),
        "",
        *_reference_lines(summary, unit),
        "",
        (f"![loops](loop.png)  \n*Response–excitation loops, measured (grey) and model (red): "
         f"{summary['loop_caption']}.*"),
        "",
    ]
    return atomic_write(path, "\n".join(lines))
