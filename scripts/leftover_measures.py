"""How much structure the discovery loop leaves, measured two ways on the independent test bed's controls.

For each chosen case (default: the three clean controls and the two out-of-library cases) the loop runs as a
user would run it without a known noise level (``noise_sd=None``, so the flag comes from a network alone),
then both leftover measures of ``hybridhyst/discover/leftover.py`` are taken on its final model: the static
network of the kinematics and the network inside the model's dynamics. A measure should flag the
out-of-library cases (structure left that no library effect names) and not the clean ones.

    PYTHONPATH=. python scripts/leftover_measures.py --json experiments/discovery_testbed/leftover.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT = "clean_friction,clean_oscillator_ar1,clean_dahl_1000,cogging,rough_patch"


def measure(case) -> dict:
    import torch

    from hybridhyst.discover import discover
    from hybridhyst.discover.leftover import residual_network, structure_flagged

    torch.set_default_dtype(torch.float64)
    start = time.perf_counter()
    res = discover(case.records(), case.nominal(), split=case.split, noise_sd=None, leftover="dynamics", progress=False)
    rep, train, val = res.report, res.splits["train"], res.splits["val"]
    dynamic = rep["unexplained"]["residual_network"]  # the loop's own measure, on its training-only fit
    row = {"name": case.name, "category": case.category, "noise": case.noise,
           "named": [s["effect"] for s in rep["steps"]], "train_rmse_after": rep["after"]["train_rmse"],
           "train_over_noise": rep["after"]["train_rmse"] / case.noise,
           "loop_s": time.perf_counter() - start - dynamic["wall_s"]}
    preds = res.predictions["after"]
    t0 = time.perf_counter()
    static = residual_network(train, preds["train"], val or None, preds["val"] or None)
    row["static"] = {**static, "wall_s": time.perf_counter() - t0, "flagged": structure_flagged(static, math.nan, None)}
    row["dynamics"] = {**dynamic, "flagged": structure_flagged(dynamic, math.nan, None)}
    return row


def main(argv=None) -> list[dict]:
    from hybridhyst.testbed.cases import CASE_BY_NAME

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=DEFAULT, help=f"comma-separated case names (default: {DEFAULT})")
    ap.add_argument("--json", metavar="PATH", help="write the rows as JSON")
    args = ap.parse_args(argv)
    rows = []
    for name in args.cases.split(","):
        if name not in CASE_BY_NAME:
            ap.error(f"unknown case {name!r}; the test bed has {sorted(CASE_BY_NAME)}")
        rows.append(measure(CASE_BY_NAME[name]))
        r = rows[-1]
        print(f"{r['name']:>18} {r['category']:>15}  named {r['named'] or '-'}  train/noise "
              f"{r['train_over_noise']:.2f}  static {r['static']['explained_share']:+.3f} "
              f"({'flag' if r['static']['flagged'] else 'no flag'}, {r['static']['wall_s']:.1f} s)  dynamics "
              f"{r['dynamics']['explained_share']:+.3f} ({'flag' if r['dynamics']['flagged'] else 'no flag'}, "
              f"{r['dynamics']['wall_s']:.1f} s)  loop {r['loop_s']:.0f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float) + "\n")
    return rows


if __name__ == "__main__":
    main()
