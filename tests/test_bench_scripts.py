"""Smoke runs of the benchmark scripts. Speed is never asserted (wall-clock numbers depend on the machine and
its load; the scripts report them): the tests check what the runs must get right whatever the timing — the
JSON's keys and shapes, every derived number consistent with the timings it is made of (a ratio is finite,
positive and the quotient of the two times it compares), the Markdown tables that render from the JSON, and
the accuracy fields within their tolerances (fast and reference gradients agree; the identified parameters
lie in their bounds and reach the noise floor, checked again by the script's independent numpy RK4).

The ``--quick`` runs are subprocesses of 8-18 s each: they run with ``-m slow`` (before a benchmark's output is
regenerated and before an issue is closed), the markdown helpers by default."""

import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"


def _run(script: str, tmp_path: Path, *extra: str) -> tuple[dict, str]:
    """The script's ``--quick`` run: its JSON and its standard output."""
    out = tmp_path / "bench.json"
    env = dict(os.environ)  # PYTHONPATH names this checkout (conftest.py)
    done = subprocess.run([sys.executable, str(SCRIPTS / script), "--quick", "--json", str(out), *extra],
                          cwd=ROOT, env=env, check=True, capture_output=True, text=True, timeout=1200)
    return json.loads(out.read_text()), done.stdout


def _script(name: str):
    """Import ``scripts/<name>.py`` as a module (the scripts are not a package)."""
    sys.path.insert(0, str(SCRIPTS))  # bench_identify imports bench_simulate
    try:
        spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(SCRIPTS))
    return module


def _positive(*values) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in values)


def _per_sample_step_is_consistent(row: dict) -> bool:
    return row["us_per_sample_step"] == pytest.approx(row["time_s"] / (row["batch"] * (row["length"] - 1)) * 1e6)


@pytest.mark.slow
def test_bench_simulate_quick_writes_consistent_json_and_tables(tmp_path):
    res, stdout = _run("bench_simulate.py", tmp_path)
    bench = _script("bench_simulate")
    assert {"command", "machine", "gradient_ratio", "throughput", "skipped", "scaling"} <= set(res)
    assert res["quick"] is True and res["skipped"] == []  # the quick grid is far below the memory and time caps
    g = res["gradient_ratio"]
    assert g["length"] == 400 and (g["fast_repeats"], g["reference_repeats"]) == (5, 1)
    assert g["n_parameters"] == sum(p.numel() for p in bench.make_model().parameters())
    assert _positive(g["fast_s"], g["reference_s"], g["first_fast_call_s"], g["ratio"])
    assert g["ratio"] == pytest.approx(g["reference_s"] / g["fast_s"])
    assert 0 <= g["max_rel_grad_difference"] < 1e-6  # accuracy: the compiled adjoint gives the reference gradient
    rows = res["throughput"]
    assert sorted((r["backend"], r["batch"], r["length"], r["mode"]) for r in rows) == sorted(
        [("fast", b, 500, m) for b in (1, 16) for m in ("forward", "gradient")]
        + [("reference", 1, 500, m) for m in ("forward", "gradient")])
    assert all(_positive(r["time_s"], r["us_per_sample_step"]) and _per_sample_step_is_consistent(r) for r in rows)
    for mode in ("forward", "gradient"):  # the scaling summary restates the fast rows at the one length
        per = res["scaling"][f"{mode}_per_sample_vs_batch"]
        fast = {str(r["batch"]): r["us_per_sample_step"] for r in rows if r["backend"] == "fast" and r["mode"] == mode}
        assert per["length"] == 500 and per["us_per_sample_step"] == pytest.approx(fast)
    # the Markdown printed is the one rendered from the JSON, with one table row per (path, batch)
    assert bench.report_markdown(res) in stdout
    assert f"| **ratio** | **{g['ratio']:.0f}×**" in stdout
    table = [[cell.strip() for cell in line.split("|")[1:4]] for line in stdout.splitlines()
             if line.startswith(("| fast |", "| reference |"))]
    assert sorted(table) == [["fast", "1", "500"], ["fast", "16", "500"], ["reference", "1", "500"]]


def test_bench_simulate_readme_section_is_replaced_between_markers(tmp_path):
    write_readme_section = _script("bench_simulate").write_readme_section
    readme = tmp_path / "README.md"
    readme.write_text("# P\n\n<!-- x:start -->\nold\n<!-- x:end -->\ntail\n")
    write_readme_section("x", "new table", readme)
    assert readme.read_text() == "# P\n\n<!-- x:start -->\nnew table\n<!-- x:end -->\ntail\n"
    write_readme_section("y", "other", readme)
    assert "<!-- y:start -->\nother\n<!-- y:end -->" in readme.read_text()


