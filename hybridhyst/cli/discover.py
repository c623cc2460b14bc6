"""``hybridhyst-discover``: the closed loop on measured data (``hybridhyst.discover``).

Default (``conf/discover.yaml`` with ``conf/data/discover/brfd.yaml``): the measured BRFD friction damper at
36 lb band tension from a Coulomb + viscous + Dahl nominal; train on the 0.5 and 1.5 in characterisation tests,
validate on the 1 in tests, test on the earthquake records. Writes ``discovery.json``, ``report.md``,
``residuals.png``, ``loops.png`` and ``config.yaml`` into the run directory (``hydra.run.dir=...``) and ends
with a few lines on the terminal: the effects named, the validation and test RMSE before → after.
"""

from __future__ import annotations

import math
from pathlib import Path

import hydra
from omegaconf import DictConfig

from ..data.decimate import decimate_all, decimation_factors
from ..data.records import RecordSet
from ..data.splits import Split
from ..discover import DiscoverSettings, discover
from ..discover.report import check_discovery, write_discovery
from ..discover.result import AFTER_ADDED, disagreement_line
from .common import (
    CONF_DIR,
    check_app,
    check_model_data,
    edge_line,
    guarded,
    hydra_entry,
    instantiate,
    load_records,
    mark_complete,
    prepare_run_dir,
    say,
    split_options,
    to_plain,
    torch_settings,
    write_model,
)
from .settings import config_block, simulation_settings

__all__ = ["load_split", "main", "run", "summary_lines"]


def load_split(cfg: DictConfig) -> tuple[RecordSet, Split]:
    """The records of ``split.select``, thinned (``cfg.thinning``), and their split (``split.held_out`` ->
    test, ``split.val`` -> validation, the rest -> training)."""
    split = split_options(cfg)
    th = cfg.thinning
    samples_per_cycle, downsample, frequency = th.samples_per_cycle, th.downsample, th.frequency_condition
    records = load_records(cfg, split["select"])
    factors = decimation_factors(records, samples_per_cycle, downsample, frequency, "thinning.frequency_condition")
    records = RecordSet(decimate_all(records, factors, "discovery"), records.name)
    return records, records.split(held_out=split["held_out"], val=split["val"])


def summary_lines(report: dict, unit: str, run_dir: Path | str, reuse: str | None = None) -> list[str]:
    """A few lines for the terminal: the effects named (added, removed, the best one not accepted), the
    validation, test and training RMSE before -> after in the response's unit, the override that selects the
    discovered model in another app (``reuse``) and where the report is."""
    def fmt(v):
        return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"

    def name(step):
        trends = step.get("trends")
        if isinstance(trends, dict) and trends:
            return f"{step['effect']} ({', '.join(f'{k} {v}' for k, v in trends.items())})"
        return str(step["effect"])

    u = f" {unit}" if unit else ""
    added = [name(s) for s in report.get("steps") or [] if s.get("accepted", True)]
    removed = [str(s["effect"]) for s in report.get("removed") or []]
    rejected = [s for s in report.get("rejected") or [] if s.get("kind") != "trend"
                and s.get("when") != AFTER_ADDED]  # the best candidate of the step that stopped the loop
    line = "discovery: added " + ("; ".join(added) if added else "nothing")
    line += f"; removed {', '.join(removed)}" if removed else ""
    if rejected:
        why = rejected[0].get("refused_by")
        line += f"; best remaining candidate not accepted: {name(rejected[0])}" + (
            f" ({'; '.join(why)})" if why else "")
    lines = [line]
    lines += [f"  {text}" for text in
              (disagreement_line(s, unit) for s in (report.get("steps") or []) + (report.get("rejected") or []))
              if text]
    first = (report.get("before") or {}).get("first_fit") or {}
    if first.get("at_bounds") and first.get("recentred", 0) >= first.get("recentre", 0) > 0:
        # the re-centring ran to its cap with values still at an edge: the declared values are far off
        lines.append("  the nominal's first fit: " + edge_line(
            first["at_bounds"], "discover.identify.recentre=N, discover.identify.bounds={name: [low, high]}"))
    if report.get("stopped") == "max_steps":
        n = report.get("settings", {}).get("max_steps")
        lines.append(f"  stopped at the cap on effects added (discover.max_steps={n}), not by the acceptance rule: "
                     "raise it to let the loop go on")
    b, a = report["before"], report["after"]
    v = report.get("validation") or {}
    if v.get("kind") == "loco":
        lines.append(f"  leave-one-condition-out RMSE {fmt(v['rmse_before'])} -> {fmt(v['rmse_after'])}{u}")
    elif "loco" in (v.get("parts_after") or {}):
        lines.append(f"  leave-one-condition-out RMSE {fmt(v['parts_before']['loco'])} -> "
                     f"{fmt(v['parts_after']['loco'])}{u}")
    for key, what in (("val_rmse", "validation"), ("test_rmse", "test"), ("train_rmse", "training")):
        if b.get(key) is not None or a.get(key) is not None:
            lines.append(f"  {what} RMSE {fmt(b.get(key))} -> {fmt(a.get(key))}{u}")
    if report.get("refit"):
        lines.append("  (validation: the training-only fits; test and training: both refitted on training + "
                     "validation records)")
    lines += [f"  {text}" for text in leftover_lines(report)]
    if reuse:
        lines.append(f"  the discovered model in another app: {reuse}")
    lines.append(f"  report: {Path(run_dir) / 'report.md'}")
    return lines


