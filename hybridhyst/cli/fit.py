"""``hybridhyst-fit``: fit a nominal model to measured records and score it on held-out conditions.

Default (``conf/fit.yaml``): the Coulomb + viscous + Dahl friction model (``model=dahl_friction``) fitted
to the BRFD characterisation tests at 36 lb band tension, trained on the 0.5 and 1.5 in tests and scored
on the held-out 1 in tests. Writes ``summary.json``, ``report.md``, ``loop.png``, ``predictions.parquet``
and ``config.yaml`` into the run directory (``hydra.run.dir=...``).
"""

from __future__ import annotations

import math
import textwrap
import time
from pathlib import Path

import hydra
import numpy as np
import pandas as pd
from omegaconf import DictConfig

from ..analysis.finite import check_finite
from ..data.decimate import decimate, decimate_all, decimation_factors
from ..identify.gradient import fit_gradient
from ..simulate import SimulationSettings, simulate_resolved
from ..simulate.api import MAX_SUBSTEPS_SCORED
from ..training.config import config_number
from .common import (
    CONF_DIR,
    atomic_write,
    check_app,
    check_model_data,
    guarded,
    hydra_entry,
    instantiate,
    load_records,
    mark_complete,
    prepare_run_dir,
    resolution_note,
    say,
    split_options,
    to_plain,
    torch_settings,
    write_json,
    write_model,
)
from .fit_report import (
    _fmt,
    convergence_note,
    diverged_sentence,
    loop_caption,
    part_rmse,
    start_sentence,
    write_loop_figure,
    write_report,
)
from .settings import identify_start, simulation_settings, start_settings

__all__ = ["decimation_factors", "load_split", "main", "run"]

MAX_LOOPS = 6  # panels in loop.png



def load_split(cfg: DictConfig):
    """Load the records of ``cfg.data``, keep ``split.select`` and split off ``split.held_out``.

    Returns
    -------
    (train, held_out) record sets. A ``ValueError`` names a condition or value that matches nothing, or
    says that nothing is held out.
    """
    split = split_options(cfg, ("select", "held_out"))
    if not split["held_out"]:
        raise ValueError("no held-out records: set split.held_out to the conditions to score on, e.g. "
                         "'split.held_out=[{amplitude_in: [1.0]}]'")
    records = load_records(cfg, split["select"])
    train, _, test = records.split(held_out=split["held_out"])
    return train, test


def _evaluate(model, records, factors, sim: SimulationSettings) -> tuple[dict, dict, list]:
    """Simulate every record on its evaluation grid; per-record RMSE and the pooled RMSE.

    The pooled value weights each record by its full-rate sample count, so it estimates the RMSE over
    all original samples (as the BRFD reference numbers are computed). The records are simulated at the
    sub-steps they need, from the fit's (``simulate_resolved``: a held-out condition may make a state stiffer
    than any training one); the scores say how many (``substeps``).
    """
    data = [decimate(r, factors[r.name]) for r in records]
    preds, substeps, _ = simulate_resolved(model, data, settings=sim)
    per, frames = {}, []
    sq, n = 0.0, 0
    for r_full, r, p in zip(records, data, preds):
        y_model = p[:, 0].cpu().numpy()
        # a diverged record's error is not a value (``_check_finite`` names it), nor is a pooled one holding it
        mse = float(np.mean((y_model - r.y) ** 2)) if np.isfinite(y_model).all() else math.nan
        per[r.name] = math.sqrt(mse)
        sq += mse * len(r_full)
        n += len(r_full)
        frames.append(pd.DataFrame({"record": r.name, "t": r.t, "x": r.x, "y": r.y, "y_model": y_model}))
    pooled = math.sqrt(sq / n) if n else float("nan")
    return {"pooled": pooled, "per_record": per, "substeps": substeps}, {r.name: f for r, f in zip(data, frames)}, data


def _conditions_table(records, keys) -> dict[str, dict]:
    """{record: {condition: value}} for ``keys`` (None: every condition of the records, in order of appearance)."""
    if keys is None:
        keys = list(dict.fromkeys(k for r in records for k in r.conditions))
    return {r.name: {k: r.conditions.get(k) for k in keys} for r in records}


START = ("identify", "model")  # fit.start: a global search first, or the model config's values


