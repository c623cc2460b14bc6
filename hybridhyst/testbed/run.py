"""Run the independent test bed through ``hybridhyst.discover.discover`` and score it.

Every case runs with the same settings, the library defaults: only records, nominal, split and noise_sd
are passed. Per case (``run_case``):

* named: the effects of the final model that the nominal lacked (``report["effects"]["added"]``: one
  accepted and removed again, or replaced by a simpler special case, is not named; the simpler one is);
  trends: the accepted steps that add no effect (kind
  "trend" or "condition": parameters made functions of a condition; "start": the state every record
  starts from), reported apart and not counted as effects; dropped: nominal effects the loop removed
  (reported, not scored);
* single / pair / condition: found = every expected family has a member among the named effects, wrong =
  named effects in no expected family and any second member of one, ok_effect = found and nothing wrong;
  each key parameter fitted vs its truth (relative error, within its tolerance: ok_param);
* clean: ok_effect = nothing added (neither an effect nor a trend or start state: the truth has neither; trends
  on a condition the truth's parameters follow are allowed, ``Case.trends_ok``);
* out_of_library: ok_effect = nothing named; flagged = ``report["unexplained"]["structure_flagged"]``
  (False when missing); ok needs both;
* ok_rmse: held-out RMSE after discovery / noise sd ≤ ``RMSE_RATIO`` (1.2);
* ok: ok_effect and ok_rmse (and ok_param where there are keys; and flagged for out_of_library).

Overall (``summary``): share of effect cases (single + pair + condition) with ok_effect (target ≥ 90 %),
share of all cases with ok_rmse (target ≥ 90 %), every clean control ok, every out-of-library case ok.
"""

from __future__ import annotations

import math
import os
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

from .cases import ALIASES, CASE_BY_NAME, Case

__all__ = ["EFFECT_CATEGORIES", "RMSE_RATIO", "TARGETS", "markdown", "run_bed", "run_case", "summary"]

RMSE_RATIO = 1.2
EFFECT_CATEGORIES = ("single", "pair", "condition")
TARGETS = {"effect_share": 0.9, "rmse_share": 0.9}


def _number(v):
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)) else None


def _lookup(coord: str, report: dict):
    """The fitted value of ``coord`` ("<effect>.<param>"): from the final parameters, else the accepting
    step's new coordinates; under an alias of the effect (same parameter name) when the name is absent."""
    effect, param = coord.split(".", 1)
    names = [effect, f"{effect}_added"] + sorted(ALIASES.get(effect, set()) - {effect})
    params = report.get("after", {}).get("parameters", {})
    for name in names:
        key = f"{name}.{param}"
        value = _number((params.get(key) or {}).get("value"))
        if value is None:
            for step in report.get("steps", []):
                value = _number((step.get("new_coordinates") or {}).get(key))
                if value is not None:
                    break
        if value is not None:
            return key, value
    return None, None


def _path_entry(step: dict, noise: float) -> list:
    """[effect, accepted, validation RMSE before / noise, after / noise, cross-check before, after] of a step."""
    ev, cross = step["evidence"], step.get("cross_check") or {}
    in_noise = [None if _number(ev[k]) is None else _number(ev[k]) / noise for k in ("val_rmse_before",
                                                                                   "val_rmse_after")]
    return [step["effect"], bool(step.get("accepted")), *in_noise, _number(cross.get("before")),
            _number(cross.get("after"))]


