"""A discovery candidate's fit on long records: its starts screened on the leading samples against every sample.

``discover.fitting.fit_candidate`` starts from a dozen or more rows (heuristic starts, the best search points, each
also re-balanced) and keeps the three lowest after one round of Levenberg–Marquardt. On training records of more
than ``fitting.SCREEN_SAMPLES`` samples the search, the re-balance and that round fit the leading part of each
record (``fitting.screened``); the three rows chosen are then fitted on every sample. This script fits the same
candidates both ways, side by side in one run, on the Bouc–Wen benchmark's training record (40 960 samples, what
``experiment=boucwen_discovery`` fits):

1. the Bouc–Wen candidate on the linear nominal (m, c, k as the loop identified them before its first step, from
   ``experiments/boucwen_discovery/discovery.json``, polished), discovery's first step;
2. the LuGre candidate on the model that fit gave (the second step's runner-up, at the sub-steps the first fit
   needed).

For each: the wall time both ways (the two alternating, after a first call that builds the loops), their ratio,
the training RMSE each reaches and the sub-steps chosen.

    PYTHONPATH=. python scripts/bench_screen.py --json experiments/performance/bench_screen.json --write-readme

``--quick``: the first 3000 samples of the record screened on 1000, the Bouc–Wen candidate only (a smoke
run). A script, not a timed test: numbers depend on the machine load.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))  # bench_simulate

DISCOVERY = ROOT / "experiments" / "boucwen_discovery" / "discovery.json"
WHOLE = 10**12  # a screen no record reaches: every phase on every sample
QUICK_SAMPLES, QUICK_SCREEN = 3000, 1000  # --quick: a smoke run, not the default screen


def _setup(quick: bool):
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    from hybridhyst.data import load_builtin
    from hybridhyst.discover.fitting import polish
    from hybridhyst.simulate import SimulationSettings

    (train,) = [r for r in load_builtin("boucwen").records if r.conditions.get("split") == "train"]
    if quick:
        train = train.slice(0, QUICK_SAMPLES)
    cfg = OmegaConf.load(ROOT / "conf" / "model" / "linear_oscillator.yaml")
    # the nominal the loop identified (CMA-ES + LM) before its first step, as the committed discovery holds it
    before = json.loads(DISCOVERY.read_text())["before"]["parameters"]
    for key, entry in before.items():
        effect, param = key.split(".")
        if effect == "structure":
            if param in cfg:
                cfg[param] = entry["value"]
        else:
            cfg.effects[effect][param] = entry["value"]
    model = instantiate(cfg).double()
    sim = SimulationSettings(substeps=1)
    return [train], polish(model, [train], sim, 25, 10.0), sim


def _fit(cand, model, train, sim, screen: int):
    from hybridhyst.discover import fitting

    old, fitting.SCREEN_SAMPLES = fitting.SCREEN_SAMPLES, screen
    try:
        t0 = time.perf_counter()
        fit = fitting.fit_candidate(cand, model, train, sim, 25, 10.0)
        return fit, time.perf_counter() - t0
    finally:
        fitting.SCREEN_SAMPLES = old


def compare(name: str, model, train, sim, screen: int) -> tuple[dict, object]:
    """The candidate ``name`` on ``model`` fitted screened on ``screen`` samples and whole, alternating after a first
    call each; the row and the screened fit."""
    from hybridhyst.discover import fitting
    from hybridhyst.discover.candidates import Scales, effect_candidates

    (cand,) = effect_candidates(model, Scales.of(train, oscillator=True), [name])  # as the loop scales an oscillator
    n = sum(len(r) for r in train)
    ways = {"screened": screen, "whole": WHOLE}
    fits, seconds = {}, {}
    for k in range(2):  # the first round builds the loops; the second is timed, in the other order
        for way in (ways if k == 0 else list(ways)[::-1]):
            fits[way], seconds[way] = _fit(cand, model, train, sim, ways[way])
    row = {"candidate": name, "samples": n, "screen_samples": screen, "base_substeps": sim.substeps,
           "active": fitting.screened(train, screen) is not train}
    for way, fit in fits.items():
        row[way] = {"seconds": seconds[way], "rmse": math.sqrt(fit.sse / n), "substeps": fit.substeps}
    row["ratio"] = row["whole"]["seconds"] / row["screened"]["seconds"]
    row["rmse_ratio"] = row["screened"]["rmse"] / row["whole"]["rmse"]
    return row, fits["screened"]


def run(quick: bool) -> dict:
    from bench_simulate import machine_brief

    from hybridhyst.discover import fitting

    torch.set_default_dtype(torch.float64)
    res = {**machine_brief(), "quick": quick}
    train, nominal, sim = _setup(quick)
    res["nominal_rmse"] = math.sqrt(nominal.sse / sum(len(r) for r in train))
    screen = QUICK_SCREEN if quick else fitting.SCREEN_SAMPLES
    first, fit = compare("bouc_wen", nominal.model, train, sim, screen)
    res["rows"] = [first]
    if not quick:
        res["rows"].append(compare("lugre", fit.model, train, sim.at(fit.substeps), screen)[0])
    return res


def markdown(res: dict) -> str:
    from bench_simulate import cores

    lines = [f"One discovery candidate's fit on the Bouc–Wen benchmark's training record ({cores(res)}, load "
             f"average at the start {res['load_average_at_start']}): the many-row phases screened on the leading "
             f"samples (the default) against every sample, side by side; the linear nominal's training RMSE "
             f"{res['nominal_rmse']:.3g} m.", "",
             "| candidate | on the model | samples | screen | screened s | every sample s | **ratio** | "
             "RMSE screened / every sample [m] | sub-steps |",
             "|---|---|---|---|---|---|---|---|---|"]
    on = {"bouc_wen": "linear nominal", "lugre": "+ Bouc–Wen (that fit)"}
    for r in res["rows"]:
        s, w = r["screened"], r["whole"]
        lines.append(f"| {r['candidate']} | {on.get(r['candidate'], '')} | {r['samples']} | {r['screen_samples']} | "
                     f"{s['seconds']:.1f} | {w['seconds']:.1f} | **{r['ratio']:.2f}×** | {s['rmse']:.4g} / "
                     f"{w['rmse']:.4g} | {s['substeps']} / {w['substeps']} |")
    return "\n".join(lines)


def main(argv=None) -> dict:
    from bench_simulate import simple_main

    return simple_main(argv, __doc__, "bench_screen", run, markdown)


if __name__ == "__main__":
    main()
