"""Every case of issue 36 ("runs a user can trust"), run and counted per section: cases handled / cases tried.

The cases are the parametrized tests of ``tests/test_trust_*.py`` (one test id a case; the other tests there
check the mechanisms behind them and are run, not counted); this script runs them
with pytest and prints, per section, how many passed. A case passes when the app does what it should: a
one-line error naming what is wrong and the fix (data, config), a non-zero exit naming records and samples
(divergence), nothing run from a planted file (code), a signal that ends the run with a non-zero exit and a
resumable state (interruption), a second run refused (concurrency).

    python scripts/trust_matrix.py            # all sections, about 5 minutes on 2 cores
    python scripts/trust_matrix.py --json experiments/trust_matrix.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# section -> (test file, prefix of the name of the test function whose parametrizations are the cases)
SECTIONS = {
    "data": ("tests/test_trust_data.py", "test_data_mistake"),
    "config": ("tests/test_trust_config.py", "test_config_mistake"),
    "divergence": ("tests/test_trust_divergence.py", "test_a_diverged_simulation"),
    "code from files": ("tests/test_trust_runs.py", "test_code"),
    "interruption": ("tests/test_trust_runs.py", "test_interruption"),
    "concurrency": ("tests/test_trust_runs.py", "test_concurrency"),
}


def _section(case: ET.Element) -> str | None:
    file = case.get("classname", "").replace(".", "/") + ".py"
    name = case.get("name", "")
    for section, (path, prefix) in SECTIONS.items():
        if file == path and (prefix is None or name.startswith(prefix)):
            return section
    return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="also write the counts and each case's outcome to this file")
    parser.add_argument("-n", default="2", help="pytest-xdist processes (default 2)")
    args = parser.parse_args(argv)
    files = sorted({path for path, _ in SECTIONS.values()})
    with tempfile.TemporaryDirectory() as tmp:
        xml = Path(tmp) / "trust.xml"
        subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", args.n,
                        "--dist", "loadfile", f"--junitxml={xml}", *files], cwd=ROOT, check=False)
        root = ET.parse(xml).getroot()
    tried, handled, cases = Counter(), Counter(), {}
    for case in root.iter("testcase"):
        section = _section(case)
        if section is None:
            continue
        outcome = "failed" if case.find("failure") is not None or case.find("error") is not None else (
            "skipped" if case.find("skipped") is not None else "passed")
        tried[section] += 1
        handled[section] += outcome == "passed"
        cases[f"{case.get('classname')}::{case.get('name')}"] = outcome
    print("\nsection                cases handled / cases tried")
    for section in SECTIONS:
        print(f"  {section:<20} {handled[section]:>3} / {tried[section]}")
    total_h, total_t = sum(handled.values()), sum(tried.values())
    print(f"  {'all':<20} {total_h:>3} / {total_t}")
    if args.json:
        Path(args.json).write_text(json.dumps({"sections": {s: {"handled": handled[s], "tried": tried[s]}
                                                            for s in SECTIONS}, "cases": cases}, indent=2) + "\n")
    return 0 if total_h == total_t else 1


if __name__ == "__main__":
    sys.exit(main())
