"""``discovery.json`` and ``report.md`` of a discovery run, with residual-vs-feature and loop figures."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..analysis.finite import Diverged, check_finite, nonfinite_records
from ..files import atomic_write, write_json
from ..physics.parameters import render_unit
from ..report.figures import write_loops
from ..report.markdown import model_reuse_sentence
from .diagnose import FEATURE_UNITS, FEATURES, features, shared_controls
from .leftover import FLAG_SHARE
from .loop import DiscoveryResult
from .result import AFTER_ADDED, disagreement_line

__all__ = ["change_sentence", "check_discovery", "diverged_records", "write_discovery"]

STAGES = {"after": "discovered model", "before": "nominal"}  # the models whose predictions a discovery keeps


def _simulated(result: DiscoveryResult, stage: str) -> tuple[list, list, list, list]:
    """``stage``'s predictions of every record it simulated, with the records' names, times and splits."""
    names, preds, times, splits = [], [], [], []
    for split, records in result.splits.items():
        for r, p in zip(records, (result.predictions.get(stage) or {}).get(split) or []):
            names.append(r.name)
            preds.append(p)
            times.append(r.t)
            splits.append(split)
    return preds, names, times, splits


def diverged_records(result: DiscoveryResult, stage: str = "after") -> list[Diverged]:
    """The records on which ``stage``'s model ("after": the discovered one, "before": the nominal it is compared
    with) simulated non-finite values, each from its first non-finite sample, split by split ("train", "val",
    "test")."""
    preds, names, times, splits = _simulated(result, stage)
    return nonfinite_records(preds, names, times, splits)


def _diverged_report(result: DiscoveryResult) -> dict:
    return {stage: [d.to_dict() for d in diverged_records(result, stage)] for stage in STAGES}


def check_discovery(result: DiscoveryResult, *, keep_going: bool = False, time_unit: str = "s", warn=None
                    ) -> list[Diverged]:
    """The app's check of what a discovery simulated (``analysis.finite.check_finite``): the discovered model's
    predictions of every record (training, validation, test). A record it diverged on is a ``DivergenceError``
    naming it and the sample it diverged from (exit code 2 in the app), or with ``keep_going`` a warning through
    ``warn``. The nominal's own divergences ("before") are a finding of the comparison, not a failure of the run:
    ``report.md`` and ``discovery.json``'s ``diverged`` name them either way."""
    preds, names, times, splits = _simulated(result, "after")
    result.report["diverged"] = _diverged_report(result)
    return check_finite(preds, names, times, splits=splits, keep_going=keep_going, time_unit=time_unit,
                        what="the discovered model's simulation", warn=warn,
                        hint="raise simulation.substeps, check the model's parameters or leave those records out")


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    return f"{v:.4g}" if isinstance(v, (int, float)) else str(v)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def residual_figure(result: DiscoveryResult, path: Path) -> Path:
    """Training residual (measured − model) against each feature, before (top) and after (bottom)."""
    plt = _pyplot()
    train = result.splits["train"]
    controls = shared_controls(train)  # a panel per control channel: a residual that follows the coil current
    names = [f for f in FEATURES if f != "sign_v"] + [f"control:{c}" for c in controls]
    fig, axes = plt.subplots(2, len(names), figsize=(min(2.2 * len(names), 16), 4.6), dpi=90, squeeze=False)
    units = {"x": train[0].units.get("x") or "x", "t": train[0].units.get("t") or "s"} if train else None
    labels = {**{f: render_unit(FEATURE_UNITS[f], units) for f in FEATURES},
              **{f"control:{c}": train[0].units.get(c) or "-" for c in controls}}
    for row, stage in enumerate(("before", "after")):
        feats = [features(r.t, r.x, {c: r.controls[c] for c in controls}) for r in train]
        res = [r.scored(np.asarray(r.y) - p) for r, p in zip(train, result.predictions[stage]["train"])]
        for col, name in enumerate(names):
            ax = axes[row, col]
            f = np.concatenate([r.scored(fe[name]) for fe, r in zip(feats, train)])
            r = np.concatenate(res)
            step = max(1, len(f) // 4000)
            ax.plot(f[::step], r[::step], ".", ms=1.2, alpha=0.4, color="C0" if row == 0 else "C2")
            eta = result.report[stage]["diagnostics"]["dependence"].get(name, 0.0)
            ax.set_title(f"{name} (η²={eta:.2f})", fontsize=7)
            ax.set_xlabel(f"{name} [{labels[name]}]", fontsize=7)
            ax.tick_params(labelsize=6)
            if col == 0:
                unit = train[0].units.get("y") if train else None
                ax.set_ylabel(f"residual, {stage}" + (f" [{unit}]" if unit else ""), fontsize=7)
    fig.tight_layout()
    atomic_write(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)
    return path


def loops_figure(result: DiscoveryResult, path: Path, limit: int = 6) -> Path:
    """Held-out (test) records, or training ones without a test split: measured, before and after
    (``write_loops``, axes in the records' units)."""
    split = "test" if result.splits["test"] else "train"
    recs = list(result.splits[split][:limit])
    predictions = {stage: list(result.predictions[stage][split][: len(recs)]) for stage in ("before", "after")}
    styles = {"before": {"color": "C0", "ls": "--"}, "after": {"color": "C3"}}
    return write_loops(path, recs, predictions, styles=styles)


def _ic(ev: dict, when: str):
    return next((ev[f"{c}_{when}"] for c in ("bic", "aic") if f"{c}_{when}" in ev), None)


def _other_parts(ev: dict, unit: str, arrow: bool = False) -> str:
    """The errors besides the headline one that a change was judged on (``validation: both``), in words."""
    b, a = ev.get("parts_before") or {}, ev.get("parts_after") or {}
    change = "{} → {}" if arrow else "from {} to {}"
    return "".join(f" and the {_named(k)} RMSE " + change.format(_fmt(v), _fmt(a.get(k))) + f" {unit}"
                   for k, v in list(b.items())[1:])


def _named(part: str) -> str:
    return "leave-one-condition-out" if part == "loco" else part


def _paragraph(step: dict, before_rmse: float, unit: str, scored: str = "validation") -> str:
    """One step in words; ``scored``: the records the acceptance rule's RMSE is measured on ("validation", or
    "training" when there are none)."""
    ev = step["evidence"]
    fall = (1 - ev["val_rmse_after"] / ev["val_rmse_before"]) * 100 if ev["val_rmse_before"] else math.nan
    tail = (f"the {scored} RMSE from {_fmt(ev['val_rmse_before'])} to {_fmt(ev['val_rmse_after'])} {unit} "
            f"({_fmt(fall)} %){_other_parts(ev, unit)}, and the information criterion from "
            f"{_fmt(_ic(ev, 'before'))} to "
            f"{_fmt(_ic(ev, 'after'))}.")
    if step["kind"] == "trend":
        trends = ", ".join(f"{k}: {v}" for k, v in step.get("trends", {}).items())
        return (f"**{step['effect']}** (trends): {step['description']}, chosen per parameter from a per-condition "
                f"fit ({trends}). With them (every parameter refitted) {tail}")
    new = ", ".join(f"{k} = {_fmt(v)}" + (f" {step['parameters'].get(k, {}).get('unit', '')}".rstrip())
                    for k, v in step.get("new_coordinates", {}).items())
    kind = {"effect": "effect", "start": "start state"}.get(step["kind"], "parameter function")
    compared = ev.get("compared") or {}

    def also(c):  # the other errors a compared candidate was scored on (``validation: both``)
        return "".join(f", {_named(k)} {_fmt(v)} {unit}" for k, v in list((c.get("parts_val") or {}).items())[1:])

    others = "; ".join(f"{name} {_fmt(c['val_rmse'])} {unit}{also(c)} (criterion {_fmt(c['criterion'])})"
                       for name, c in compared.items() if name != step["effect"])
    why = (f" Refitted beside it, {scored} RMSE: {others}; of these the lowest is taken, or among "
           f"those within the margin of it the lowest information criterion.") if others else ""
    return (f"**{step['effect']}** ({kind}): {step['description']} Fitted new coordinates: {new}. With it "
            f"(every parameter refitted) the training residual's sum of squares fell by "
            f"{_fmt(100 * (ev.get('explained_share') or 0))} %, {tail}{why}")


def change_sentence(change: dict, scored: str, unit: str) -> str:
    """One removal or replacement of ``simplify`` in words: "removed", "replaced by its special case ..." (a simpler
    set it contains, ``replacement: special_case``) or "swapped for ..." (a runner-up it beat when it was added,
    ``replacement: rival_swap``: not a special case of it) or "replaced by ... once the loop had stopped" (a special
    case of it with one more effect, ``replacement: revisit``)."""
    g, by = change, " + ".join(change.get("by") or [])
    if not by:
        what = "removed: its contribution vanished"
    elif g.get("replacement") == "rival_swap":
        what = (f"swapped for {by}, a runner-up that validation turned down when {g['effect']} was added although "
                "the information criterion preferred it (not a special case of it)")
    elif g.get("replacement") == "revisit":
        what = (f"replaced by {by} once the loop had stopped short of the noise: a special case of it with one more "
                "effect chosen from there, which the rule accepts as a step over the final model")
    else:
        what = f"replaced by its special case {by}"
    moved = f"{_fmt(g['val_rmse_before'])} → {_fmt(g['val_rmse_after'])} {unit}{_other_parts(g, unit, True)}"
    return (f"**{g['effect']}** {what} after step {g.get('after_step', '?')} (refitted, {scored} RMSE {moved}, and the "
            "information criterion fell).")


def _disagrees(step: dict, unit: str) -> str:
    """The step's disagreement line as a sentence of its paragraph ("" when its evidence agrees)."""
    text = disagreement_line(step, unit)
    return f" **{text[0].upper()}{text[1:]}.**" if text else ""


def report_markdown(result: DiscoveryResult, title: str, unit: str) -> str:
    r = result.report
    b, a = r["before"], r["after"]
    lines = [f"# {title}", "", f"Wall time {r['wall_s']:.1f} s. Training records: {len(r['records']['train'])}, "
             f"validation: {len(r['records']['val'])}, test (held-out conditions): {len(r['records']['test'])}.",
             "", "## Error before and after", "", f"| split | before [{unit}] | after [{unit}] |", "|---|---|---|"]
    for s in ("train", "val", "test"):
        lines.append(f"| {s} | {_fmt(b.get(f'{s}_rmse'))} | {_fmt(a.get(f'{s}_rmse'))} |")
    if r.get("refit"):
        rf = r["refit"]
        lines += ["", "Validation errors are those of the fits on the training records alone (out of sample). Once "
                  "the structure was chosen, the nominal and the final model were refitted on the training and "
                  f"validation records ({len(rf['records'])}); test and training errors are the refitted models' "
                  f"(without the refit: test {_fmt(rf['before']['test_rmse_without_refit'])} → "
                  f"{_fmt(rf['after']['test_rmse_without_refit'])} {unit})."]
    first = b.get("first_fit") or {}
    if first.get("recentred") or first.get("at_bounds"):
        edges = ", ".join(f"`{n}` ({side})" for n, side in first.get("at_bounds", {}).items())
        moved = (f"searched again around values at the edge of its search box {first['recentred']} time(s) "
                 "(`identify`'s `recentre`)" if first.get("recentred") else "")
        held = f"left values at an edge of its search box: {edges}" if edges else ""
        lines += ["", "The nominal's first fit " + "; ".join(t for t in (moved, held) if t) + "."]
    if b["per_condition"]:
        lines += ["", f"Held-out conditions (RMSE [{unit}]):", "", "| condition | before | after |", "|---|---|---|"]
        lines += [f"| {k} | {_fmt(v)} | {_fmt(a['per_condition'].get(k))} |" for k, v in b["per_condition"].items()]
    lines += ["", *_diverged_lines(r.get("diverged") or _diverged_report(result)), "## Accepted", ""]
    kind = (r.get("validation") or {}).get("kind", "records")
    scored = "leave-one-condition-out" if kind == "loco" else "validation" if r["records"]["val"] else "training"
    if kind == "loco":
        lines += [f"The acceptance rule's RMSE is {r['validation']['on']}: each operating point's records predicted "
                  "by the model refitted on the others (`validation: loco`).", ""]
    elif kind == "both" and len(r["validation"].get("parts_after") or {}) > 1:
        lines += [f"The acceptance rule judges {r['validation']['on']} (each operating point's records predicted by "
                  "the model refitted on the others): a change must lower both by the margin (`validation: "
                  "both`).", ""]
    elif not r["records"]["val"]:
        lines += ["No validation records: the acceptance rule's RMSE is the training records'.", ""]
    lines += [_paragraph(s, b.get("val_rmse"), unit, scored) + _disagrees(s, unit) + "\n" for s in r["steps"]] or [
        "Nothing was added.", ""]
    for g in r.get("removed", []):
        lines += [change_sentence(g, scored, unit), ""]
    if r.get("stopped") == "max_steps":
        lines += [f"The loop stopped at its cap on effects added (`discover.max_steps` = "
                  f"{r['settings']['max_steps']}), not by the acceptance rule: more may be found with a higher cap.",
                  ""]
    for s in r["rejected"]:
        ev = s["evidence"]
        refused = disagreement_line(s, unit) if (s.get("cross_check") or {}).get("refused") else None
        if refused:
            what = (f"The condition trends **{s['effect']}** were refused by the cross-check" if s["kind"] == "trend"
                    else f"The start state **{s['effect']}**, offered {AFTER_ADDED}, was refused by its cross-check"
                    if s.get("when") == AFTER_ADDED else f"The loop stopped at **{s['effect']}**, refused by its "
                    "cross-check")
            lines += [f"{what}: {refused}.", ""]
            continue
        if s.get("outcome") == "constant":
            lines += [f"The condition trends, **{s['effect']}**, changed nothing: fitted level by level, every "
                      f"parameter's values were best described by a constant ({len(s['trends'])} "
                      f"parameter{'s' if len(s['trends']) != 1 else ''} tried).", ""]
            continue
        moved = f"{_fmt(ev['val_rmse_before'])} → {_fmt(ev['val_rmse_after'])} {unit}{_other_parts(ev, unit, True)}"
        what = (f"The condition trends, **{s['effect']}**, were not taken" if s["kind"] == "trend" else
                f"The start state **{s['effect']}**, offered {AFTER_ADDED}, was not taken"
                if s.get("when") == AFTER_ADDED else
                f"The loop stopped at the best remaining candidate, **{s['effect']}**")
        why = ("; refused: " + "; ".join(s["refused_by"])) if s.get("refused_by") else \
            f" (margin {r['settings']['margin']:.0%} required)"
        lines += [f"{what}: {scored} RMSE {moved} and the information criterion {_fmt(_ic(ev, 'before'))} → "
                  f"{_fmt(_ic(ev, 'after'))}{why}.", ""]
    u = r["unexplained"]
    dep = sorted(u["dependence"].items(), key=lambda kv: -kv[1])[:4]
    lines += ["## What is left", "",
              f"Training RMSE {_fmt(u['train_rmse'])} {unit}" + (f" (noise sd {_fmt(u['noise_sd'])})" if u["noise_sd"]
                                                                 else "") + "; lag-1 autocorrelation "
              f"{_fmt(u['whiteness']['lag_1'])} ({'white' if u['whiteness']['white'] else 'not white'}); the "
              f"residual depends most on {', '.join(f'{k} (η² = {v:.2f})' for k, v in dep)}; its largest share "
              f"({_fmt(100 * u['where']['share'])} %) sits at loop phase {u['where']['phase_deg']:.0f}°. "
              + _leftover_sentence(u["residual_network"]) + _scale_sentence(u.get("scale") or {}, unit) + (
                  " **Structure is left that no library effect explains** (flagged: above 1.2 × the known noise, "
                  f"or the network recovers more than {FLAG_SHARE:.0%} of it); look at the residual figures for its "
                  "shape."
                  if u.get("structure_flagged") else ""),
              "",
              "![Residual against each feature, before and after](residuals.png)", "",
              "![Loops: measured, before and after](loops.png)", ""]
    lines += ["## Parameters after", "", "| parameter | value | unit |", "|---|---|---|"]
    lines += [f"| {k} | {_fmt(v['value'])} | {v['unit']} |" for k, v in a["parameters"].items()]
    if r.get("model_config"):
        lines += ["", model_reuse_sentence("discovered", r["model_config"])]
    return "\n".join(lines) + "\n"


def _diverged_lines(diverged: dict) -> list[str]:
    """A paragraph naming each record a model's simulation diverged on (its RMSE is then not a value: the table's
    "—"), never leaving it out silently; [] when none did."""
    lines = []
    for stage, what in STAGES.items():
        gone = diverged.get(stage) or []
        if gone:
            named = ", ".join(Diverged(**d).describe() for d in gone)
            lines += [f"**The {what}'s simulation diverged** on {len(gone)} record{'s' if len(gone) > 1 else ''}: "
                      f"{named}. Its RMSE on a split holding one of them is not a value (—).", ""]
    return lines


SCALE_RATIO = 1.5  # a residual RMS that changes by more than this factor across a condition's levels is named


def _scale_sentence(scale: dict, unit: str) -> str:
    """The condition across whose levels the residual's size changes most, where it changes by more than
    ``SCALE_RATIO``: a spread that grows with a condition leaves its mean flat (η² ≈ 0) and is named here."""
    best = None  # (ratio, condition, (level, rms) lowest, (level, rms) highest)
    for name, per_level in scale.items():
        if per_level:
            lo, hi = min(per_level.items(), key=lambda kv: kv[1]), max(per_level.items(), key=lambda kv: kv[1])
            ratio = hi[1] / max(lo[1], 1e-300)
            if ratio > SCALE_RATIO and (best is None or ratio > best[0]):
                best = (ratio, name, lo, hi)
    if best is None:
        return ""
    ratio, name, lo, hi = best
    return (f" Its size changes with {name}: RMS {_fmt(lo[1])} {unit} at {name} = {lo[0]}, {_fmt(hi[1])} {unit} at "
            f"{hi[0]} (× {ratio:.1f}), a spread its mean does not show.")


def _leftover_sentence(net: dict) -> str:
    """What the leftover network (``leftover.py``) recovered, in one sentence."""
    share, on = _fmt(100 * net["explained_share"]), net["on"]
    if net.get("network") == "dynamics":
        return (f"A network inside the model's equations (a force with a latent state, fitted through the simulator "
                f"with every physical parameter held) removes {share} % of the remaining mean squared error on the "
                f"{on} records ({_fmt(net['rmse_before'])} → {_fmt(net['rmse_after_network'])}; "
                f"{_fmt(100 * net['train_share'])} % on the training records)"
                + (", in sample: not used for the flag." if on != "val" else "."))
    inputs = ", ".join(net["inputs"])
    if net["explained_share"] <= 0:
        return (f"A small network of ({inputs}) recovers none of the remaining residual "
                f"variance on the {on} records (its prediction there is worse than none: {share} %).")
    where = ("training records it was fitted to (no validation records: in sample, an upper bound)" if on == "train"
             else f"{on} records")
    return f"A small network of ({inputs}) recovers {share} % of the remaining residual variance on the {where}."


def write_discovery(result: DiscoveryResult, out_dir, title: str = "Discovery", unit: str = "") -> Path:
    """Write ``discovery.json``, ``report.md``, ``residuals.png`` and ``loops.png`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result.report.setdefault("diverged", _diverged_report(result))
    residual_figure(result, out / "residuals.png")
    loops_figure(result, out / "loops.png")
    atomic_write(out / "report.md", report_markdown(result, title, unit))
    write_json(out / "discovery.json", result.report)
    return out / "report.md"
