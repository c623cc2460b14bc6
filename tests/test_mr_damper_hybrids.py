"""The MR damper trial's generator (scripts/mr_damper_hybrids.py): independent of the library, right on a known
solution, and the experiment README's block is what the committed summary renders."""

from __future__ import annotations

import ast
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "mr_damper_hybrids.py"


def _script():
    spec = importlib.util.spec_from_file_location("mr_damper_hybrids", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


mr = _script()


def test_the_generator_imports_nothing_from_the_library():
    names = set()
    for node in ast.walk(ast.parse(SCRIPT.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            names.add((node.module or "").split(".")[0])
    assert "hybridhyst" not in names


def test_the_virgin_loading_is_the_bouc_wen_n2_solution():
    """From z = 0 with x rising, n = 2 and A = 1 give dz/dx = 1 − (β + γ) z², so z = tanh(√(β+γ) x) / √(β+γ):
    the generator's noise-free force over the first quarter cycle is c ẋ + α z + k x with that z."""
    current, freq, amp = 0.75, 2.0, 6.0
    t, x, force = mr.clean(current, freq, amp)
    quarter = t <= 1 / (4 * freq)
    root = np.sqrt(mr.BETA + mr.GAMMA)
    v = amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t)
    exact = mr.damping(current) * v + mr.hysteretic(current) * np.tanh(root * x) / root + mr.K * x
    assert np.abs(force[quarter] - exact[quarter]).max() < 1e-6 * np.abs(exact).max()
    assert mr.damping(1.5) > mr.damping(0.0) and mr.hysteretic(1.5) > mr.hysteretic(0.0)  # the current matters


def test_the_unloading_branch_is_the_bouc_wen_n2_solution():
    """After the first reversal (ẋ < 0, z > 0) n = 2 gives dz/dx = 1 + (β − γ) z² (β ≠ γ tells the terms apart):
    with k² = β − γ > 0, z = tan(k (x − x_r) + arctan(k z_r)) / k from the reversal (x_r, z_r), until z reaches 0."""
    current, freq, amp = 1.0, 1.0, 10.0
    t, x, force = mr.clean(current, freq, amp)
    v = amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t)
    z = (force - mr.damping(current) * v - mr.K * x) / mr.hysteretic(current)
    k = np.sqrt(mr.BETA - mr.GAMMA)
    i_r = int(np.argmin(np.abs(t - 1 / (4 * freq))))  # the reversal at x = amp (a sample exactly)
    angle = k * (x - x[i_r]) + np.arctan(k * z[i_r])
    exact = np.tan(angle) / k
    branch = (t > t[i_r]) & (t < 3 / (4 * freq)) & (angle > 0.01)  # from the reversal until z = 0
    assert branch.sum() > 20 and np.abs(z[branch] - exact[branch]).max() < 1e-6


def test_the_generator_s_laws_noise_and_split(monkeypatch):
    assert mr.damping(0.0) == 0.8 and abs(mr.damping(50.0) - 2.8) < 1e-12
    assert mr.hysteretic(0.0) == 20.0 and abs(mr.hysteretic(50.0) - 80.0) < 1e-12
    assert set(mr.HELD_OUT) < set(mr.CURRENTS)
    rng = np.random.default_rng(1)
    base = mr.clean(0.0, 1.0, 1e-9)
    monkeypatch.setattr(mr, "clean", lambda *args: base)  # one ODE solve: record() adds its noise to clean()
    noise = np.concatenate([mr.record(0.0, 1.0, 1e-9, rng)[2] - base[2] for _ in range(20)])
    assert abs(noise.std() - mr.NOISE_SD) < 0.15 * mr.NOISE_SD
    lag1 = np.corrcoef(noise[:-1], noise[1:])[0, 1]
    assert abs(lag1 - mr.NOISE_AR) < 0.05


def test_the_readme_block_is_what_the_committed_summary_renders():
    summary = json.loads((mr.FOLDER / "summary.json").read_text())
    text = (mr.FOLDER / "README.md").read_text()
    block = text.split("<!-- mr:start -->\n")[1].split("\n<!-- mr:end -->")[0]
    assert block == mr.render(summary)
    assert [r["name"] for r in summary["runs"]] == list(mr.RUNS)