def score(case: Case, report: dict, wall_s: float) -> dict:
    """The row of one case from its discovery report."""
    steps = report.get("steps", [])
    # what the final model holds beyond the nominal (effects accepted and later removed, or replaced by a
    # simpler special case, are not named; the simpler ones are)
    named = list((report.get("effects") or {}).get("added", []))
    trends = [s["effect"] for s in steps if s.get("kind", "effect") != "effect"]
    dropped = list((report.get("effects") or {}).get("dropped", []))
    params = report.get("after", {}).get("parameters", {})
    library = (report.get("effects") or {}).get("keys", {})  # effect key -> library name (lag_voltage: control_lag)
    fitted = {k: v.get("value") for k, v in params.items()
              if library.get(k.split(".", 1)[0], k.split(".", 1)[0].removesuffix("_added")) in named}
    before, after = report["before"].get("test_rmse"), report["after"].get("test_rmse")
    ratio = after / case.noise if _number(after) is not None else None
    unexplained = report.get("unexplained") or {}
    flagged = bool(unexplained.get("structure_flagged", False))
    network_share = _number((unexplained.get("residual_network") or {}).get("explained_share"))
    row = {"name": case.name, "category": case.category, "description": case.description,
           "samples_per_cycle": case.samples_per_cycle, "noise_kind": case.noise_kind, "noise": case.noise,
           "expected": [sorted(e) for e in case.expected], "named": named, "trends": trends, "dropped": dropped,
           "fitted": fitted,
           "test_rmse_before": before, "test_rmse_after": after, "after_over_noise": ratio,
           "ok_rmse": ratio is not None and ratio <= RMSE_RATIO, "flagged": flagged,
           "network_share": network_share, "train_rmse_after": report["after"].get("train_rmse"), "wall_s": wall_s,
           "keys": [], "error": None,
           # every step tried (accepted ones first), its validation RMSE before and after in units of the noise
           # (and, for accepted steps, the leave-one-condition-out cross-check before and after)
           "path": [_path_entry(s, case.noise) for s in steps + report.get("rejected", [])]}
    if case.category in EFFECT_CATEGORIES:
        found = all(any(n in family for n in named) for family in case.expected)
        # named effects in no expected family, and a second member of one (two hysteretic elements for one)
        wrong = [n for n in named if not any(n in family for family in case.expected)]
        for family in case.expected:
            wrong += [n for n in named if n in family][1:]
        keys = []
        for coord, truth, tol in case.keys:
            used, value = _lookup(coord, report)
            rel = abs(value / truth - 1) if value is not None and truth else None
            keys.append({"coordinate": coord, "found_as": used, "truth": truth, "value": value, "rel_error": rel,
                         "tolerance": tol, "ok": rel is not None and rel <= tol})
        row.update(found=found, wrong=wrong, ok_effect=found and not wrong, keys=keys,
                   ok_param=all(k["ok"] for k in keys))
        row["ok"] = row["ok_effect"] and row["ok_param"] and row["ok_rmse"]
    elif case.category == "clean":
        # trends on a condition the truth's parameters follow are the truth; anything else is added
        wrong = named + [t for t in trends if _trend_condition(t) not in case.trends_ok]
        row.update(found=None, wrong=wrong, ok_effect=not wrong, ok_param=None)
        row["ok"] = row["ok_effect"] and row["ok_rmse"]
    else:  # out_of_library
        row.update(found=None, wrong=named, ok_effect=not named, ok_param=None)
        row["ok"] = row["ok_effect"] and flagged and row["ok_rmse"]
    return row


def _trend_condition(step: str) -> str | None:
    """The condition of a trend step's name: ``trends~<condition>`` (every parameter at once) or
    ``<effect>.<parameter>~<condition>`` (one parameter, offered where the training data hold too few levels of
    the condition for the joint step); None for a step of another kind (a start state)."""
    head, sep, cond = step.rpartition("~")
    return cond if sep and (head == "trends" or "." in head) else None


def run_case(case: Case, options: dict | None = None, keep_model: bool = False) -> dict:
    """Generate the case's data, run discovery with the library defaults (``options``: discover() keywords
    given to every case alike, e.g. ``{"validation": "loco"}``), score it. A failure gives a row with
    ``error`` set (and every criterion False) instead of raising. ``keep_model``: the row carries the final model
    too (``"model"``; not JSON: for a caller that uses it, ``floor.case_floor``)."""
    import torch

    from ..discover import discover

    torch.set_default_dtype(torch.float64)
    start = time.perf_counter()
    try:
        records = case.records()
        nominal = case.nominal()
        res = discover(records, nominal, split=case.split, noise_sd=case.noise, progress=False, **(options or {}))
        row = score(case, res.report, time.perf_counter() - start)
        return {**row, "model": res.model} if keep_model else row
    except Exception as exc:  # a crash is a result of the bed, not a reason to lose the other cases
        return {"name": case.name, "category": case.category, "description": case.description,
                "samples_per_cycle": case.samples_per_cycle, "noise_kind": case.noise_kind, "noise": case.noise,
                "expected": [sorted(e) for e in case.expected], "named": [], "trends": [], "dropped": [],
                "fitted": {}, "keys": [],
                "test_rmse_before": None, "test_rmse_after": None, "after_over_noise": None, "ok_rmse": False,
                "flagged": False, "network_share": None, "train_rmse_after": None, "found": False, "wrong": [],
                "ok_effect": False, "ok_param": False, "ok": False,
                "wall_s": time.perf_counter() - start,
                "error": f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}"}


