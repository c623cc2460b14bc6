"""How low can each test-bed case's held-out error go? The library's structures fitted to the held-out records
themselves (``hybridhyst.testbed.floor``), next to what the discovery loop reached (the bed's committed table).

The beds' held-out target (RMSE ≤ 1.2 × noise in ≥ 90 % of cases) counts every case, those whose effect the
library lacks included. A case whose best structure stays above 1.2 × noise even when fitted to the held-out
records themselves (an in-sample error, each record with parameters of its own) cannot meet it; a case where a
structure reaches it and the loop does not is the loop's miss. Writes the table into
``experiments/discovery_testbed/README.md`` (between the ``floor`` markers) and ``--json``.

With ``--with-loop`` each case first runs through the loop as the bed runs it, and the loop's final model is
refitted to the held-out records too: a miss where that refit reaches the target is one of generalisation (the
structure is right, its parameters learnt on the other conditions do not carry over); where only another
structure reaches it, one of selection.

    PYTHONPATH=. python scripts/testbed_floor.py --beds blind,blind2 --with-loop \\
        --json experiments/discovery_testbed/floor.json --write-readme        # about 20 min on 2 cores
    PYTHONPATH=. python scripts/testbed_floor.py --beds blind2 --cases b2_play_linkage_damper --jobs 1
    PYTHONPATH=. python scripts/testbed_floor.py --beds blind,blind2 \\
        --from-json experiments/discovery_testbed/floor.json --write-readme    # the tables again, no fits
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # its sibling discovery_testbed, loaded from anywhere

from discovery_testbed import README, code_version, write_readme  # noqa: E402  (the commit, the README's sections)

from hybridhyst.testbed.run import _f  # noqa: E402  (a number of the bed's tables, or "—")

LOOP_TABLES = {"first": "testbed.json", "blind": "blind.json", "blind2": "blind2.json"}  # the loop's committed rows
TITLES = {"first": "the first bed", "blind": "the blind bed", "blind2": "the second blind bed"}


def loop_rows(bed: str) -> dict[str, dict]:
    """The loop's rows of ``bed``'s committed table, by case name, and the commit they come from."""
    path = ROOT / "experiments" / "discovery_testbed" / LOOP_TABLES[bed]
    data = json.loads(path.read_text())
    return {r["name"]: {**r, "_code": data.get("code", "?")} for r in data["rows"]}


def lowest(floor: dict) -> float:
    """The lowest error any structure reached fitted to the held-out records."""
    return min(v for k in ("nominal", "expected", "best_effect", "discovered") if (v := floor.get(k)) is not None)


def _f2(v) -> str:
    return _f(v, "{:.2f}")


def verdict(floor: dict, loop: dict | None, ratio: float) -> str:
    """What the floor says of the case's held-out target: the loop meets it; or some structure fitted to the
    held-out records reaches it and the loop misses it; or none does (the target is out of reach)."""
    if loop is not None and loop.get("after_over_noise") is not None and loop["after_over_noise"] <= ratio:
        return "the loop meets it"
    if floor.get("error"):
        return "error"
    if loop is None:
        return "no loop result"
    if lowest(floor) > ratio:
        return "out of reach"
    if floor.get("discovered") is not None and floor["discovered"] <= ratio:
        return "the loop's miss: its model fits the record, not from the others (generalisation)"
    return "the loop's miss" + (": another structure fits (selection)" if floor.get("discovered") is not None else "")


def singled_out(floor: dict) -> str:
    """Whether the best single library effect on the held-out records is one the case expects."""
    fams = floor.get("expected_families") or []
    if not fams or floor.get("best_effect_name") is None:
        return "—"
    return "yes" if any(floor["best_effect_name"] in f for f in fams) else "no"


def markdown(rows: list[dict], loops: dict[str, dict], ratio: float) -> str:
    head = ("| case | category | loop: named | loop: held-out / noise | nominal fitted to it | expected structure "
            "fitted to it | best single effect fitted to it | expected effect best? | loop's model refitted to it "
            "| verdict |\n|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        loop = loops.get(r["name"])
        named = ", ".join(loop["named"]) if loop and loop.get("named") else "nothing"
        if r.get("error"):
            lines.append(f"| {r['name']} | {r['category']} | {named} | {_f2(loop and loop.get('after_over_noise'))} "
                         f"| error: {r['error'].splitlines()[0]} | | | | | error |")
            continue
        structure = " / ".join(" + ".join(st) or "the nominal" for st in r["expected_structure"]) or "the nominal"
        lines.append(f"| {r['name']} | {r['category']} | {named} | {_f2(loop and loop.get('after_over_noise'))} "
                     f"| {_f2(r['nominal'])} | {_f2(r['expected'])} ({structure}) | {_f2(r['best_effect'])} "
                     f"({r['best_effect_name']}) | {singled_out(r)} | {_f2(r.get('discovered'))} "
                     f"| {verdict(r, loop, ratio)} |")
    return head + "\n".join(lines)


def tally(rows: list[dict], loops: dict[str, dict], ratio: float) -> dict:
    verdicts = [verdict(r, loops.get(r["name"]), ratio) for r in rows]
    effect_rows = [r for r in rows if r.get("expected_families")]
    return {"cases": len(rows),
            "reachable": sum(v == "the loop meets it" or v.startswith("the loop's miss") for v in verdicts),
            "loop_meets": sum(v == "the loop meets it" for v in verdicts),
            "loop_misses": sum(v.startswith("the loop's miss") for v in verdicts),
            "generalisation_misses": sum(v.endswith("(generalisation)") for v in verdicts),
            "selection_misses": sum(v.endswith("(selection)") for v in verdicts),
            "out_of_reach": sum(v == "out of reach" for v in verdicts),
            "effect_cases": len(effect_rows),
            "expected_best": sum(singled_out(r) == "yes" for r in effect_rows),
            "errors": sum(v == "error" for v in verdicts), "no_loop": sum(v == "no loop result" for v in verdicts)}


def main(argv=None) -> dict:
    from hybridhyst.testbed.blind_cases import bed_cases
    from hybridhyst.testbed.cases import CASES
    from hybridhyst.testbed.floor import case_floor
    from hybridhyst.testbed.run import RMSE_RATIO, run_bed

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--beds", default="blind,blind2", help="comma-separated beds: first, blind, blind2 "
                    "(default blind,blind2)")
    ap.add_argument("--cases", help="comma-separated case names (default: every case of the beds)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--json", metavar="PATH", help="write the rows and the tallies as JSON")
    ap.add_argument("--with-loop", action="store_true",
                    help="run the loop on each case first (as the bed does) and refit its final model to the held-out "
                         "records too; the loop's columns then come from this run, not the committed tables")
    ap.add_argument("--search", type=int, help="points of each candidate's global search (default: floor.SEARCH)")
    ap.add_argument("--from-json", metavar="PATH", help="write the tables of an earlier run's --json (no fits)")
    ap.add_argument("--write-readme", action="store_true", help=f"write the tables into {README.relative_to(ROOT)}")
    args = ap.parse_args(argv)
    beds = args.beds.split(",")
    unknown_beds = [b for b in beds if b not in LOOP_TABLES]
    if unknown_beds:
        ap.error(f"unknown bed(s) {unknown_beds}; the beds are {sorted(LOOP_TABLES)}")
    by_bed = {b: (list(CASES) if b == "first" else bed_cases(b)) for b in beds}
    wanted = set(args.cases.split(",")) if args.cases else None
    if wanted:
        known = {c.name for cs in by_bed.values() for c in cs}
        if wanted - known:
            ap.error(f"unknown case(s) {sorted(wanted - known)} in the beds {beds}")
        by_bed = {b: [c for c in cs if c.name in wanted] for b, cs in by_bed.items()}
    start = time.perf_counter()
    every = [c for cs in by_bed.values() for c in cs]
    if args.from_json:  # the rows of that run, its header kept
        earlier = json.loads(Path(args.from_json).read_text())
        rows = {r["name"]: r for bed in earlier["beds"].values() for r in bed["rows"]}
        args.with_loop = any(r.get("loop") for r in rows.values())
        missing = [c.name for c in every if c.name not in rows]
        if missing:
            ap.error(f"{args.from_json} has no rows for {missing}")
        header = {k: earlier.get(k) for k in ("command", "date", "code", "wall_s", "jobs", "cores")}
        if args.json:
            ap.error("--from-json writes no JSON: the rows are that file's")
    else:
        options = {**({"loop": True} if args.with_loop else {}), **({"search": args.search} if args.search else {})}
        rows = {r["name"]: r for r in run_bed(every, jobs=args.jobs, task=case_floor, options=options or None)}
        command = "PYTHONPATH=. python scripts/testbed_floor.py " + " ".join(argv if argv is not None
                                                                              else sys.argv[1:])
        header = {"command": command.strip(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                  "code": code_version(), "wall_s": time.perf_counter() - start, "jobs": args.jobs,
                  "cores": os.cpu_count()}
    parts, out = [], {**header, "ratio": RMSE_RATIO, "beds": {}}
    for bed, cases in by_bed.items():
        bed_rows = [rows[c.name] for c in cases]
        if args.with_loop:
            loops = {r["name"]: r["loop"] for r in bed_rows if r.get("loop")}
            source = "this run's loop, the library defaults"
        else:
            loops = loop_rows(bed)
            codes = sorted({loops[c.name]["_code"] for c in cases if c.name in loops})
            source = f"[{LOOP_TABLES[bed]}]({LOOP_TABLES[bed]}), {', '.join(codes)}"
        counts = tally(bed_rows, loops, RMSE_RATIO)
        out["beds"][bed] = {"tally": counts, "loop_source": source, "rows": bed_rows}
        parts.append(f"**{TITLES[bed][0].upper() + TITLES[bed][1:]}** (the loop's columns from {source}): of "
                     f"{counts['cases']} cases, {counts['reachable']} have a structure that reaches {RMSE_RATIO} × "
                     f"noise fitted to the held-out records themselves (the loop's own result counted), "
                     f"{counts['out_of_reach']} do not; the loop meets the target in {counts['loop_meets']} and "
                     f"misses it in {counts['loop_misses']}"
                     + (f"; {counts['errors']} failed" if counts["errors"] else "")
                     + (f"; {counts['no_loop']} have no row in the loop's table" if counts["no_loop"] else "")
                     + (f" ({counts['generalisation_misses']} where its own model refitted to the held-out records "
                        f"reaches it, {counts['selection_misses']} where only another structure does)"
                        if args.with_loop or any(r.get("discovered") is not None for r in bed_rows) else "")
                     + ". In "
                     f"{counts['expected_best']} of {counts['effect_cases']} effect cases the expected effect is the "
                     f"best single library effect on the held-out records.\n\n"
                     + markdown(bed_rows, loops, RMSE_RATIO))
    section = (f"Generated by `{out['command']}` ({out['date']}; {out['code']}; {out['wall_s']:.0f} s wall with "
               f"{out['jobs']} worker(s) on {out.get('cores') or '?'} cores)"
               + (f"; tables written from it by `PYTHONPATH=. python scripts/testbed_floor.py --beds {args.beds} "
                  + (f"--cases {args.cases} " if args.cases else "") + f"--from-json {args.from_json}`"
                  if args.from_json else "") + ".\n\n" + "\n\n".join(parts))
    if args.json and not args.from_json:
        Path(args.json).write_text(json.dumps(out, indent=2, default=str))
    if args.write_readme:
        write_readme(section, bed="floor")
    print(section)
    return out


if __name__ == "__main__":
    main()