def _start(model, data, cfg) -> dict:
    """Where gradient descent starts (``fit.start``): ``identify``, the batched global search of
    ``hybridhyst-identify`` (conf/identify.yaml's ``identify:`` block with the fit's simulation settings, no Fisher
    analysis, at ``simulation.substeps``, then ``fit.identify``'s keys; as ``hybridhyst-train``'s
    ``nominal_init``) on the fit's grid ``data``, which fits ``model`` in place; or ``model``, the model config's
    values. Local descent from a config's values can end in a local minimum (on MR damper loops: negative damping
    at 3.4 times the error the search reaches). Returns what the summary says about the start."""
    fit = cfg.fit
    start = str(fit.get("start", "identify"))
    if start not in START:
        raise ValueError(f"unknown fit.start {start!r}; choose 'identify' (a global search first) or 'model' (the "
                         "model config's values)")
    if start == "model":
        return {"start": "model"}
    # at the fit's starting sub-steps, without step doubling of its own: the descent resolves them from there (a
    # search at each finer step would cost three times as much on the BRFD loops, for a start)
    settings = start_settings(simulation_settings(cfg, "fit"), fit.get("identify"), "fit.identify")
    result = identify_start(model, data, settings, "fit.identify", "fit.start=model starts from the model config's "
                            "values", seed=int(cfg.seed), progress=bool(cfg.progress))
    return {"start": "identify", "search": result.search, "refine": str(settings.refine), "rmse": result.rmse,
            "evaluations": result.evaluations, "wall_s": result.wall_s, "substeps": result.substeps,
            "at_bounds": dict(result.at_bounds)}


def _per_cycle(records, factors: dict, frequency) -> dict:
    """Samples per loading cycle each record is simulated with: ``1 / (dt · f · factor)`` for a record with a
    positive frequency condition ``f`` [Hz], None for one without (what the report says about the grid)."""
    out = {}
    for r in records:
        f = r.conditions.get(frequency) if frequency else None
        ok = isinstance(f, (int, float)) and not isinstance(f, bool) and f > 0
        out[r.name] = 1.0 / (r.dt * f * factors[r.name]) if ok else None
    return out


def _descent_settings(fit) -> tuple[int, float, int]:
    """``fit.steps`` and ``fit.lbfgs_steps`` (whole numbers >= 0) and ``fit.lr`` (> 0: a negative rate climbs the
    loss and still ends "ok"), each named with its fix when it is not."""
    steps = config_number(fit, "steps", "fit.steps", whole=True)
    lbfgs_steps = config_number(fit, "lbfgs_steps", "fit.lbfgs_steps", whole=True)
    lr = config_number(fit, "lr", "fit.lr")
    for key, value in (("fit.steps", steps), ("fit.lbfgs_steps", lbfgs_steps)):
        if value < 0:
            raise ValueError(f"config key {key} must be >= 0, got {value}: give {key}=<steps> (0: none)")
    if not lr > 0:
        raise ValueError(f"config key fit.lr must be > 0, got {lr:g}: a rate <= 0 does not descend (a negative one "
                         "climbs the loss); give fit.lr=<rate>, e.g. fit.lr=0.05")
    return steps, lr, lbfgs_steps


def _fit(model, train, cfg) -> tuple:
    fit = cfg.fit
    steps, lr, lbfgs_steps = _descent_settings(fit)
    factors = decimation_factors(train, fit.samples_per_cycle, fit.downsample, fit.frequency_condition,
                                 "fit.frequency_condition")
    start = _start(model, decimate_all(train, factors, "the fit's start (fit.start=identify)"), cfg)
    result = fit_gradient(
        model, list(train), steps=steps, lr=lr, downsample=factors, loss=fit.loss,
        lbfgs_steps=lbfgs_steps, progress=bool(cfg.progress),
        simulation=simulation_settings(cfg, "fit"), resolve=bool(fit.resolve),
        max_substeps=int(fit.max_substeps),
    )
    return result, factors, start


def _reference(cfg) -> dict | None:
    """The reference numbers of ``cfg.reference`` when the run uses the protocol they were measured with."""
    from ..data.splits import as_queries

    ref = cfg.get("reference")
    if not ref:
        return None
    protocol = to_plain(ref.protocol)
    split = split_options(cfg, ("select", "held_out"))
    used = {"data": to_plain(cfg.data), "select": split["select"], "held_out": split["held_out"]}
    if "held_out" in protocol:
        protocol["held_out"] = as_queries(protocol["held_out"])
    if any(used[k] != v for k, v in protocol.items()):
        return None
    return {"source": ref.source, "held_out_rmse": to_plain(ref.held_out_rmse)}