def _init_worker() -> None:
    """One thread per worker process, torch's and the compiled loops' alike: the workers already fill the cores,
    and threads on top of them only wait for each other."""
    import torch

    torch.set_default_dtype(torch.float64)
    torch.set_num_threads(1)
    os.environ["HYBRIDHYST_FAST_THREADS"] = "1"


def _registered(name: str) -> Case | None:
    """The case of that name in any bed (the first, ``cases.CASES``, or a blind one)."""
    if name in CASE_BY_NAME:
        return CASE_BY_NAME[name]
    from .blind_cases import blind_case

    return blind_case(name)


def _run_named(name: str, options: dict | None = None, task: Callable = run_case) -> dict:
    return task(_registered(name), options)


def run_bed(cases: Sequence[Case], jobs: int = 2, progress: bool = True, options: dict | None = None,
            cost: dict[str, float] | None = None, task: Callable = run_case) -> list[dict]:
    """Run ``cases`` (from ``CASES``) on ``jobs`` worker processes (torch float64, one thread each); rows in
    the order of ``cases``. ``jobs`` ≤ 1 runs in this process (any cases, registered or not). ``options``:
    discover() keywords, the same for every case. ``cost``: expected seconds per case name (an earlier run's);
    the workers take the costliest first, so that a long case does not start last (the rows keep their order).
    ``task``: what is run per case, ``task(case, options) -> row`` (a module-level function; default
    ``run_case``; ``floor.case_floor`` measures a case's floor instead)."""
    cases = list(cases)
    if jobs <= 1:
        _init_worker()
        rows = []
        for case in cases:
            rows.append(task(case, options))
            _report(rows[-1], progress)
        return rows
    unknown = [c.name for c in cases if _registered(c.name) is not c]
    if unknown:
        raise ValueError("run_bed with jobs > 1 takes cases from hybridhyst.testbed.cases.CASES or a blind bed "
                         f"(blind_cases.bed_cases); not there: {unknown}")
    out: dict[str, dict] = {}
    with ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker) as pool:
        order = sorted(cases, key=lambda c: -(cost or {}).get(c.name, 0.0))  # stable: unknown costs keep their order
        futures = {pool.submit(_run_named, c.name, options, task): c.name for c in order}
        for fut in _as_completed(futures):
            row = fut.result()
            out[row["name"]] = row
            _report(row, progress)
    return [out[c.name] for c in cases]


def _as_completed(futures):
    from concurrent.futures import as_completed

    return as_completed(futures)


def _report(row: dict, progress: bool) -> None:
    if progress and "named" not in row:  # a row of another task (``floor.case_floor``)
        print(f"{row['name']:>24}: {row.get('brief', '')} {row['wall_s']:.0f} s", flush=True)
    elif progress:
        err = f" ERROR {row['error'].splitlines()[0]}" if row.get("error") else ""
        ratio = row.get("after_over_noise")
        print(f"{row['name']:>24}: named {row['named']} trends {row['trends']} ok={row['ok']} "
              f"after/noise {'—' if ratio is None else f'{ratio:.2f}'} {row['wall_s']:.0f} s{err}", flush=True)


