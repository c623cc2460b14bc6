"""The README's test command from an empty compile cache, as a fresh machine runs it: ``python -m pytest -q`` (the
default selection: no ``slow`` tests, up to 4 processes) with ``HYBRIDHYST_CACHE`` pointing at a new, empty
directory, so that every model the tests simulate is generated and built by the C compiler on the way; its wall
time and the tests' own summary line.

    PYTHONPATH=. python scripts/bench_tests.py --json experiments/performance/bench_tests.json --write-readme

``--quick``: one small test in one process (a smoke version).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))  # bench_simulate

TARGET_S = 360.0  # the bound for this run on CI's 2 cores


def run(quick: bool) -> dict:
    from bench_simulate import machine_brief

    target = ["-n", "0", "tests/test_identify_space.py", "-k", "logits"] if quick else []
    machine = machine_brief()  # the load at the start, before the tests load the machine
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "HYBRIDHYST_CACHE": cache}
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *target], cwd=ROOT,
                              env=env, capture_output=True, text=True)
        wall = time.perf_counter() - start
        built = len(list((Path(cache) / "fast").glob("eq_*.forward.*.txt")))  # a model's values: its first loop
    lines = [ln for ln in done.stdout.splitlines() if ln.strip()]
    return {**machine, "command": " ".join(["python -m pytest -q", *target]), "returncode": done.returncode,
            "wall_s": wall, "models_built": built, "summary": lines[-1] if lines else "", "target_s": TARGET_S}


def markdown(res: dict) -> str:
    from bench_simulate import cores

    verdict = "met" if res["wall_s"] <= res["target_s"] and res["returncode"] == 0 else "**not met**"
    return (f"The README's test command (`{res['command']}`) with an empty compile cache ({cores(res)}, "
            f"load average at the start {res['load_average_at_start']}): {res['wall_s']:.0f} s wall, "
            f"{res['models_built']} models built on the way; the tests' summary: `{res['summary']}` "
            f"(target {res['target_s'] / 60:.0f} min: {verdict}).")


def main(argv=None) -> dict:
    from bench_simulate import simple_main

    return simple_main(argv, __doc__, "bench_tests", run, markdown)


if __name__ == "__main__":
    main()