def leftover_lines(report: dict) -> list[str]:
    """What the terminal says about the structure left: the flag (report.md's "What is left"), and where the noise
    level was estimated while the final residual is coloured, that the estimate may be low."""
    u = report.get("unexplained") or {}
    lines = []
    if u.get("structure_flagged"):
        lines.append("structure is left that no library effect explains: see report.md's 'What is left' and "
                     "residuals.png")
    noise, lag = report.get("noise") or {}, (u.get("whiteness") or {}).get("lag_1")
    if noise.get("source") != "given" and lag is not None and lag >= 0.3:
        lines.append(f"the noise level (sd {float(noise.get('sd') or math.nan):.4g}) was estimated from "
                     "sample-to-sample differences, which assumes white noise; the final residual's lag-1 "
                     f"autocorrelation is {lag:.2f}: if the measurement noise is coloured, the estimate is low (the "
                     "rule then takes differences within the noise for real ones): give the level as "
                     "discover.noise_sd=...")
    return lines


def _workers(d) -> int:
    """``discover.workers``: a number, or auto (one per core this process may use)."""
    from ..simulate.fast.build import row_threads

    w = d.get("workers", 1)
    if str(w) == "auto":
        return row_threads()
    if not isinstance(w, int) or isinstance(w, bool) or w < 1:
        raise ValueError(f"discover.workers must be a whole number >= 1 or auto, got {w!r}")
    return w


def _settings(cfg: DictConfig) -> DiscoverSettings:
    """``DiscoverSettings`` from ``cfg.discover`` (through the one typed schema: a misspelt key or a wrong type is a
    one-line error naming it), the app's split, progress, seed and ``simulation:`` block."""
    d = cfg.discover
    block = {k: v for k, v in config_block(d, "discover.yaml", "discover").items() if k not in ("identify", "workers")}
    first_fit = {**(to_plain(d.identify) or {}), "seed": int(cfg.seed)}
    return DiscoverSettings.from_config(
        block, "discover", split=split_options(cfg, ("held_out", "val")), progress=bool(cfg.progress),
        workers=_workers(d), identify_options=first_fit, simulation=simulation_settings(cfg, "discover"))


def run(cfg: DictConfig) -> dict:
    """Discover, write the run directory, print a short summary, return ``discovery.json``'s content."""
    check_app(cfg, "discover")
    run_dir = prepare_run_dir(cfg)
    with torch_settings(cfg.dtype, cfg.get("threads"), cfg.get("seed")):
        records, parts = load_split(cfg)
        settings = _settings(cfg)  # its conditions are checked by discover, before any fitting
        model = instantiate(cfg.model, _convert_="all").double()
        note = check_model_data(model, records)  # before the first fit (the loop checks the conditions again)
        if note:  # records without units: the model's are assumed
            say(note)
        result = discover(records, model, settings=settings)
    check_discovery(result, keep_going=bool(cfg.get("keep_going", False)),
                    time_unit=records.records[0].units.get("t") or "s", warn=lambda text: say(text, error=True))
    unit = records.records[0].units.get("y", "")
    title = cfg.title or f"Discovery: {cfg.model.get('name') or model.name} nominal on {records.name}"
    reuse = write_model(run_dir, result.model, "discovered", "discovered by hybridhyst-discover", records.records)
    result.report["model_config"] = "model/discovered.yaml"
    write_discovery(result, run_dir, title=title, unit=unit)
    mark_complete(run_dir, "discover", ["config.yaml", "discovery.json", "report.md", "residuals.png", "loops.png",
                                        "model.pt", "model/discovered.yaml"])
    say("\n".join(summary_lines(result.report, unit, run_dir, reuse)))
    return result.report


@hydra.main(config_path=CONF_DIR, config_name="discover", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    guarded(run, cfg)


def main() -> None:
    """Console entry point ``hybridhyst-discover`` (Hydra overrides on the command line)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
