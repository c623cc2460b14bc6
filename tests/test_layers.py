"""Import direction: the layers contract in pyproject.toml ([tool.importlinter]), checked by import-linter.

``cli`` → ``studies | testbed`` → ``discover`` → ``training | identify`` → ``synth`` → ``simulate`` →
``physics`` → ``data | nets | analysis | report`` → ``files | settings | progress | units``: nothing imports upward
(also not inside a function), and layers joined by "|" do not import each other.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("importlinter", reason="import-linter is a dev dependency (pip install -e '.[dev]')")

ROOT = Path(__file__).resolve().parents[1]


def lint_imports(root: Path) -> subprocess.CompletedProcess:
    """``lint-imports`` on the ``hybridhyst`` package found under ``root`` with ``root``'s pyproject.toml."""
    env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "HOME": str(root)}
    code = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
    return subprocess.run([sys.executable, "-c", code, "--config", str(root / "pyproject.toml"), "--no-cache"],
                          cwd=root, env=env, capture_output=True, text=True, timeout=300)


def _copy_sources(dest: Path) -> Path:
    shutil.copy(ROOT / "pyproject.toml", dest / "pyproject.toml")
    shutil.copytree(ROOT / "hybridhyst", dest / "hybridhyst", ignore=shutil.ignore_patterns("files", "__pycache__"))
    return dest


def test_the_package_keeps_its_layers():
    result = lint_imports(ROOT)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert "Contracts: 1 kept, 0 broken." in result.stdout


@pytest.mark.parametrize("module, line", [
    ("data/_probe.py", "def f():\n    from ..simulate import simulate\n"),  # upward, inside a function
    ("physics/_probe.py", "import hybridhyst.cli.common\n"),  # absolute, from the bottom to the top
    ("nets/_probe.py", "from ..analysis import rmse\n"),  # between independent layers
])
def test_a_wrong_import_breaks_the_contract(tmp_path, module, line):
    root = _copy_sources(tmp_path)
    (root / "hybridhyst" / module).write_text(line)
    result = lint_imports(root)
    assert result.returncode != 0 and "BROKEN" in result.stdout, result.stdout[-3000:]
    assert f"hybridhyst.{module[:-3].replace('/', '.')}" in result.stdout
