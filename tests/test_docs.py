"""The documentation (README.md and docs/) stays true to the repository: its generated parts are what their scripts
write, its links resolve, it cites only files the repository holds, and the routes it documents work."""

from __future__ import annotations

import importlib.util
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
PAGES = [README, *sorted(DOCS.glob("*.md"))]


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


# ----------------------------------------------------------------------------------------------- generated parts
def test_the_layer_diagram_is_current():
    layers = _script("docs_layers")
    doc = layers.TARGET.read_text(encoding="utf-8")
    assert layers.replaced(doc, layers.render()) == doc, (
        "docs/architecture.md's layer diagram differs from pyproject.toml's contract; "
        "run python scripts/docs_layers.py")


def test_the_layer_diagram_follows_the_contract():
    layers = _script("docs_layers")
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    changed = text.replace('"runs",', '"runs | extra",')
    assert "runs | extra" in layers.render(changed) and "runs | extra" not in layers.render(text)


def test_the_effects_doc_is_current():
    effects = _script("docs_effects")
    assert effects.TARGET.read_text(encoding="utf-8") == effects.render(), (
        "docs/effects.md differs from the registries; run PYTHONPATH=. python scripts/docs_effects.py")


def test_every_layer_package_has_its_row():
    layers = _script("docs_layers")
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line.startswith("| `hybridhyst/")]
    for layer in layers.layers():
        for package in layer:
            names = ([f"`hybridhyst/{package}/`"] if (ROOT / "hybridhyst" / package).is_dir()
                     else [f"`hybridhyst/{package}.py`", f"`{package}.py`"])
            assert any(n in row for n in names for row in rows), f"docs/architecture.md has no row for {package}"


# -------------------------------------------------------------------------------------------- the README's limits
def test_the_readme_is_short():
    lines = README.read_text(encoding="utf-8").count("\n")
    assert lines <= 200, f"README.md has {lines} lines; move detail into docs/"


def test_the_two_commands_on_a_fresh_machine_are_what_ci_runs():
    text = README.read_text(encoding="utf-8")
    block = text.split("## Two commands on a fresh machine", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    commands = [line.split("#", 1)[0].strip() for line in block.splitlines() if line.strip()]
    assert commands == ["bash scripts/setup.sh && hybridhyst-discover", "bash scripts/setup.sh && python -m pytest -q"]
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert ci == commands[1], f".ci/run runs {ci!r}, the README says {commands[1]!r}"


# ---------------------------------------------------------------------------------------------------- the links
def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    return {_slug(m) for m in re.findall(r"^#{1,6} (.+)$", path.read_text(encoding="utf-8"), flags=re.M)}


@pytest.mark.parametrize("page", PAGES, ids=[p.name if p == README else f"docs/{p.name}" for p in PAGES])
def test_every_link_resolves(page):
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists() or not dest.resolve().is_relative_to(ROOT):
            broken.append(target)
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(target)
    assert not broken, f"{page.relative_to(ROOT)}: links that lead nowhere: {broken}"


@pytest.mark.parametrize("page", PAGES, ids=[p.name if p == README else f"docs/{p.name}" for p in PAGES])
def test_the_docs_cite_only_files_the_repository_holds(page):
    text = page.read_text(encoding="utf-8")
    outside = sorted(set(re.findall(r"DESIGN\.md|STYLE\.md|\.\./shared", text)))
    assert not outside, f"{page.relative_to(ROOT)} cites {outside}, which the repository does not hold"


def test_the_index_lists_every_page():
    index = (DOCS / "README.md").read_text(encoding="utf-8")
    missing = [p.name for p in DOCS.glob("*.md") if p.name != "README.md" and f"({p.name})" not in index]
    assert not missing, f"docs/README.md does not link {missing}"


def test_the_extending_checklists_name_real_tests():
    text = (DOCS / "extending.md").read_text(encoding="utf-8")
    named = re.findall(r"\*Tests?:\*(.*?)(?:\n- \[|\n\n|$)", text, flags=re.S)
    assert named, "docs/extending.md names no test"
    for group in named:
        for ref in re.findall(r"`([\w/]+\.py::)?(test_\w+)`", group):
            file = ROOT / (ref[0].removesuffix("::") if ref[0] else "tests/test_extending.py")
            assert re.search(rf"^def {ref[1]}\(", file.read_text(encoding="utf-8"), flags=re.M), (
                f"docs/extending.md names {ref[1]}, which {file.relative_to(ROOT)} does not define")


# ---------------------------------------------------------------------------------------- documented routes work
def test_the_readme_example_is_the_documented_discover_command():
    from tests.test_own_data import readme_commands

    text = README.read_text(encoding="utf-8")
    block = text.split("## Your own data", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    words = shlex.split(block.replace("\\\n", " "))
    assert words[0] == "hybridhyst-discover" and words[1:] == readme_commands()["discover"]


def _own_data_route() -> tuple[str, list[str]]:
    """The data config (YAML) and the command of docs/own-data.md's "npz and MAT files"."""
    text = (DOCS / "own-data.md").read_text(encoding="utf-8").split("## npz and MAT files", 1)[1].split("\n## ", 1)[0]
    config = text.split("```yaml\n", 1)[1].split("```", 1)[0]
    command = shlex.split(text.split("```bash\n", 1)[1].split("```", 1)[0].replace("\\\n", " "), comments=True)
    return config, command


@pytest.mark.parametrize("suffix", [".npz", ".mat"])
def test_the_npz_and_mat_route_reads_the_example(suffix, tmp_path):
    import scipy.io
    import yaml
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli.common import CONF_DIR
    from hybridhyst.data import read_table
    from hybridhyst.training.config import instantiate

    csv = ROOT / "examples" / "own_data" / "damper_loops.csv"
    runs = tmp_path / "runs"
    runs.mkdir()
    for name, part in pd.read_csv(csv).groupby("record", sort=False):
        arrays = {"t": part["t"].to_numpy(), "angle_deg": part["angle_deg"].to_numpy(),
                  "torque_nm": part["torque_nm"].to_numpy(), "pressure_mpa": np.array(part["pressure_mpa"].iloc[0])}
        if suffix == ".npz":
            np.savez(runs / f"{name}{suffix}", **arrays)
        else:
            scipy.io.savemat(runs / f"{name}{suffix}", arrays)
    text, command = _own_data_route()
    config = yaml.safe_load(text)
    config["path"] = str(runs / f"*{suffix}")
    if suffix == ".mat":
        config["_target_"] = "hybridhyst.data.read_mat"
    search = next(w for w in command if w.startswith("hydra.searchpath="))
    folder = tmp_path / re.search(r"file://([^\]]+)\]", search).group(1)
    name = next(w.split("=", 1)[1] for w in command if w.startswith("data="))
    (folder / "data").mkdir(parents=True)
    (folder / "data" / f"{name}.yaml").write_text(yaml.safe_dump(config), encoding="utf-8")
    overrides = [f"hydra.searchpath=[file://{folder}]", *[w for w in command[1:] if not w.startswith("hydra.")]]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(command[0].removeprefix("hybridhyst-"), overrides=overrides)
    records = instantiate(cfg.data, _convert_="all")
    table = read_table(csv, record="record", input="angle_deg", output="torque_nm", conditions=["pressure_mpa"])
    assert records.names == table.names
    for got, want in zip(records, table):
        assert got.conditions == pytest.approx(want.conditions) and got.units == {"t": "s", "x": "deg", "y": "Nm"}
        np.testing.assert_allclose(got.y, want.y)
