"""Import direction: lower packages never import the ones above them (read from the source, every import)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hybridhyst"

# package -> packages it must never import (checked so far; the full order is issue 13's)
FORBIDDEN = {
    "discover": {"cli", "training", "studies"},
    "identify": {"cli", "discover", "studies"},
    "simulate": {"cli", "discover", "identify", "training", "studies"},
    "analysis": {"cli", "discover", "identify", "training", "studies", "simulate"},
    "files": {"cli", "discover", "identify", "training", "studies", "simulate", "physics", "data"},
}


def imported_packages(path: Path) -> set[str]:
    """The first-level ``hybridhyst`` subpackages a module imports (relative or absolute, at any depth)."""
    module = path.relative_to(PACKAGE.parent).with_suffix("").parts  # ("hybridhyst", "discover", "loop")
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(module[: len(module) - node.level])
                target = base + (node.module.split(".") if node.module else [])
                names = [".".join(target + [a.name]) if not node.module else ".".join(target) for a in node.names]
            elif node.module:
                names = [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "hybridhyst" and len(parts) > 1:
                found.add(parts[1])
    return found


def _modules(package: str) -> list[Path]:
    root = PACKAGE / package
    return sorted(root.rglob("*.py")) if root.is_dir() else [PACKAGE / f"{package}.py"]


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_lower_packages_do_not_import_upwards(package):
    bad = {str(p.relative_to(PACKAGE)): sorted(imported_packages(p) & FORBIDDEN[package]) for p in _modules(package)}
    assert not {k: v for k, v in bad.items() if v}, f"{package}/ imports upwards: {bad}"


def test_the_checker_sees_relative_and_absolute_imports(tmp_path):
    probe = PACKAGE / "discover" / "_probe_layers.py"
    probe.write_text("from ..cli.common import atomic_write\n\n\ndef f():\n    import hybridhyst.training.base\n")
    try:
        assert {"cli", "training"} <= imported_packages(probe)
    finally:
        probe.unlink()
