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


def test_the_readme_block_is_what_the_committed_summary_renders():
    summary = json.loads((mr.FOLDER / "summary.json").read_text())
    text = (mr.FOLDER / "README.md").read_text()
    block = text.split("<!-- mr:start -->\n")[1].split("\n<!-- mr:end -->")[0]
    assert block == mr.render(summary)
    assert [r["name"] for r in summary["runs"]] == list(mr.RUNS)
