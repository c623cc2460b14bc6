"""``hybridhyst-identify``: batched global identification of a nominal model on a record set.

Default (``conf/identify.yaml``): seed 001's modified Bouc–Wen law with constant parameters identified from
the synthetic 1:3 loop at p = 0.05 MPa with 0.2 Nm noise. Writes ``summary.json`` (parameters with units,
RMSE overall and per record, identifiable combinations, uncertainty, wall time), ``model.pt`` (the fitted
model's state dict), ``loops.png``, ``report.md`` and ``config.yaml`` into the run directory
(``hydra.run.dir=...``).
"""

from __future__ import annotations

import math
import textwrap
import time
from pathlib import Path

import hydra
import numpy as np
import torch
from omegaconf import DictConfig

from ..analysis.finite import DivergenceError, check_finite, divergence_message, nonfinite_records
from ..analysis.noise import autocorrelation
from ..data.records import RecordSet
from ..identify import SearchSpace, identify
from ..report.figures import write_loops
from ..report.markdown import model_reuse_sentence
from ..simulate import simulate
from .common import (
    CONF_DIR,
    atomic_write,
    check_app,
    check_model_data,
    edge_line,
    guarded,
    hydra_entry,
    instantiate,
    load_records,
    mark_complete,
    prepare_run_dir,
    resolution_note,
    say,
    split_options,
    torch_settings,
    write_json,
    write_model,
)
from .settings import identify_settings, simulation_settings

__all__ = ["add_noise", "main", "run"]


def add_noise(records: RecordSet, noise_sd: float, seed: int) -> RecordSet:
    """Records with Gaussian noise of standard deviation ``noise_sd`` added to ``y`` (record i uses seed [seed, i])."""
    if not (math.isfinite(noise_sd) and noise_sd >= 0):
        raise ValueError(f"add_noise must be a non-negative number, got {noise_sd!r}")
    if noise_sd == 0:
        return records
    return RecordSet([r.with_noise(noise_sd, [int(seed), i]) for i, r in enumerate(records)], records.name)


def _load(cfg) -> RecordSet:
    """The records of ``cfg.data`` matching ``split.select``, with ``add_noise`` Gaussian noise added."""
    added, seed = float(cfg.add_noise or 0.0), int(cfg.seed or 0)
    records = load_records(cfg, split_options(cfg, ("select",))["select"])
    return add_noise(records, added, seed)


def _identify(model, records, cfg):
    noise = float(cfg.noise_sd or 0.0)  # the data's noise level (by default the noise added to them)
    settings = identify_settings(cfg.identify, "identify", ("noise_sd",), seed=int(cfg.seed),
                                 progress=bool(cfg.progress), noise_sd=noise or None,
                                 simulation=simulation_settings(cfg, "identify"))
    return identify(model, records, settings)


HINT = "raise simulation.substeps, narrow identify.bounds or check the model config's values"


def _diverged_everywhere(error: ValueError, records: RecordSet, cfg, run_dir: Path, start: float) -> dict:
    """Identification ended non-finite (every member of the search diverged): name the records the model
    diverges on at its config's values, and from which sample. Without ``keep_going`` that is the error (exit
    code 2); with it a warning, and ``summary.json`` and ``report.md`` say so (``status: diverged``: nothing was
    identified, so no model is written)."""
    model = instantiate(cfg.model, _convert_="all")
    with torch.no_grad():
        preds = simulate(model, list(records), settings=simulation_settings(cfg, "identify"))
    unit = (records.records[0].units.get("t") if len(records) else None) or "s"
    found = nonfinite_records(preds, records.names, [r.t for r in records])
    if not found:
        raise error
    message = f"{error}; at the model config's values {divergence_message(found, len(records), time_unit=unit)}"
    if not cfg.get("keep_going", False):
        raise DivergenceError(f"{message}; keep_going=true writes the results anyway", found) from error
    say(f"warning: {message}; results written anyway (keep_going=true)", error=True)
    summary = {"status": "diverged", "model": cfg.model.get("name") or model.name, "records": records.names,
               "error": str(error), "diverged": [d.to_dict() for d in found], "wall_s": time.perf_counter() - start}
    atomic_write(run_dir / "report.md", f"# Identification: {summary['model']}\n\nNothing was identified: {message}."
                 f" Try: {HINT}.\n")
    write_json(run_dir / "summary.json", summary)
    mark_complete(run_dir, "identify", ["config.yaml", "report.md", "summary.json"])
    return summary


