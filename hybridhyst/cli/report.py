"""``hybridhyst-report DIR [DIR ...] [--out OUT] [--title TITLE]``: compare the runs of ``hybridhyst-train``.

Scans the directories recursively for run directories (folders with ``metrics.json``, e.g. a Hydra
``multirun/``) and writes ``report.md``, ``summary.csv``, ``per_condition.csv`` and ``figures/*.png``
to OUT (default: ``report/`` inside the first DIR). A missing directory or one without runs ends with a
one-line ``error: ...`` on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from .common import guarded

__all__ = ["main", "run"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hybridhyst-report",
        description="Compare hybridhyst-train run directories: Markdown and CSV tables, PNG figures.")
    parser.add_argument("dirs", nargs="+", metavar="DIR",
                        help="run directories or folders holding them (searched recursively)")
    parser.add_argument("--out", default=None, help="output folder (default: DIR/report for the first DIR)")
    parser.add_argument("--title", default=None, help="heading of report.md")
    return parser


def run(args: argparse.Namespace) -> dict:
    """Write the report for parsed arguments; returns ``{"report": path of report.md}``."""
    from ..report import write_report

    out = Path(args.out) if args.out else Path(args.dirs[0]) / "report"
    command = shlex.join(["hybridhyst-report", *args.argv])
    return {"report": write_report(args.dirs, out, title=args.title, command=command)}


def main(argv: list[str] | None = None) -> None:
    """Console entry point ``hybridhyst-report``; prints the path of the written ``report.md``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(argv)
    args.argv = argv
    print(guarded(run, args)["report"])


if __name__ == "__main__":
    main()
