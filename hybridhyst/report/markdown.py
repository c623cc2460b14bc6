"""``report.md`` with its CSV tables and figures: the comparison of many ``hybridhyst-train`` runs."""

from __future__ import annotations

import math
import shlex
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from ..files import atomic_write
from .collect import collect_runs
from .figures import data_efficiency_figure, error_per_condition_figure, lambda_figure, loops_figure
from .tables import condition_stats, condition_table, error_unit, failed_table, summary_table

__all__ = ["model_reuse_sentence", "write_report"]


def model_reuse_sentence(what: str, config: str) -> str:
    """The report sentence that says where a run's fitted model is and how another app selects it
    (``config``: its config file in the run directory, e.g. ``model/discovered.yaml``)."""
    name = Path(config).stem
    return (f"The {what} model, with these values, is in `{config}` (its config) and `model.pt` (its state dict): "
            f"select it in any app with `'hydra.searchpath=[file://<this directory>]' model={name}` (with "
            "`nominal_state=<this directory>`, `hybridhyst-train` starts from exactly these values instead of "
            "identifying the nominal again).")


def _num(value) -> str:
    """A number with 4 significant digits; missing values as "—"."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "—"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{value:.4g}"
    return str(value)


def _pm(mean, std) -> str:
    return "—" if _num(mean) == "—" else f"{_num(mean)} ± {_num(std)}"


def _cell(value) -> str:
    """Text safe inside a GitHub-markdown table cell (one line, escaped pipes)."""
    return " ".join(str(value).split()).replace("|", "\\|")


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(map(_cell, header)) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(map(_cell, row)) + " |" for row in rows]


def _summary_lines(summary: pd.DataFrame, unit: str | None) -> list[str]:
    if summary.empty:
        return ["No run finished successfully."]
    u = f" [{unit}]" if unit else ""
    header = ["configuration", "residual arch", "λ_phys", "train fraction", "seeds", f"test RMSE{u}",
              f"test MAE{u}", "test NRMSE", f"val RMSE{u}", "parameters", "mean training time [s]"]
    with_failed = bool(summary["n_failed"].any())
    if with_failed:
        header.insert(5, "failed")
    rows = []
    for r in summary.itertuples():
        row = [r.configuration, _num(r.arch), _num(r.lambda_phys), _num(r.train_fraction), str(r.n_seeds),
               _pm(r.test_rmse_mean, r.test_rmse_std), _pm(r.test_mae_mean, r.test_mae_std),
               _pm(r.test_nrmse_mean, r.test_nrmse_std), _pm(r.val_rmse_mean, r.val_rmse_std),
               "—" if r.n_parameters is None or pd.isna(r.n_parameters) else str(int(r.n_parameters)),
               _num(r.train_time_s_mean)]
        if with_failed:
            row.insert(5, str(r.n_failed))
        rows.append(row)
    return _table(header, rows)


def _condition_lines(table: pd.DataFrame) -> list[str]:
    """Per-condition table with the best value per row in bold, and who wins how often."""
    if table.empty:
        return ["No per-condition test metrics in the runs."]
    configs = [c for c in table.columns if c != "best"]
    rows = []
    for condition, r in table.iterrows():
        cells = [f"**{_num(r[c])}**" if c == r["best"] else _num(r[c]) for c in configs]
        rows.append([condition, *cells, r["best"] or "—"])
    wins = table["best"].value_counts()
    tally = "; ".join(f"{name}: {n} of {len(table)}" for name, n in wins.items())
    return [*_table(["condition", *configs, "best"], rows), "", f"Best per held-out condition: {tally}."]


def _kept_start_lines(summary: pd.DataFrame) -> list[str]:
    """A sentence per configuration whose runs kept their starting weights (training never beat the start on
    validation): their errors are the starting model's, not a trained one's."""
    if summary.empty or "n_kept_start" not in summary or not summary["n_kept_start"].any():
        return []
    lines = []
    for r in summary.itertuples():
        if r.n_kept_start:
            every = "all" if r.n_kept_start == r.n_seeds else f"{r.n_kept_start} of"
            lines.append(f"- **{r.configuration}**: {every} {r.n_seeds} successful run(s) kept their starting "
                         "weights (the trained model did worse than the one it started from on the validation "
                         "records, or on the training records where there are none): these errors are the "
                         "starting model's, not a trained one's.")
    return ["## Runs that kept their starting weights", "", *lines, ""]


def _failed_lines(runs: pd.DataFrame) -> list[str]:
    failed = failed_table(runs)
    if failed.empty:
        return ["None: every run directory holds a successful run."]
    rows = [[f"`{r.path}`", r.status, r.name if isinstance(r.name, str) else "—",
             "—" if pd.isna(r.seed) else _num(r.seed), r.error] for r in failed.itertuples()]
    return _table(["run", "status", "name", "seed", "error"], rows)


def _overview(runs: pd.DataFrame, unit: str | None) -> str:
    counts = runs["status"].value_counts()
    parts = ", ".join(f"{counts.get(s, 0)} {s}" for s in ("ok", "failed", "invalid"))
    ok = runs[runs["status"] == "ok"]
    data = ", ".join(f"`{d}`" for d in dict.fromkeys(ok["data"].dropna())) or "—"
    model = ", ".join(f"`{m}`" for m in dict.fromkeys(ok["model"].dropna())) or "—"
    units = sorted(set(ok["unit_F"].dropna()))
    unit_text = (f"Errors in {unit}; " if unit else f"Errors in different force units ({', '.join(units)}); "
                 if units else "Errors in the force unit of the data (the runs state none); ")
    return (f"{len(runs)} run directories ({parts}); data {data}, nominal model {model}. {unit_text}"
            "mean ± std over seeds (std with ddof = 1, \"—\" for a single seed); NRMSE is RMSE / std of the "
            "measurement. Tables as CSV: [summary.csv](summary.csv), [per_condition.csv](per_condition.csv).")


def _figure_lines(figures: dict[str, Path | None], names: tuple[str, ...], heading: bool = True) -> list[str]:
    """Embedded figures (relative links) with captions, each under its own heading if ``heading``."""
    captions = {
        "error_per_condition": ("Test RMSE per held-out condition",
                                "Mean test RMSE per held-out condition and configuration (the best "
                                "configurations); error bars: std over seeds."),
        "loops": ("Hysteresis loops of the held-out conditions",
                  "Measured response (grey) and the prediction of the best seed (by validation error) of the "
                  "best configurations."),
        "lambda_phys": ("Physics-loss weight λ_phys",
                        "Mean ± std test RMSE over seeds vs λ_phys, settings otherwise equal; λ = 0 at the left edge."),
        "data_efficiency": ("Data efficiency",
                            "Mean ± std test RMSE over seeds vs the fraction of the training data used."),
    }
    lines = []
    for name in names:
        if figures.get(name) is not None:
            title, caption = captions[name]
            lines += [f"## {title}", ""] if heading else []
            lines += [f"![{title}](figures/{name}.png)", "", f"*{caption}*", ""]
    return lines


def _figures(runs, summary, stats, conditions, unit, fig_dir: Path, notes: list[str]) -> dict[str, Path | None]:
    """Draw every applicable figure; stale PNGs of figures that no longer apply are removed."""
    figures = {
        "loops": loops_figure(runs, summary, list(conditions.index), fig_dir / "loops.png", notes),
        "error_per_condition": error_per_condition_figure(stats, summary, unit, fig_dir / "error_per_condition.png"),
        "lambda_phys": lambda_figure(summary, unit, fig_dir / "lambda_phys.png"),
        "data_efficiency": data_efficiency_figure(summary, unit, fig_dir / "data_efficiency.png"),
    }
    for name, path in figures.items():
        if path is None:
            (fig_dir / f"{name}.png").unlink(missing_ok=True)
    return figures


def write_report(dirs: str | Path | Iterable[str | Path], out_dir: str | Path, title: str | None = None, *,
                 command: str | None = None) -> Path:
    """Compare the runs found under ``dirs`` and write the report to ``out_dir``.

    Writes ``report.md`` (GitHub markdown), ``summary.csv`` (one row per configuration, mean and std over
    seeds; errors in the force unit ``unit_F``), ``per_condition.csv`` (mean test RMSE, conditions ×
    configurations, plus the best) and ``figures/*.png``.

    Parameters
    ----------
    dirs
        Run directories or folders holding them (e.g. a Hydra ``multirun/``), searched recursively.
    out_dir
        Output folder, created if needed.
    title
        Heading of the report (default "Comparison of hybridhyst runs").
    command
        How the report was generated, for its first line (default: the equivalent ``hybridhyst-report``
        command).

    Returns
    -------
    Path
        The path of ``report.md``.

    Raises
    ------
    ValueError
        If a directory does not exist or holds no run directory.
    """
    dirs = [dirs] if isinstance(dirs, (str, Path)) else list(dirs)
    runs = collect_runs(dirs)
    summary = summary_table(runs)
    stats = condition_stats(runs, summary)
    conditions = condition_table(runs, summary)
    unit = error_unit(runs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    notes: list[str] = []
    figures = _figures(runs, summary, stats, conditions, unit, out / "figures", notes)
    atomic_write(out / "summary.csv", summary.drop(columns=["config", "hidden"], errors="ignore").to_csv(index=False))
    atomic_write(out / "per_condition.csv", conditions.to_csv())
    if command is None:
        command = shlex.join(["hybridhyst-report", *map(str, dirs), "--out", str(out)]
                             + (["--title", title] if title else []))
    u = f" [{unit}]" if unit else ""
    lines = [
        f"_Generated by `{command}` from the run directories under {', '.join(f'`{d}`' for d in dirs)}._",
        "", f"# {title or 'Comparison of hybridhyst runs'}", "", _overview(runs, unit), "",
        "## Summary per configuration", "", "Best (lowest mean test RMSE) first.", "",
        *_summary_lines(summary, unit), "",
        *_kept_start_lines(summary),
        f"## Test RMSE per held-out condition{u}", "",
        "Mean over seeds; the best configuration for each condition in **bold**.", "",
        *_condition_lines(conditions), "",
        *_figure_lines(figures, ("error_per_condition",), heading=False),
        *_figure_lines(figures, ("loops", "lambda_phys", "data_efficiency")),
        "## Failed and invalid runs", "", *_failed_lines(runs), "",
    ]
    if notes:
        lines += ["## Notes", "", *(f"- {n}" for n in notes), ""]
    return atomic_write(out / "report.md", "\n".join(lines))
