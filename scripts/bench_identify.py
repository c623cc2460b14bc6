"""Benchmark of identification: hybridhyst vs scipy ``differential_evolution`` with a numpy-vectorised RK4.

(3) Identify the 11 constant parameters of seed 001's modified Bouc–Wen + viscous + Coulomb law from the
1711-sample 1:3, p = 0.05 MPa loop with 0.2 Nm noise until the response RMSE reaches the noise floor
(≤ 1.02 × 0.2 Nm): hybridhyst (batched population on the compiled fast path + exact-gradient refinement)
vs scipy's ``differential_evolution(..., vectorized=True)`` on a numpy RK4 of the same equations,
vectorised over the population; same bounds, same RK4 grid. (4) Joint identification of all nine
pressures of the 1:3 mixture with every parameter a linear function of p: wall time and RMSE per pressure.
(5) hybridhyst's former hand-written differential evolution and CMA-ES (read from git revision
``HANDWRITTEN_REV``) against the libraries' that replaced them (scipy's and cma's), on the problem of (3) with
the same budget and seeds: the search alone, and ``identify`` to the floor with each.

    PYTHONPATH=. python scripts/bench_identify.py --json bench_identify.json --write-readme

``--quick`` is a smoke run (short time caps; the floor may not be reached).
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import subprocess
import sys
import time
import types
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
# the problem and its identifiers; the names marked F401 are not used here: kept so that this module still offers them
# (tests/test_bench_scripts.py reads some)
from bench_identify_problem import (  # noqa: E402
    BIG,  # noqa: F401
    BOUNDS,  # noqa: F401
    FLOOR,
    MIXTURE,  # noqa: F401
    NOISE_SD,
    PRESSURE,
    SCENARIOS,
    TUNED,
    WIDE,  # noqa: F401
    constant_bounds,
    constant_model,
    linear_bounds,
    linear_model,
    load_records,
    numpy_rk4_response,  # noqa: F401
    numpy_rmse,  # noqa: F401
    rk4_inputs,  # noqa: F401
    run_identify,
    run_repeats,
    run_scipy,
    warm_up,
)
from bench_simulate import bench_parser, command_line, emit, machine_info, machine_markdown  # noqa: E402


def bench_single(scenario: str, quick: bool, scipy_max_s: float, skip_scipy: bool) -> dict:
    """(3) one loop to the noise floor: hybridhyst vs scipy, same bounds (``SCENARIOS[scenario]``)."""
    bounds = SCENARIOS[scenario]
    recs = load_records([PRESSURE])
    r = recs.records[0]
    out = {"scenario": scenario, "floor": FLOOR, "noise_sd": NOISE_SD, "n_parameters": len(bounds),
           "samples": len(r), "bounds": {f"{e}.{n}": [lo, hi] for e, n, lo, hi in bounds},
           "first_fast_call_s": warm_up(constant_model(bounds), r)}
    repeats = 1 if quick else 5
    out["hybridhyst"] = run_repeats(bounds, recs, repeats, **TUNED)
    if not quick:
        out["hybridhyst_default"] = run_repeats(bounds, recs, repeats)
    for key in ("hybridhyst", "hybridhyst_default"):
        if key in out:
            print(f"  [{scenario}] {key}: median {out[key]['wall_s']:.2f} s of {out[key]['walls_s']}, "
                  f"worst RMSE {out[key]['rmse']:.4f}", flush=True)
    if not skip_scipy:
        # scipy's default population (15 per parameter) and a small one (5), the faster of which is compared
        for key, popsize in (("scipy", 15), ("scipy_small", 5)) if not quick else (("scipy", 15),):
            out[key] = run_scipy(r, bounds, scipy_max_s, popsize=popsize)
            print(f"  [{scenario}] {key}: {out[key]['wall_s']:.1f} s, RMSE {out[key]['rmse']:.4f}", flush=True)
        fastest = min(out.get("scipy_small", out["scipy"])["wall_s"], out["scipy"]["wall_s"])
        out["ratio"] = fastest / out["hybridhyst"]["wall_s"]
        if "hybridhyst_default" in out:
            out["ratio_default"] = fastest / out["hybridhyst_default"]["wall_s"]
    return out


def bench_joint(quick: bool) -> dict:
    """(4) all nine pressures of the 1:3 mixture jointly, parameters linear in p."""
    pressures = [0.03, 0.05, 0.07] if quick else [round(0.01 * i, 2) for i in range(1, 10)]
    recs = load_records(pressures)
    model = linear_model()
    first = warm_up(model, recs.records[0], {"pressure_mpa": 0.05})
    kw = {"pop": 48, "generations": 60} if not quick else {"pop": 24, "generations": 10}
    res = run_identify(model, recs, linear_bounds(), attempts=1, **kw)
    per = [{"pressure_mpa": p, "rmse": res["per_record"][rec.name], "at_floor": res["per_record"][rec.name] <= FLOOR}
           for p, rec in zip(pressures, recs.records)]
    print(f"  joint: {res['wall_s']:.1f} s, pooled RMSE {res['rmse']:.4f}", flush=True)
    return {"pressures": pressures, "first_fast_call_s": first, "n_coordinates": len(linear_bounds()),
            "per_pressure": per, **{k: res[k] for k in ("wall_s", "rmse", "evaluations", "attempts", "settings", "x")}}


# -- (5) hand-written searches vs the libraries' ------------------------------------------------------
# The last commit whose identify/search.py carried hybridhyst's own differential evolution and CMA-ES.
HANDWRITTEN_REV = "9e504ee"


def load_handwritten(rev: str):
    """``hybridhyst/identify/search.py`` as of git revision ``rev``, imported under a private name (its relative
    imports resolve in today's package); ``(None, why)`` when git or the revision is not available."""
    root = Path(__file__).resolve().parents[1]
    try:
        src = subprocess.run(["git", "show", f"{rev}:hybridhyst/identify/search.py"], cwd=root, check=True,
                             capture_output=True, text=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        return None, f"cannot read hybridhyst/identify/search.py at {rev}: {e}"
    name = f"hybridhyst.identify._search_{rev}"
    module = types.ModuleType(name)
    module.__package__, module.__file__ = "hybridhyst.identify", f"{rev}:hybridhyst/identify/search.py"
    sys.modules[name] = module  # dataclasses look their module up
    exec(compile(src, module.__file__, "exec"), module.__dict__)
    return module, ""


@contextmanager
def search_in_identify(method: str, search):
    """``identify(search=method)`` with ``search`` as its global search (restored after)."""
    ident = importlib.import_module("hybridhyst.identify.identify")
    name = {"de": "differential_evolution", "cma": "cma_es"}[method]
    saved = getattr(ident, name)
    setattr(ident, name, search)
    try:
        yield
    finally:
        setattr(ident, name, saved)


def search_problem(bounds, decimate: int = 2):
    """The search's objective in ``identify(search_decimate=2)``: pooled MSE on every 2nd sample of the loop."""
    from hybridhyst.data.decimate import decimate_all
    from hybridhyst.identify import RecordsProblem, SearchSpace

    space = SearchSpace(constant_model(bounds), constant_bounds(bounds))
    return RecordsProblem(space, decimate_all(load_records([PRESSURE]).records, decimate, "identification"))


def run_search(search, problem, pop: int, generations: int, seed: int) -> dict:
    """One search alone (no refinement): cost reached, rows evaluated, objective calls and wall time."""
    sizes = []

    def cost(X):
        sizes.append(X.shape[0])
        return problem.cost(X)

    t0 = time.perf_counter()
    res = search(cost, problem.space, pop=pop, generations=generations, seed=seed, progress=False)
    return {"seed": seed, "rmse": math.sqrt(res.cost), "evaluations": res.evaluations, "calls": len(sizes),
            "rows": sum(sizes), "wall_s": time.perf_counter() - t0}


def _median(rows, key):
    return float(np.median([r[key] for r in rows]))


NEAR_FLOOR = 1.05 * NOISE_SD  # a search-alone RMSE counted as "at the floor" (the refinement takes it the rest)


def implementations(own, library) -> dict:
    """The searches compared in (5), per method: hand-written first, then the library-based ones."""
    return {"de": [("hand-written", own.differential_evolution), ("scipy", library.differential_evolution)],
            "cma": [("hand-written", own.cma_es),
                    ("cma, its bound transform", partial(library.cma_es, boundary="transform")),
                    ("cma, reflected into the box", partial(library.cma_es, boundary="reflect"))]}


def summarize(method, scenario, name, runs, idents) -> dict:
    return {"method": method, "scenario": scenario, "implementation": name, "search": runs,
            "search_rmse": _median(runs, "rmse"), "search_evaluations": _median(runs, "evaluations"),
            "search_wall_s": _median(runs, "wall_s"), "near_floor": sum(r["rmse"] <= NEAR_FLOOR for r in runs),
            "identify": {"wall_s": _median(idents, "wall_s"), "walls_s": [x["wall_s"] for x in idents],
                         "rmse": max(x["rmse"] for x in idents), "evaluations": _median(idents, "evaluations"),
                         "reached_floor": all(x["reached_floor"] for x in idents), "settings": idents[0]["settings"]}}


def bench_compare(quick: bool, rev: str, scenarios) -> dict:
    """(5) hybridhyst's hand-written DE / CMA-ES (git ``rev``) vs scipy's / cma's, same problem, budget and seeds:
    the search alone (pop 32, 100 generations, 10 seeds) and ``identify`` to the floor (``TUNED``, 5 runs)."""
    import torch

    from hybridhyst.identify import search as library

    own, why = load_handwritten(rev)
    if own is None:
        print(f"  (5) skipped: {why}", flush=True)
        return {"skipped": why}
    torch.set_num_threads(1)
    seeds, repeats = (range(2), 1) if quick else (range(10), 5)
    budget = {"pop": 32, "generations": 15 if quick else 100}
    recs = load_records([PRESSURE])
    out = {"rev": rev, "budget": budget, "seeds": list(seeds), "repeats": repeats, "near_floor": NEAR_FLOOR,
           "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "rows": []}
    for method, impls in implementations(own, library).items():
        for scenario in scenarios:
            bounds = SCENARIOS[scenario]
            problem = search_problem(bounds)
            runs, idents = {name: [] for name, _ in impls}, {name: [] for name, _ in impls}
            for seed in seeds:  # interleaved, so a change of the machine's load hits all alike
                for name, search in impls:
                    runs[name].append(run_search(search, problem, seed=seed, **budget))
            for i in range(repeats):
                for name, search in impls:
                    with search_in_identify(method, search):
                        idents[name].append(run_identify(constant_model(bounds), recs, constant_bounds(bounds),
                                                         attempts=5, base_seed=10 * i, search=method, **TUNED))
            for name, _ in impls:
                row = summarize(method, scenario, name, runs[name], idents[name])
                out["rows"].append(row)
                per_seed = ", ".join(f"{x['rmse']:.4f}" for x in row["search"])
                print(f"  (5) {method} {scenario} {name}: search RMSE median {row['search_rmse']:.4f} ({per_seed}), "
                      f"wall {row['search_wall_s']:.2f} s; identify median {row['identify']['wall_s']:.2f} s, "
                      f"worst RMSE {row['identify']['rmse']:.4f}", flush=True)
    return out


def single_markdown(s: dict) -> list[str]:
    lines = [f"**(3) One loop to the noise floor, {s['scenario']} bounds** (1:3, p = {PRESSURE} MPa, "
             f"{s['samples']} samples, noise sd {NOISE_SD} Nm, floor RMSE ≤ {FLOOR:.3f} Nm; "
             f"{s['n_parameters']} constant parameters, same bounds):", "",
             "| identifier | wall time | final RMSE [Nm] (worst run) | reached floor | evaluations | GPU |",
             "|---|---|---|---|---|---|"]
    rows = (("hybridhyst", "hybridhyst `identify`, tuned (pop 16, search on every 2nd sample)"),
            ("hybridhyst_default", "hybridhyst `identify`, default settings (pop 32)"),
            ("scipy", "scipy `differential_evolution` (popsize 15), numpy-vectorised RK4"),
            ("scipy_small", "scipy `differential_evolution` (popsize 5), numpy-vectorised RK4"))
    for key, label in rows:
        if key in s:
            r = s[key]
            spread = (f" (median of {len(r['walls_s'])}: {', '.join(f'{w:.2f}' for w in r['walls_s'])})"
                      if "walls_s" in r else "")
            lines.append(f"| {label} | {r['wall_s']:.2f} s{spread} | {r['rmse']:.4f} | "
                         f"{'yes' if r['reached_floor'] else 'no'} | {r['evaluations']} | not measured |")
    if "ratio" in s:
        cap = s["scipy"]["cap_s"]
        reached = all(s[k]["reached_floor"] for k in ("scipy", "scipy_small") if k in s)
        capped = "" if reached else f" (a scipy run stopped by its {cap:.0f} s cap: a lower bound)"
        default = f"; default settings {s['ratio_default']:.0f}×" if "ratio_default" in s else ""
        lines.append(f"| **ratio** (faster scipy / hybridhyst median) | **{s['ratio']:.0f}×** tuned{default} "
                     f"(target ≥ 30×){capped} | | | | |")
    lines += ["", f"First fast call (compile or cache load, not timed): {s['first_fast_call_s']:.1f} s. "
              f"hybridhyst settings: {s['hybridhyst']['settings']}."]
    for key in ("scipy", "scipy_small"):
        if key in s:
            lines.append(f"scipy settings: {s[key]['settings']}; {s[key]['generations']} generations.")
    return lines


def joint_markdown(j: dict) -> list[str]:
    lines = [f"**(4) Joint identification of {len(j['pressures'])} pressures** (1:3; every parameter linear in p, "
             f"v_s fixed at 0.1 deg/s: {j['n_coordinates']} coordinates): wall time {j['wall_s']:.1f} s, pooled "
             f"RMSE {j['rmse']:.4f} Nm, {j['evaluations']} simulated record evaluations.", "",
             "| p [MPa] | response RMSE [Nm] | ≤ floor |", "|---|---|---|"]
    lines += [f"| {r['pressure_mpa']:.2f} | {r['rmse']:.4f} | {'yes' if r['at_floor'] else 'no'} |"
              for r in j["per_pressure"]]
    lines += ["", f"Settings: {j['settings']}. The seed 001 truth is not linear in p (c is quadratic), so the "
              "floor is not guaranteed at every pressure."]
    return lines


def compare_markdown(c: dict) -> list[str]:
    if "skipped" in c:
        return [f"**(5) Hand-written searches vs the libraries'**: skipped ({c['skipped']})."]
    b = c["budget"]
    lines = [f"**(5) Hand-written searches (git {c['rev']}) vs the libraries'** (scipy `differential_evolution`; "
             "`cma.CMAEvolutionStrategy` ask/tell with IPOP restarts, bounds by cma's transform or by reflection), "
             f"the loop of (3), one process, OMP_NUM_THREADS={c['omp_num_threads']}. *Search alone*: pop {b['pop']}, "
             f"{b['generations']} generations, no refinement, seeds {c['seeds'][0]}–{c['seeds'][-1]} (the same for "
             "every implementation, runs interleaved); RMSE on every 2nd sample (the search's objective); "
             f"'near floor': RMSE ≤ {c['near_floor']:.2f} Nm. *identify*: the tuned settings of (3) with that "
             f"search, to the floor, median of {c['repeats']} runs.", "",
             "| search | bounds | implementation | search RMSE [Nm]: median (min–max) | near floor | evaluations "
             "| search wall (median) | identify wall (median) | identify worst RMSE | floor |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    groups: dict = {}
    for r in c["rows"]:
        groups.setdefault((r["method"], r["scenario"]), []).append(r)
    for (method, scenario), rows in groups.items():
        for r in rows:
            lo, hi = min(s["rmse"] for s in r["search"]), max(s["rmse"] for s in r["search"])
            idf = r["identify"]
            lines.append(f"| {method} | {scenario} | {r['implementation']} | {r['search_rmse']:.4f} "
                         f"({lo:.4f}–{hi:.4f}) | {r['near_floor']}/{len(r['search'])} | {r['search_evaluations']:.0f} "
                         f"| {r['search_wall_s']:.2f} s | {idf['wall_s']:.2f} s | {idf['rmse']:.4f} "
                         f"| {'yes' if idf['reached_floor'] else 'no'} |")
        own = rows[0]
        for lib in rows[1:]:
            lines.append(f"| {method} | {scenario} | ratio {lib['implementation']} / {own['implementation']} "
                         f"| {lib['search_rmse'] / own['search_rmse']:.3f} | "
                         f"| {lib['search_evaluations'] / own['search_evaluations']:.2f} "
                         f"| {lib['search_wall_s'] / own['search_wall_s']:.2f} "
                         f"| {lib['identify']['wall_s'] / own['identify']['wall_s']:.2f} | | |")
    return lines


def report_markdown(result: dict) -> str:
    lines = [f"Generated by `{result['command']}` ({'quick' if result['quick'] else 'full'} run, finished "
             f"{result['finished_utc']}).", "", machine_markdown(result["machine"]), ""]
    for single in result["single"].values():
        lines += single_markdown(single) + [""]
    lines += [f"{s['scenario'].capitalize()} bounds: {', '.join(f'{k} {v}' for k, v in s['bounds'].items())}."
              for s in result["single"].values()] + [""]
    if "joint" in result:
        lines += joint_markdown(result["joint"])
    if "compare" in result:
        lines += [""] + compare_markdown(result["compare"])
    return "\n".join(lines)


def parse_args(argv=None) -> argparse.Namespace:
    ap = bench_parser(__doc__, "bench_identify", "smoke run: short caps, three pressures in (4)")
    ap.add_argument("--scipy-max-s", type=float, default=600.0, help="wall-time cap of the scipy run [s]")
    ap.add_argument("--scenarios", default="tight,wide", help="bound boxes for (3), comma separated")
    ap.add_argument("--skip-scipy", action="store_true", help="run hybridhyst only")
    ap.add_argument("--skip-joint", action="store_true", help="skip (4)")
    ap.add_argument("--skip-compare", action="store_true", help="skip (5), hand-written vs library searches")
    ap.add_argument("--handwritten-rev", default=HANDWRITTEN_REV,
                    help="git revision whose identify/search.py holds the hand-written searches for (5)")
    return ap.parse_args(argv)


def main(argv=None) -> dict:
    args = parse_args(argv)
    result = {"command": command_line(), "quick": bool(args.quick), "machine": machine_info()}
    import cma  # noqa: F401  the libraries' import (cma's ~2 s: it loads matplotlib) is in no timing
    import scipy.optimize  # noqa: F401
    print("(3) one loop to the noise floor", flush=True)
    scenarios = ["tight"] if args.quick else args.scenarios.split(",")
    cap = 20.0 if args.quick else args.scipy_max_s
    result["single"] = {name: bench_single(name, args.quick, cap, args.skip_scipy) for name in scenarios}
    if not args.skip_joint:
        print("(4) joint identification over pressure", flush=True)
        result["joint"] = bench_joint(args.quick)
    if not args.skip_compare:
        print("(5) hand-written vs library searches", flush=True)
        result["compare"] = bench_compare(args.quick, args.handwritten_rev, scenarios)
    result["finished_utc"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return emit(args, "bench_identify", result, report_markdown(result))


if __name__ == "__main__":
    main()
