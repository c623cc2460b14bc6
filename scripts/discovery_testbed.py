"""The independent discovery test bed: data from generators that share no code with the library
(``hybridhyst/testbed``), every case run through ``discover`` with the library defaults, scored against
the truth. Writes the table into ``experiments/discovery_testbed/README.md`` (between markers) and
``--json``.

    PYTHONPATH=. python scripts/discovery_testbed.py --json /tmp/testbed.json --write-readme
    PYTHONPATH=. python scripts/discovery_testbed.py --cases coulomb,dahl --jobs 1
    PYTHONPATH=. python scripts/discovery_testbed.py --fast        # the two small cases of the default tests
    PYTHONPATH=. python scripts/discovery_testbed.py --bed blind --json experiments/discovery_testbed/blind.json \
        --write-readme   # the blind bed: once, with the loop final
    PYTHONPATH=. python scripts/discovery_testbed.py --bed blind2 --json experiments/discovery_testbed/blind2.json \
        --write-readme   # the second blind bed, likewise
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

README = ROOT / "experiments" / "discovery_testbed" / "README.md"
MARKERS = {"first": ("<!-- results:start -->", "<!-- results:end -->"),
           "blind": ("<!-- blind:start -->", "<!-- blind:end -->"),
           "blind2": ("<!-- blind2:start -->", "<!-- blind2:end -->"),
           "floor": ("<!-- floor:start -->", "<!-- floor:end -->")}  # the floor's tables (scripts/testbed_floor.py)


def write_readme(section: str, path: Path = README, bed: str = "first") -> None:
    start, end = MARKERS[bed]
    text = path.read_text()
    a, b = text.index(start) + len(start), text.index(end)
    path.write_text(text[:a] + "\n" + section + "\n" + text[b:])


def code_version() -> str:
    """The commit the bed ran on, and whether the library had uncommitted changes (read-only git calls)."""
    import subprocess

    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "--no-optional-locks", "status", "--porcelain", "--", "hybridhyst"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown commit"
    return f"commit {head}" + (" with uncommitted changes in hybridhyst/" if dirty else "")


def _earlier_cost(path) -> dict[str, float]:
    """Seconds per case of the run this one replaces (its ``--json`` file, if there is one): the workers take the
    costliest cases first. Only the wall time depends on it."""
    try:
        return {r["name"]: float(r["wall_s"]) for r in json.loads(Path(path).read_text())["rows"]}
    except (TypeError, OSError, ValueError, KeyError):
        return {}


def main(argv=None) -> list[dict]:
    from hybridhyst.discover.settings import CROSS_CHECK
    from hybridhyst.discover.validation import VALIDATION
    from hybridhyst.testbed.cases import CASE_BY_NAME, CASES, FAST_CASES
    from hybridhyst.testbed.run import markdown, run_bed, summary

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bed", choices=("first", "blind", "blind2"), default="first",
                    help="which bed: the first (hybridhyst/testbed/cases/, default) or a blind one "
                    "(hybridhyst/testbed/blind/ or blind2/, run once with the loop final: not for tuning)")
    ap.add_argument("--cases", help="comma-separated case names (default: all)")
    ap.add_argument("--fast", action="store_true", help=f"only the small cases {', '.join(FAST_CASES)}")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--json", metavar="PATH", help="write the rows and the summary as JSON")
    ap.add_argument("--validation", choices=VALIDATION, default="records",
                    help="discover's validation for every case (default: records, the library default)")
    ap.add_argument("--cross-check", choices=CROSS_CHECK, default="confirm",
                    help="discover's cross-check for every case (default: confirm, the library default)")
    ap.add_argument("--no-start-states", action="store_true",
                    help="discover without the start-state candidates (start_states=False) for every case")
    ap.add_argument("--further", type=int, default=0,
                    help="discover's further for every case: candidates judged below the top when none of it passes "
                         "(default: 0, the library default)")
    ap.add_argument("--revisit", action="store_true",
                    help="discover's revisit for every case: each added effect tried as a special case of it with one "
                         "more effect once the loop stopped short of the noise (default: off, the library default)")
    ap.add_argument("--write-readme", action="store_true", help=f"write the table into {README.relative_to(ROOT)}")
    args = ap.parse_args(argv)
    if args.write_readme and (args.validation != "records" or args.no_start_states or args.cross_check != "confirm"
                               or args.further or args.revisit):
        ap.error("--write-readme writes the table of the library's defaults; run the other settings with --json")
    if args.bed != "first":
        from hybridhyst.testbed.blind_cases import bed_cases

        CASES = bed_cases(args.bed)  # noqa: N806
        CASE_BY_NAME = {c.name: c for c in CASES}  # noqa: N806
    names = args.cases.split(",") if args.cases else list(FAST_CASES) if args.fast else [c.name for c in CASES]
    unknown = [n for n in names if n not in CASE_BY_NAME]
    if unknown:
        ap.error(f"unknown case(s) {unknown}; the bed has {sorted(CASE_BY_NAME)}")
    start = time.perf_counter()
    options = {**({"validation": args.validation} if args.validation != "records" else {}),
               **({"start_states": False} if args.no_start_states else {}),
               **({"cross_check": args.cross_check} if args.cross_check != "confirm" else {}),
               **({"further": args.further} if args.further else {}),
               **({"revisit": True} if args.revisit else {})} or None
    rows = run_bed([CASE_BY_NAME[n] for n in names], jobs=args.jobs, options=options, cost=_earlier_cost(args.json))
    wall = time.perf_counter() - start
    args_text = " ".join(argv if argv is not None else sys.argv[1:])
    command = f"PYTHONPATH=. python scripts/discovery_testbed.py {args_text}".strip()
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    version = code_version()
    section = (f"Generated by `{command}` ({when}; {version}; {wall:.0f} s wall with {args.jobs} worker(s) on "
               f"{os.cpu_count()} cores).\n\n" + markdown(rows))
    if args.json:
        Path(args.json).write_text(json.dumps({"command": command, "date": when, "code": version, "wall_s": wall,
                                               "jobs": args.jobs,
                                               "summary": summary(rows), "rows": rows}, indent=2, default=str))
    if args.write_readme:
        write_readme(section, bed=args.bed)
    print(section)
    return rows


if __name__ == "__main__":
    main()