@pytest.mark.slow
def test_bench_identify_quick_reaches_the_noise_floor_inside_the_bounds(tmp_path):
    res, stdout = _run("bench_identify.py", tmp_path, "--skip-joint")
    bench = _script("bench_identify")
    assert set(res["single"]) == {"tight"} and "joint" not in res
    single = res["single"]["tight"]
    assert {"hybridhyst", "scipy", "ratio", "floor", "bounds", "samples", "n_parameters"} <= set(single)
    assert single["floor"] == pytest.approx(1.02 * 0.2) and single["n_parameters"] == len(single["bounds"]) == 11
    ours, scipy = single["hybridhyst"], single["scipy"]
    assert _positive(ours["wall_s"], scipy["wall_s"], single["ratio"], ours["rmse"], scipy["rmse"])
    assert single["ratio"] == pytest.approx(scipy["wall_s"] / ours["wall_s"])
    # accuracy: the identified parameters are admissible and reach the floor (no time cap on hybridhyst's
    # attempts, so this does not depend on the machine; scipy's run is capped at 20 s and may stop short)
    for fit in (ours, scipy):
        assert set(fit["x"]) == set(single["bounds"])
        assert all(lo <= fit["x"][name] <= hi for name, (lo, hi) in single["bounds"].items())
    assert ours["reached_floor"] and ours["rmse"] <= single["floor"]
    assert ours["per_record"] == {bench.load_records([bench.PRESSURE]).records[0].name: pytest.approx(ours["rmse"])}
    # the RMSE hybridhyst reports is the one the script's numpy RK4 of the same law gives at its parameters
    record = bench.load_records([bench.PRESSURE]).records[0]
    assert len(record) == single["samples"]
    theta = np.array([[ours["x"][f"{e}.{n}"] for e, n, _, _ in bench.BOUNDS]])
    assert bench.numpy_rmse(theta, bench.rk4_inputs(record))[0] == pytest.approx(ours["rmse"], rel=1e-6)
    assert bench.report_markdown(res) in stdout and f"**{single['ratio']:.0f}×** tuned" in stdout


@pytest.mark.slow
def test_bench_neural_quick_measures_every_path_consistently(tmp_path):
    res, _ = _run("bench_neural.py", tmp_path)
    bench = _script("bench_neural")
    rows = res["rows"]
    cpu = [r for r in rows if r["device"] == "cpu"]
    assert sorted((r["model"], r["path"], r["batch"], r["mode"]) for r in cpu) == sorted(
        (m, p, b, mode) for m in ("nominal", "neural") for p in ("fast", "reference")
        for b in (1, 16) for mode in ("forward", "gradient"))
    assert all(r["length"] == 200 and _positive(r["time_s"], r["us_per_sample_step"])
               and _per_sample_step_is_consistent(r) for r in rows)
    # one ratio per neural row, the quotient of its time and the compiled nominal's at the same batch and mode;
    # for the compiled network also the batched loop's time over its own
    time_of = {(r["device"], r["model"], r["path"], r["batch"], r["mode"]): r["time_s"] for r in rows}
    neural = {(r["device"], r["path"], r["batch"], r["mode"]) for r in rows if r["model"] == "neural"}
    assert {(x["device"], x["path"], x["batch"], x["mode"]) for x in res["ratios"]} == neural
    for x in res["ratios"]:
        own = time_of[(x["device"], "neural", x["path"], x["batch"], x["mode"])]
        assert x["neural_over_nominal_fast"] == pytest.approx(own / time_of[("cpu", "nominal", "fast", x["batch"],
                                                                              x["mode"])])
        if x["path"] == "fast":
            assert x["reference_over_fast"] == pytest.approx(
                time_of[("cpu", "neural", "reference", x["batch"], x["mode"])] / own)
    table = bench.markdown(res)  # the README block renders a row per (device, model, path, batch)
    assert table.startswith(bench.BEGIN) and table.endswith(bench.END)
    assert sum(line.startswith("| cpu |") for line in table.splitlines()) == len(cpu) // 2


