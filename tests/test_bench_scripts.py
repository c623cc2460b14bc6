"""Smoke test of the benchmark scripts (a quick run, not a timing: speed is shown by the scripts themselves)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script: str, tmp_path: Path, *extra: str) -> dict:
    out = tmp_path / "bench.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    subprocess.run([sys.executable, str(ROOT / "scripts" / script), "--quick", "--json", str(out), *extra],
                   cwd=ROOT, env=env, check=True, capture_output=True, timeout=300)
    return json.loads(out.read_text())


def test_bench_simulate_quick_writes_the_expected_json(tmp_path):
    res = _run("bench_simulate.py", tmp_path)
    assert {"command", "machine", "gradient_ratio", "throughput", "skipped", "scaling"} <= set(res)
    g = res["gradient_ratio"]
    assert {"fast_s", "reference_s", "ratio", "first_fast_call_s", "max_rel_grad_difference"} <= set(g)
    assert g["fast_s"] > 0 and g["ratio"] > 1 and g["max_rel_grad_difference"] < 1e-6
    rows = res["throughput"]
    assert {(r["backend"], r["mode"]) for r in rows} == {(b, m) for b in ("fast", "reference")
                                                         for m in ("forward", "gradient")}
    assert all(r["time_s"] > 0 and r["us_per_sample_step"] > 0 for r in rows)


def test_bench_simulate_readme_section_is_replaced_between_markers(tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        from bench_simulate import write_readme_section
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    readme = tmp_path / "README.md"
    readme.write_text("# P\n\n<!-- x:start -->\nold\n<!-- x:end -->\ntail\n")
    write_readme_section("x", "new table", readme)
    assert readme.read_text() == "# P\n\n<!-- x:start -->\nnew table\n<!-- x:end -->\ntail\n"
    write_readme_section("y", "other", readme)
    assert "<!-- y:start -->\nother\n<!-- y:end -->" in readme.read_text()


@pytest.mark.slow
def test_bench_identify_quick_writes_the_expected_json(tmp_path):
    res = _run("bench_identify.py", tmp_path, "--skip-joint")
    single = res["single"]["tight"]
    assert {"hybridhyst", "scipy", "ratio", "floor", "bounds"} <= set(single)
    assert single["hybridhyst"]["rmse"] < 1.0 and len(single["bounds"]) == 11


def test_bench_neural_quick_measures_every_path(tmp_path):
    res = _run("bench_neural.py", tmp_path)
    paths = {(r["model"], r["path"], r["mode"]) for r in res["rows"]}
    assert paths == {(m, p, mode) for m, p in (("nominal", "fast"), ("nominal", "reference"), ("neural", "reference"))
                     for mode in ("forward", "gradient")}
    assert all(r["us_per_sample_step"] > 0 for r in res["rows"])
    assert {r["batch"] for r in res["ratios"]} == {1, 16}