def _num(v) -> str:
    return "∞" if v is None or not math.isfinite(v) else f"{v:.3g}"


def _report(summary: dict) -> str:
    lines = [f"# Identification: {summary['model']}", "",
             f"Search {summary['search']['method']} + refinement {summary['search']['refine']}; "
             f"{summary['search']['evaluations']} simulated rows; wall time {summary['wall_s']:.3g} s. "
             f"{resolution_note(summary['simulation'], 'identify')}".rstrip(), "",
             f"Pooled RMSE {summary['rmse']:.4g} {summary['response_unit']}".rstrip()
             + (f" (noise sd {summary['noise_sd']:g})" if summary['noise_sd'] else ""), "",
             f"| record | RMSE [{summary['response_unit'] or '-'}] |", "|---|---|"]
    lines += [f"| {k} | {v:.4g} |" for k, v in summary["per_record"].items()]
    lines += ["", "## Parameters", "", "| coordinate | value | sd | unit |", "|---|---|---|---|"]
    for name, value in summary["coordinates"].items():
        unit = summary["units"].get(name, "")
        lines.append(f"| {name} | {value:.6g} | {_num(summary['uncertainty'].get(name))} | {unit} |")
    lines += ["", "## Identifiable combinations (Fisher information eigen-analysis)", "",
              "| combination | eigenvalue | sd (log scale) | identifiable |", "|---|---|---|---|"]
    for c in summary["combinations"]:
        ok = "yes" if c["identifiable"] else "no"
        lines.append(f"| {c['expression']} | {c['eigenvalue']:.3g} | {_num(c['sd'])} | {ok} |")
    if summary["at_bounds"]:
        lines += ["", edge_line(summary["at_bounds"], WIDEN)]
    if coloured_note(summary):
        lines += ["", coloured_note(summary)]
    if summary["non_identifiable"]:
        lines += ["", "Not identifiable from these records (they trade off): "
                  + ", ".join(summary["non_identifiable"]) + ". Compare responses and the identifiable "
                  "combinations, not these raw values."]
    lines += ["", "![loops](loops.png)", "", model_reuse_sentence("identified", "model/identified.yaml"), ""]
    return "\n".join(lines)


def coloured_note(summary: dict) -> str:
    """Where the residual is correlated from sample to sample (mean lag-1 autocorrelation ≥ 0.3), that the ± sd
    assume independent samples ('' otherwise, or without uncertainties)."""
    lag = summary.get("residual_lag_1")
    if lag is None or not lag >= 0.3 or not summary.get("uncertainty"):
        return ""
    return (f"The residual's lag-1 autocorrelation is {lag:.2f}: the ± sd assume independent samples, and with noise "
            "(or a model error) correlated in time the records hold fewer independent samples than samples, so the "
            "true uncertainties are larger.")


# the keys that widen identification's search box, for the sentence on coordinates at its edge
WIDEN = ("identify.bounds={name: [low, high]}, identify.box_factor, or identify.recentre=N to search again around "
         "the edge")


def summary_lines(summary: dict, run_dir, reuse: str | None = None) -> list[str]:
    """The terminal summary: the RMSE, the identified coordinates with units, box edges, the override that
    selects the identified model in another app (``reuse``), where the report is."""
    unit = f" {summary['response_unit']}".rstrip()
    noise = f" (noise sd {summary['noise_sd']:g})" if summary["noise_sd"] else ""
    lines = [f"identify: {summary['model']} on {len(summary['records'])} record(s): RMSE {summary['rmse']:.4g}{unit}"
             f"{noise}, {summary['search']['identify_wall_s']:.3g} s"]
    sds = summary["uncertainty"] or {}
    coords = [f"{n} = {v:.4g}{f' ± {sds[n]:.2g}' if n in sds else ''} {summary['units'].get(n, '')}".rstrip()
              for n, v in summary["coordinates"].items()]
    lines += textwrap.wrap(", ".join(coords), 116, initial_indent="  ", subsequent_indent="  ")
    if summary["non_identifiable"]:
        traded = ", ".join(summary["non_identifiable"])
        lines.append(f"  not identifiable from these records (they trade off): {traded}")
    if summary["at_bounds"]:
        lines.append("  " + edge_line(summary["at_bounds"], WIDEN))
    for note in (coloured_note(summary), resolution_note(summary["simulation"], "identify")):
        lines += textwrap.wrap(note, 116, initial_indent="  ", subsequent_indent="  ") if note else []
    if reuse:
        lines.append(f"  the identified model in another app: {reuse}")
    lines.append(f"  report: {Path(run_dir) / 'report.md'}")
    return lines