def _score(model, train, held_out, cfg, substeps: int) -> tuple[dict, dict, dict]:
    """RMSE on the evaluation grid (finer than the fit's, with the fit's sub-steps per sample) for both parts:
    (scores, prediction frames, decimation factors)."""
    ev = cfg.evaluate
    sim = simulation_settings(cfg, "fit").at(substeps)
    scores, frames, factors = {}, {}, {}
    for part, records in (("train", train), ("held_out", held_out)):
        f = decimation_factors(records, ev.samples_per_cycle, ev.downsample, cfg.fit.frequency_condition,
                               "fit.frequency_condition")
        scores[part], part_frames, _ = _evaluate(model, list(records), f, sim)
        frames.update({k: v.assign(split=part) for k, v in part_frames.items()})
        factors.update(f)
    return scores, frames, factors


def _check_finite(frames: dict, train, held_out, cfg) -> list:
    """Which scored records diverged (non-finite model response), from which sample: an error naming them (exit
    code 2), or with ``keep_going`` a warning (the summary and report name them; their RMSE is not finite)."""
    names = [*train.names, *held_out.names]
    unit = (train[0].units.get("t") if len(train) else None) or "s"
    return check_finite([frames[n]["y_model"].to_numpy() for n in names], names,
                        [frames[n]["t"].to_numpy() for n in names], splits=[frames[n]["split"].iloc[0] for n in names],
                        keep_going=bool(cfg.get("keep_going", False)),
                        hint=f"it diverges there even at the most sub-steps scoring tries ({MAX_SUBSTEPS_SCORED} per "
                             "sample): check the fitted parameters (fit.start, fit.lr) or sample finer",
                        what="the fitted model's simulation", time_unit=unit, warn=lambda text: say(text, error=True))


def _chosen_loops(chosen, names: list[str]) -> list[str] | None:
    """``report.loop_records`` (a name or a list) as a list, checked against the records' ``names`` before any
    fitting; None: the default (the held-out records)."""
    if chosen is None:
        return None
    picked = [chosen] if isinstance(chosen, str) else [str(n) for n in chosen]
    unknown = [n for n in picked if n not in names]
    if unknown or not picked:
        raise ValueError(f"report.loop_records {unknown or picked!r}: give record names of {sorted(names)} "
                         "(null: the held-out records)")
    return picked


def _worst_first(held_out: list[str], per_record: dict) -> list[str]:
    """The held-out records drawn by default: the worst first, at most ``MAX_LOOPS`` (a large miss, or a diverged
    record, is never left out for a good fit)."""
    return sorted(held_out, key=lambda n: -math.inf if math.isnan(per_record[n]) else -per_record[n])[:MAX_LOOPS]


def _summary(cfg, model, train, held_out, result, fit_factors, scores, eval_factors, start) -> dict:
    frequency = cfg.fit.frequency_condition
    fit_info = {"start": start, "loss": cfg.fit.loss, "final_loss": result.loss, "steps": result.steps,
                "samples": result.n_samples, "evaluations": result.evaluations, "decimation": fit_factors,
                "per_cycle": _per_cycle(train, fit_factors, frequency), "wall_s": result.wall_s,
                "substeps": result.substeps, "resolution": result.resolution if cfg.fit.resolve else None,
                "converged": result.converged, "stop": result.stop, "last_change": result.last_change}
    return {
        "parameters": model.parameter_table(),
        "rmse": {"train": scores["train"]["pooled"], "held_out": scores["held_out"]["pooled"]},
        "per_record": {**scores["train"]["per_record"], **scores["held_out"]["per_record"]},
        "split": {"train": train.names, "held_out": held_out.names},
        "conditions": _conditions_table([*train, *held_out], to_plain(cfg.report.condition_columns)),
        "units": {"x": train[0].units.get("x", ""), "y": train[0].units.get("y", ""),
                  "t": train[0].units.get("t") or "s"},
        "fit": fit_info,
        "evaluate": {"samples_per_cycle": cfg.evaluate.samples_per_cycle, "decimation": eval_factors,
                     "per_cycle": _per_cycle([*train, *held_out], eval_factors, frequency),
                     "substeps": {part: scores[part]["substeps"] for part in ("train", "held_out")}},
        "model": cfg.model.get("name") or model.name,
        "reference": _reference(cfg),
    }