def summary(rows: Sequence[dict]) -> dict:
    """Shares and counts of the pass criteria, and whether each target is met."""
    effect_rows = [r for r in rows if r["category"] in EFFECT_CATEGORIES]
    clean = [r for r in rows if r["category"] == "clean"]
    ool = [r for r in rows if r["category"] == "out_of_library"]
    n_eff = sum(bool(r["ok_effect"]) for r in effect_rows)
    n_rmse = sum(bool(r["ok_rmse"]) for r in rows)
    out = {
        "cases": len(rows),
        "effect_cases": len(effect_rows), "effect_ok": n_eff,
        "effect_share": n_eff / len(effect_rows) if effect_rows else None,
        "param_ok": sum(bool(r.get("ok_param")) for r in effect_rows if r.get("keys")),
        "param_cases": sum(1 for r in effect_rows if r.get("keys")),
        "rmse_ok": n_rmse, "rmse_share": n_rmse / len(rows) if rows else None,
        "clean_cases": len(clean), "clean_ok": sum(bool(r["ok"]) for r in clean),
        "ool_cases": len(ool), "ool_not_named": sum(bool(r["ok_effect"]) for r in ool),
        "ool_flagged": sum(bool(r["flagged"]) for r in ool), "ool_ok": sum(bool(r["ok_effect"] and r["flagged"])
                                                                           for r in ool),
        "all_ok": sum(bool(r["ok"]) for r in rows), "wall_s": sum(r["wall_s"] for r in rows),
        "errors": [r["name"] for r in rows if r.get("error")],
    }
    out["targets"] = {
        "effect_share": out["effect_share"] is not None and out["effect_share"] >= TARGETS["effect_share"],
        "rmse_share": out["rmse_share"] is not None and out["rmse_share"] >= TARGETS["rmse_share"],
        "clean_all_ok": out["clean_ok"] == out["clean_cases"],
        "out_of_library_ok": out["ool_ok"] == out["ool_cases"],
    }
    out["passed"] = all(out["targets"].values())
    return out


def _f(v, fmt="{:.3g}"):
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v)


def _yes(v):
    return "—" if v is None else ("yes" if v else "no")


def markdown(rows: Sequence[dict]) -> str:
    """The results table (one row per case) and the summary of the pass criteria."""
    lines = ["| case | category | samples/cycle, noise | expected | named (in order) | trends | effect ok | "
             "key parameter: fitted / true (rel. error) | held-out RMSE before → after | after / noise | "
             "flagged (network share) | all ok | wall [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        expected = " + ".join("{" + ", ".join(e) + "}" for e in r["expected"]) or "nothing"
        keys = "; ".join(f"{k['coordinate']}: {_f(k['value'])} / {_f(k['truth'])} ({_f(k['rel_error'], '{:.0%}')})"
                         for k in r.get("keys", [])) or "—"
        flagged = _yes(r["flagged"]) if r["category"] == "out_of_library" else ("yes" if r["flagged"] else "—")
        if r["category"] == "out_of_library" and r.get("network_share") is not None:
            flagged += f" ({r['network_share']:.2f})"
        status = "**error**" if r.get("error") else f"**{_yes(r['ok'])}**"
        dropped = f" (dropped {', '.join(r['dropped'])})" if r.get("dropped") else ""
        lines.append(
            f"| {r['name']} | {r['category']} | {r['samples_per_cycle']}, {r['noise_kind']} | {expected} | "
            f"{', '.join(r['named']) or 'nothing'}{dropped} | {', '.join(r['trends']) or '—'} | "
            f"{_yes(r['ok_effect'])} | "
            f"{keys} | {_f(r['test_rmse_before'])} → {_f(r['test_rmse_after'])} | "
            f"{_f(r['after_over_noise'], '{:.2f}')} | {flagged} | {status} | {r['wall_s']:.0f} |")
    s = summary(rows)
    pct = lambda v: "—" if v is None else f"{v:.1%}"  # noqa: E731
    mark = lambda ok: "met" if ok else "**not met**"  # noqa: E731
    t = s["targets"]
    lines += ["",
              f"**Pass criteria:** effect named correctly in {s['effect_ok']} of {s['effect_cases']} effect cases "
              f"({pct(s['effect_share'])}, target ≥ 90 %: {mark(t['effect_share'])}); held-out RMSE ≤ "
              f"{RMSE_RATIO} × noise in {s['rmse_ok']} of {s['cases']} cases ({pct(s['rmse_share'])}, target ≥ 90 %: "
              f"{mark(t['rmse_share'])}); clean controls with nothing added {s['clean_ok']} of {s['clean_cases']} "
              f"({mark(t['clean_all_ok'])}); out-of-library cases with nothing named and structure flagged "
              f"{s['ool_ok']} of {s['ool_cases']} ({mark(t['out_of_library_ok'])}). "
              + (f"Key parameters within tolerance in {s['param_ok']} of {s['param_cases']} effect cases"
                 if s["param_cases"] else "No key parameters checked (the generators' parametrisations are not the "
                 "library's)") + "; all criteria met in "
              f"{s['all_ok']} of {s['cases']} cases. Sum of case wall times {s['wall_s']:.0f} s."
              + (f" Cases that raised: {', '.join(s['errors'])}." if s["errors"] else "")]
    return "\n".join(lines)