def _summary(cfg, model, result, records) -> dict:
    fisher = result.fisher
    units = {c.name: c.unit for c in SearchSpace(model).coordinates}
    return {
        "model": cfg.model.get("name") or model.name,
        "records": records.names,
        "parameters": result.parameters,
        "coordinates": result.x,
        "units": units,
        "rmse": result.rmse,
        "response_unit": records.records[0].units.get("y", "") if len(records) else "",
        "per_record": result.per_record,
        "at_bounds": result.at_bounds,
        "noise_sd": float(cfg.get("noise_sd") or 0.0),
        "identifiable": result.identifiable,
        "non_identifiable": fisher.non_identifiable if fisher else [],
        "combinations": fisher.combinations if fisher else [],
        "uncertainty": result.uncertainty,
        "search": {"method": result.search, "refine": cfg.identify.refine, "evaluations": result.evaluations,
                   "identify_wall_s": result.wall_s},
        "simulation": {"substeps": result.substeps,
                       "resolution": None if math.isnan(result.resolution) else result.resolution},
        "history": result.history,
    }


def run(cfg: DictConfig) -> dict:
    """Identify, write the run directory, return the summary (also ``summary.json``)."""
    check_app(cfg, "identify")
    start = time.perf_counter()
    run_dir = prepare_run_dir(cfg)
    with torch_settings(cfg.dtype, cfg.get("threads"), cfg.get("seed")):
        records = _load(cfg)
        model = instantiate(cfg.model, _convert_="all")
        note = check_model_data(model, records)
        if note:  # records without units: the model's are assumed
            say(note)
        try:
            result = _identify(model, records, cfg)
        except ValueError as e:
            if "ended non-finite" not in str(e):
                raise
            return _diverged_everywhere(e, records, cfg, run_dir, start)
        with torch.no_grad():
            preds = simulate(model, list(records), settings=simulation_settings(cfg, "identify").at(
                result.substeps))
        unit = (records.records[0].units.get("t") if len(records) else None) or "s"
        diverged = check_finite(preds, records.names, [r.t for r in records], keep_going=bool(cfg.get("keep_going")),
                                hint=HINT, what="the identified model's simulation", time_unit=unit,
                                warn=lambda text: say(text, error=True))
        summary = _summary(cfg, model, result, records)
        summary["diverged"] = [d.to_dict() for d in diverged]
        lags = [autocorrelation(r.scored(np.asarray(r.y) - np.asarray(p)[:, 0]))["lag_1"]
                for r, p in zip(records, preds) if np.all(np.isfinite(np.asarray(p)))]
        summary["residual_lag_1"] = float(np.nanmean(lags)) if lags else None
    shown = list(records)[: max(1, int(cfg.report.max_figures))]
    write_loops(run_dir / "loops.png", shown, {"identified": list(preds)[: len(shown)]}, measured="data")
    # the fitted nominal (model.pt, model/identified.yaml): hybridhyst-train starts a hybrid from it
    reuse = write_model(run_dir, model, "identified", "identified by hybridhyst-identify", list(records))
    summary["wall_s"] = time.perf_counter() - start
    atomic_write(run_dir / "report.md", _report(summary))
    write_json(run_dir / "summary.json", summary)
    mark_complete(run_dir, "identify", ["config.yaml", "loops.png", "model.pt", "model/identified.yaml", "report.md",
                                        "summary.json"])
    say("\n".join(summary_lines(summary, run_dir, reuse)))
    return summary


@hydra.main(config_path=CONF_DIR, config_name="identify", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    guarded(run, cfg)


def main() -> None:
    """Console entry point ``hybridhyst-identify`` (Hydra overrides on the command line)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
