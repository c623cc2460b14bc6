"""Does the discovery loop's result hinge on the nominal it starts from?

For cases of the first test bed (``hybridhyst/testbed/cases.py``), the loop is run again from a nominal with one
of its effects left out — a special case of the truth, as a user who declares less than the device has
(viscous + stiffness for a friction damper, Coulomb + viscous without the spring, a VPPTD law without its
friction or cubic term) — with the same one user setting as the bed (``testbed.run.run_case``). Each run is
compared with the bed's own run (``experiments/discovery_testbed/testbed.json``): the final model's effects
(the bed's nominal less the effects it dropped, plus those it named) and the held-out RMSE over the noise.

    PYTHONPATH=. python scripts/nominal_start.py --jobs 2 --json experiments/discovery_testbed/nominal_start.json \
        --write-readme

Writes its table between the ``starts`` markers of ``experiments/discovery_testbed/README.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from discovery_testbed import README, code_version  # noqa: E402

MARKERS = ("<!-- starts:start -->", "<!-- starts:end -->")
# (bed case, nominal effect key left out)
VARIANTS = [("clean_friction", "coulomb"), ("clean_friction", "spring"), ("coulomb", "spring"),
            ("stribeck+cubic", "coulomb"), ("time_delay", "coulomb"), ("travel_drift", "coulomb"),
            ("clearance", "viscous"), ("vpptd_linear+clearance", "friction"), ("vpptd_linear+clearance", "cubic")]


def run_variant(variant: tuple[str, str, bool]) -> dict:
    """Run the case from its nominal less one effect (``(case, effect key, revisit)``); the final model's effects,
    held-out RMSE / noise, wall."""
    import torch

    from hybridhyst.discover import discover
    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import _init_worker

    _init_worker()
    name, left_out, revisit = variant
    case = CASE_BY_NAME[name]
    torch.set_default_dtype(torch.float64)
    nominal = case.nominal()
    nominal = nominal.with_effects({k: e for k, e in nominal.effects.items() if k != left_out})
    start = time.perf_counter()
    try:
        report = discover(case.records(), nominal, split=case.split, noise_sd=case.noise, progress=False,
                          revisit=revisit).report
    except Exception as exc:  # a crash is a row, not the end of the others
        return {"case": name, "left_out": left_out, "error": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - start}
    after = report["after"].get("test_rmse")
    return {"case": name, "left_out": left_out, "nominal": sorted(e.name for e in nominal.effects.values()),
            "final": sorted(report["effects"]["final"]),
            "steps": [s["effect"] for s in report["steps"]],
            "after_over_noise": after / case.noise if after is not None else None,
            "wall_s": time.perf_counter() - start, "error": None}


def bed_final(name: str, rows: dict) -> tuple[list[str], float | None]:
    """The bed's own run of case ``name``: its final effects and held-out RMSE / noise."""
    import torch

    from hybridhyst.testbed.cases import CASE_BY_NAME

    torch.set_default_dtype(torch.float64)
    row = rows[name]
    nominal = sorted(e.name for e in CASE_BY_NAME[name].nominal().effects.values())
    final = sorted({n for n in nominal if n not in row["dropped"]} | set(row["named"]))
    return final, row["after_over_noise"]


def markdown(rows: list[dict], bed: dict) -> str:
    lines = ["| case | nominal left without | final effects (bed's run) | final effects (this run) | same structure | "
             "held-out / noise (bed → this) | wall [s] |", "|---|---|---|---|---|---|---|"]
    same = 0
    for r in rows:
        final, ratio = bed_final(r["case"], bed)
        if r["error"]:
            lines.append(f"| {r['case']} | {r['left_out']} | {', '.join(final)} | error: {r['error']} | no | — | "
                         f"{r['wall_s']:.0f} |")
            continue
        ok = r["final"] == final
        same += ok
        lines.append(f"| {r['case']} | {r['left_out']} | {', '.join(final)} | {', '.join(r['final'])} | "
                     f"{'yes' if ok else '**no**'} | {ratio:.2f} → {r['after_over_noise']:.2f} | {r['wall_s']:.0f} |")
    lines += ["", f"The same final structure in {same} of {len(rows)} runs; held-out RMSE ≤ 1.2 × noise in "
              f"{sum(1 for r in rows if not r['error'] and r['after_over_noise'] <= 1.2)} of {len(rows)}."]
    return "\n".join(lines)


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", metavar="PATH")
    ap.add_argument("--revisit", action="store_true", help="discover's revisit on (the library default: off)")
    ap.add_argument("--write-readme", action="store_true")
    args = ap.parse_args(argv)
    if args.write_readme and args.revisit:
        ap.error("--write-readme writes the table of the library's defaults; run --revisit with --json")
    start = time.perf_counter()
    variants = [(*v, args.revisit) for v in VARIANTS]
    if args.jobs > 1:
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            rows = list(pool.map(run_variant, variants))
    else:
        rows = [run_variant(v) for v in variants]
    wall = time.perf_counter() - start
    bed = {r["name"]: r for r in json.loads((README.parent / "testbed.json").read_text())["rows"]}
    command = "PYTHONPATH=. python scripts/nominal_start.py " + " ".join(argv if argv is not None else sys.argv[1:])
    section = (f"Generated by `{command.strip()}` ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
               f"{code_version()}; {wall:.0f} s wall with {args.jobs} worker(s) on {os.cpu_count()} cores).\n\n"
               + markdown(rows, bed))
    if args.json:
        Path(args.json).write_text(json.dumps({"command": command, "wall_s": wall, "rows": rows}, indent=2))
    if args.write_readme:
        text = README.read_text()
        a, b = text.index(MARKERS[0]) + len(MARKERS[0]), text.index(MARKERS[1])
        README.write_text(text[:a] + "\n" + section + "\n" + text[b:])
    print(section)
    return rows


if __name__ == "__main__":
    main()