def run(cfg: DictConfig) -> dict:
    """Fit, evaluate, and write the run directory; returns the summary dict (also ``summary.json``)."""
    check_app(cfg, "fit")
    start = time.perf_counter()
    run_dir = prepare_run_dir(cfg)
    with torch_settings(cfg.dtype, cfg.get("threads"), cfg.get("seed")):
        train, held_out = load_split(cfg)
        chosen = _chosen_loops(to_plain(cfg.report.get("loop_records")), [*train.names, *held_out.names])
        model = instantiate(cfg.model, _convert_="all")
        note = check_model_data(model, [*train, *held_out])
        if note:  # records without units: the model's are assumed
            say(note)
        result, fit_factors, start_info = _fit(model, train, cfg)
        scores, frames, eval_factors = _score(model, train, held_out, cfg, result.substeps)
        diverged = _check_finite(frames, train, held_out, cfg)
    summary = _summary(cfg, model, train, held_out, result, fit_factors, scores, eval_factors, start_info)
    summary["diverged"] = [d.to_dict() for d in diverged]
    loop_names = chosen or _worst_first(held_out.names, summary["per_record"])
    unit = f" {summary['units']['y']}".rstrip()
    gone = {d["record"]: d for d in summary["diverged"]}
    write_loop_figure(run_dir / "loop.png", [frames[n] for n in loop_names], summary["units"],
                      [f"{n} (diverged from sample {gone[n]['sample']})" if n in gone else
                       f"{n} (RMSE {summary['per_record'][n]:.3g}{unit})" for n in loop_names])
    table = pd.concat(frames.values(), ignore_index=True)
    atomic_write(run_dir / "predictions.parquet", lambda p: table.to_parquet(p, index=False))
    summary["wall_s"] = time.perf_counter() - start
    summary["loop_records"] = loop_names
    summary["loop_caption"] = loop_caption(loop_names, held_out.names, chosen is not None)
    summary["reuse"] = write_model(run_dir, model, "fitted", "fitted by hybridhyst-fit", [*train, *held_out])
    write_report(run_dir / "report.md", summary)
    write_json(run_dir / "summary.json", summary)
    mark_complete(run_dir, "fit", ["config.yaml", "predictions.parquet", "report.md", "summary.json", "loop.png",
                                   "model.pt", "model/fitted.yaml"])
    say("\n".join(summary_lines(summary, run_dir)))
    return summary


def summary_lines(summary: dict, run_dir) -> list[str]:
    """The terminal summary: training and held-out RMSE in the data's unit, the fitted values, the report."""
    unit = f" {summary['units']['y']}".rstrip()
    fit = summary["fit"]
    steps = " + ".join(f"{n} {kind}" for kind, n in fit["steps"].items() if n)
    lines = [f"fit: {summary['model']}: RMSE training {part_rmse(summary, 'train', unit)}, held-out "
             f"{part_rmse(summary, 'held_out', unit)} "
             f"({steps} steps{', converged' if fit.get('converged') else ''}, {fit['wall_s']:.3g} s)"]
    lines += textwrap.wrap(start_sentence(fit.get("start") or {}, unit), 116, initial_indent="  ",
                           subsequent_indent="  ")
    if summary.get("diverged"):
        lines += textwrap.wrap(diverged_sentence(summary), 116, initial_indent="  ", subsequent_indent="  ")
    values = [f"{e}.{p} = {_fmt(info['value'])}" + (f" {info['unit']}" if isinstance(info["value"], float) else "")
              for e, params in summary["parameters"].items() for p, info in params.items() if not info.get("fixed")]
    lines += textwrap.wrap(", ".join(values), 116, initial_indent="  ", subsequent_indent="  ")
    for note in (convergence_note(fit) if not fit.get("converged") else "", resolution_note(fit, "fit")):
        lines += textwrap.wrap(note, 116, initial_indent="  ", subsequent_indent="  ") if note else []
    if summary.get("reuse"):
        lines.append(f"  the fitted model in another app: {summary['reuse']}")
    lines.append(f"  report: {Path(run_dir) / 'report.md'}")
    return lines


@hydra.main(config_path=CONF_DIR, config_name="fit", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    guarded(run, cfg)


def main() -> None:
    """Console entry point ``hybridhyst-fit`` (Hydra overrides on the command line)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