@pytest.mark.slow
def test_bench_jacobian_quick_agrees_with_finite_differences_and_reports_its_ratios(tmp_path):
    res, stdout = _run("bench_jacobian.py", tmp_path)
    bench = _script("bench_jacobian")
    assert [(r["problem"], r["substeps"], r["rows"]) for r in res["rows"]] == [("seed001", 1, bench.ROWS),
                                                                              ("delay", 1, bench.ROWS)]
    for row in res["rows"]:  # the delay's: its input moves with a coordinate
        assert _positive(row["simulation_s"], row["exact_s"], row["finite_differences_s"])
        assert row["exact_over_simulation"] == pytest.approx(row["exact_s"] / row["simulation_s"])
        assert row["fd_over_exact"] == pytest.approx(row["finite_differences_s"] / row["exact_s"])
        # every coordinate's column: the exact Jacobian equals forward differences to their truncation error
        assert len(row["column_difference"]) == row["coordinates"] and row["columns_below_floor"] == 0
        assert row["column_difference_max"] < 1e-3
        lm = row["lm"]  # the same path either way; the exact Jacobian simulates one row per Jacobian, not F + 1
        # (the delay's path parts from the differences' by their error in its column, ~1e-6, after 25 iterations)
        same = 1e-5 if row["problem"] == "seed001" else 1e-3
        assert lm["exact"]["cost"] == pytest.approx(lm["finite_differences"]["cost"], rel=same)
        assert lm["exact"]["evaluations"] < lm["finite_differences"]["evaluations"]
    assert bench.report_markdown(res) in stdout


@pytest.mark.slow
def test_bench_build_quick_times_first_calls_of_models_never_built(tmp_path):
    res, stdout = _run("bench_build.py", tmp_path)
    bench = _script("bench_build")
    assert len(res["models"]) == 3 and "main_job" not in res
    for m in res["models"].values():
        assert _positive(m["values_s"], m["gradient_s"]) and m["gradient_s"] >= m["values_s"]
    s = res["side_by_side"]
    assert s["models"] == 3 and _positive(s["together_s"], s["one_after_another_s"])
    assert bench.markdown(res) in stdout


@pytest.mark.slow
def test_bench_peers_quick_agrees_with_jax_and_reports_ratios(tmp_path):
    res, stdout = _run("bench_peers.py", tmp_path)
    bench = _script("bench_peers")
    (row,) = res["rows"]
    ours = row["peers"]["hybridhyst (compiled C, discrete adjoint)"]
    assert _positive(ours["first_s"], ours["call_s"])
    for name, peer in row["peers"].items():
        if peer.get("call_s") is None:
            assert "not installed" in peer["note"]  # JAX is an optional benchmark dependency
            continue
        assert peer["call_ratio"] == pytest.approx(peer["call_s"] / ours["call_s"])
        if name.startswith("JAX"):  # the same classic RK4 written independently: the same gradient
            assert peer["max_rel_grad_diff"] < 1e-8 and peer["max_rel_y_diff"] < 1e-10
        elif name.startswith("torchdiffeq"):  # the 3/8 rule: the method's own error, small on this grid
            assert peer["max_rel_y_diff"] < 0.05
    assert bench.markdown(res) in stdout


@pytest.mark.slow
def test_bench_training_quick_times_epochs_of_every_module_on_the_same_windows(tmp_path):
    res, stdout = _run("bench_training.py", tmp_path)
    bench = _script("bench_training")
    assert set(res["rows"]) == set(bench.MODULES)
    windows = {row["windows"] for row in res["rows"].values()}
    assert len(windows) == 1  # the same windows for every module
    for row in res["rows"].values():
        assert _positive(row["cpu"]["epoch_s"]) and len(row["cpu"]["all_epochs_s"]) == res["epochs"]
    assert res["rows"]["LSTM (2×64)"]["cpu"]["ratio_to_lstm"] == 1.0
    assert bench.markdown(res) in stdout


@pytest.mark.slow
def test_bench_tests_quick_runs_the_test_command_in_an_empty_cache(tmp_path):
    res, stdout = _run("bench_tests.py", tmp_path)
    assert res["returncode"] == 0 and "1 passed" in res["summary"] and res["models_built"] == 0
    assert _positive(res["wall_s"]) and res["command"].startswith("python -m pytest -q")
    assert f"{res['wall_s']:.0f} s wall" in stdout and "target 6 min: met" in stdout
    failed = {**res, "returncode": 1}
    assert "**not met**" in _script("bench_tests").markdown(failed)


@pytest.mark.slow
def test_bench_screen_quick_fits_one_candidate_both_ways_on_the_same_record(tmp_path):
    res, stdout = _run("bench_screen.py", tmp_path)
    bench = _script("bench_screen")
    (row,) = res["rows"]
    assert row["candidate"] == "bouc_wen" and row["samples"] == bench.QUICK_SAMPLES
    assert row["screen_samples"] == bench.QUICK_SCREEN < row["samples"] and row["active"]  # the screen cut it
    s, w = row["screened"], row["whole"]
    assert _positive(s["seconds"], w["seconds"]) and row["ratio"] == pytest.approx(w["seconds"] / s["seconds"])
    assert row["rmse_ratio"] == pytest.approx(s["rmse"] / w["rmse"])
    assert s["rmse"] < 0.1 * res["nominal_rmse"]  # the hysteretic term found, screened
    assert bench.markdown(res) in stdout
