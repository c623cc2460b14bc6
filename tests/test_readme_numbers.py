"""Every number in the documentation's prose — README.md's sections and the pages of docs/ — comes from a committed,
regenerable output (issue 13). No app runs.

1. Every ``<!-- apps:<name>:start -->`` ... ``end`` block of the guides in docs/, experiments/apps/README.md and
   experiments/README.md is exactly what ``scripts/readme_apps.py`` renders from the committed JSON in
   ``experiments/apps/``: a figure edited by hand in a block, or a JSON file changed without re-rendering, fails.
2. Outside those blocks, every number in the prose of the sections (``SECTIONS``: a README section, or a whole
   docs page) must appear in a file its paragraph links (an experiment folder under ``experiments/``, a committed
   file such as SOURCE.md), in the section's configs (``SECTION_SOURCES``: protocol settings such as
   ``fit.steps``), or in the section's short list of figures that are not measurements (``NOT_MEASURED``, each
   with its reason). A figure typed anywhere else fails. Fenced ``bash``/``python`` code is commands and is
   skipped except its ``#`` comments; inline code spans (commands, config keys, paths) are skipped; ``text``
   blocks (terminal output) are prose. A path in backticks is the repository's; a Markdown link is relative to
   its page.
3. The runs of the script are the commands the guides show.
"""

from __future__ import annotations

import importlib.util
import math
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"


def _script():
    spec = importlib.util.spec_from_file_location("readme_apps", ROOT / "scripts" / "readme_apps.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


apps = _script()

# the prose whose numbers are checked, {title: page}: a README section ("## <title>..."), or a whole page of docs/
# (its "# <title>..." heading)
SECTIONS = {
    "The main job": README,
    "Your own data": README,
    "The apps": README,
    "Discovery": DOCS / "discover.md",
    "How the discovery loop works": DOCS / "discovery-loop.md",
    "Fitting a nominal model": DOCS / "fit.md",
    "Your own measurements": DOCS / "own-data.md",
    "Control inputs": DOCS / "controls.md",
    "From Python": DOCS / "python-api.md",
    "Identification": DOCS / "identify.md",
    "Training": DOCS / "train.md",
    "Simulating": DOCS / "simulate.md",
    "Reproducing the seed papers": DOCS / "study.md",
    "Run directories": DOCS / "run-directories.md",
    "Performance": DOCS / "performance.md",
    "Units": DOCS / "units.md",
    "Architecture": DOCS / "architecture.md",
    "Extending the library": DOCS / "extending.md",
    "hybridhyst documentation": DOCS / "README.md",
}
# docs pages written from the code by a script (tests/test_docs.py checks them against it), not prose
GENERATED = {"effects.md"}

# configs and files whose numbers a section may quote without linking them (protocol settings, not results)
SECTION_SOURCES = {
    "The main job": ["conf/discover.yaml", "conf/data/discover/brfd.yaml"],
    "Your own data": ["examples/own_data/make_example.py", "examples/own_data/damper_loops.csv"],
    "The apps": ["conf/data/fit/brfd.yaml"],
    "Discovery": ["conf/discover.yaml", "conf/data/discover/brfd.yaml"],
    "How the discovery loop works": ["conf/discover.yaml", "hybridhyst/discover/fitting.py"],
    "Fitting a nominal model": ["conf/fit.yaml", "conf/data/fit/brfd.yaml"],
    "Your own measurements": ["examples/own_data/make_example.py", "examples/own_data/damper_loops.csv",
                              "conf/fit.yaml", "conf/discover.yaml", "conf/train.yaml", "conf/data/table.yaml"],
    "Control inputs": ["examples/controls/make_example.py", "conf/model/mr_damper_spencer.yaml",
                       "conf/model/mr_damper_voltage.yaml", "conf/data/table.yaml"],
    "From Python": ["tests/test_fast.py"],
    "Identification": ["conf/identify.yaml", "conf/data/identify/vpptd.yaml"],
    "Training": ["conf/train.yaml", "conf/data/train/brfd.yaml", "conf/loss/pinn_recipe.yaml",
                 "conf/sweep/lambda_phys.yaml", "conf/sweep/optuna.yaml"],
    "Simulating": ["conf/simulate.yaml"],
    "Reproducing the seed papers": [],
    "Run directories": [],
    "Performance": [],
    "Units": [],
    "Architecture": [],
    "Extending the library": [],
    "hybridhyst documentation": [],
}

# figures that are not measurements and that no linked file spells the same way: {section: {figure: reason}}
NOT_MEASURED = {
    "The main job": {
        "2": "acceptance margin, conf/discover.yaml margin: 0.02 (2 %); and the 2-core machine",
    },
    "Your own data": {"150": "size of examples/own_data/damper_loops.csv in KB (checked below)"},
    "The apps": {"2": "exit code of a config error (hybridhyst/cli/common.py)"},
    "Run directories": {
        "143": "exit code after SIGTERM (128 + 15, hybridhyst/runs.py)",
        "130": "exit code after Ctrl-C (128 + 2, hybridhyst/runs.py)",
        "0": "the exit code a killed run never has",
        "2": "exit code of a config error or a diverged simulation (hybridhyst/cli/common.py)",
        "1": "trainer.max_epochs=-1, Lightning's no limit",
    },
    "Fitting a nominal model": {"2": "exit code of a config error (hybridhyst/cli/common.py)"},
    "Your own measurements": {
        "150": "size of examples/own_data/damper_loops.csv in KB (checked below)",
        "2": "exit code of a config error (hybridhyst/cli/common.py)",
    },
    "Control inputs": {
        "460": "size of examples/controls/mr_damper_voltage.csv in KB (tests/test_controls_cli.py bounds it)",
        "1997": "the year of Spencer, Dyke, Sain & Carlson's paper",
        "2": "exit code of a config error (hybridhyst/cli/common.py)",
    },
    "From Python": {"9": "the vpptd data set's nine underpressures"},
    "Identification": {"10": "modified_bouc_wen_constant's free parameters (conf/model/)"},
    "Training": {"1": "w_data = 1 (hybridhyst/training/losses.py)", "3": "third-order Taylor expansion"},
}

# identifiers that contain digits but state no figure
IDENTIFIERS = re.compile(r"[Ss]eed ?\d{3}|Table \d+|issue #?\d+|\b\d:\d\b|\bp\d\.\d\d\b")
LIST_MARKER = re.compile(r"^\s*\d+\.(?= )", flags=re.M)  # "1. " of an ordered list
NUMBER = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?(?:[eE][-+−]?\d+)?)(?!\w)")


def page_text(title: str) -> str:
    return SECTIONS[title].read_text(encoding="utf-8")


def section(text: str, title: str) -> str:
    """Section ``title`` of ``text``, the text of its page: a README section, or a docs page after its heading."""
    if SECTIONS[title] == README:
        return apps.readme_section(text, title)
    head, _, body = text.partition("\n")
    assert head.startswith(f"# {title}"), f"{SECTIONS[title].relative_to(ROOT)} should start with '# {title}'"
    return body


def strip_blocks(text: str) -> str:
    return re.sub(r"<!-- apps:(\w+):start -->\n.*?\n<!-- apps:\1:end -->", "\n", text, flags=re.S)


def prose(text: str) -> str:
    """``text`` without generated blocks and commands: fenced bash/python code becomes its ``#`` comments, other
    fences (terminal output) their content, without blank lines, so that paragraphs can be split on them."""
    text = strip_blocks(text)

    def fence(match: re.Match) -> str:
        lang, lines = match.group(1), match.group(2).splitlines()
        if lang in ("bash", "python"):
            lines = [(re.split(r"(?:^|\s)#", line, maxsplit=1) + [""])[1] for line in lines]
        return "\n".join(line for line in lines if line.strip())

    return re.sub(r"^ *```(\w*)\n(.*?)^ *```", fence, text, flags=re.S | re.M)


def without_code(text: str) -> str:
    """``text`` without inline code spans (commands, config keys, paths)."""
    return re.sub(r"`[^`\n]+`", " ", text)


def numbers(text: str) -> list[str]:
    """Number tokens of ``text`` (unsigned; digits inside identifiers such as k2, σ0, seed 001 are not numbers)."""
    return NUMBER.findall(IDENTIFIERS.sub(" ", LIST_MARKER.sub(" ", text.replace("−", "-"))))


def linked(paragraph: str, page: Path = README) -> list[Path]:
    """Committed files a paragraph names (in backticks, from the repository's root, or as a Markdown link, from
    its ``page``): files, and folders under experiments/ (their text files)."""
    out = []
    for ref in re.findall(r"`([^`\s]+)`|\]\(([^)\s#]+)(?:#[^)\s]*)?\)", paragraph):
        path = (ROOT / ref[0]) if ref[0] else (page.parent / ref[1]).resolve()
        if path.is_file():
            out.append(path)
        elif path.is_dir() and path.resolve().is_relative_to(ROOT / "experiments"):
            out += [p for p in sorted(path.rglob("*")) if p.suffix in (".md", ".json", ".csv") and p.is_file()]
    return out


def _values(text: str) -> tuple[set[str], list[float]]:
    tokens = numbers(text)
    return set(tokens), [float(t.replace("−", "-")) for t in tokens]


def quoted_by(token: str, sources: tuple[set[str], list[float]]) -> bool:
    """``token`` is spelt so in a source, or is a source's value rounded to the token's precision."""
    spelt, values = sources
    if token in spelt:
        return True
    value = float(token)
    if "e" in token.lower():
        digits = len(token.lower().split("e")[0].replace(".", "")) - 1
        return any(math.isclose(float(f"{v:.{digits}e}"), value) for v in values)
    if "." not in token:
        return any(v == value for v in values)
    decimals = len(token.split(".")[1])
    return any(math.isclose(round(v, decimals), value, abs_tol=10 ** -(decimals + 3)) for v in values)


def unquoted(text: str, title: str) -> list[str]:
    """Numbers of section ``title`` of ``text``, its page's text (outside generated blocks), that no source quotes."""
    body = section(text, title)
    common = "".join((ROOT / p).read_text(encoding="utf-8") for p in SECTION_SOURCES[title])
    allowed = NOT_MEASURED.get(title, {})
    missing = []
    for paragraph in re.split(r"\n\s*\n", prose(body)):
        found = [t for t in numbers(without_code(paragraph)) if t not in allowed]
        if not found:
            continue
        sources = _values(common + "".join(p.read_text(encoding="utf-8") for p in linked(paragraph, SECTIONS[title])))
        missing += [f"{t!r} in: {' '.join(paragraph.split())[:100]}..." for t in found if not quoted_by(t, sources)]
    return missing


def test_every_docs_page_is_checked():
    pages = {p.name for p in DOCS.glob("*.md")}
    checked = {p.name for p in SECTIONS.values() if p.parent == DOCS}
    assert pages == checked | GENERATED, f"add {sorted(pages - checked - GENERATED)} to SECTIONS (or GENERATED)"


@pytest.mark.parametrize("title", SECTIONS)
def test_every_number_outside_the_blocks_is_quoted_from_a_committed_file(title):
    missing = unquoted(page_text(title), title)
    assert not missing, (f"section {title!r} ({SECTIONS[title].relative_to(ROOT)}) states numbers that no linked "
                         "or committed output holds; put "
                         "them in a generated block (scripts/readme_apps.py) or link the experiment that holds them:\n"
                         + "\n".join(missing))


@pytest.mark.parametrize("title", sorted(NOT_MEASURED))
def test_every_figure_let_through_is_still_in_its_section(title):
    text = page_text(title)
    used = set(numbers(without_code(prose(section(text, title)))))
    assert set(NOT_MEASURED[title]) <= used, f"drop {sorted(set(NOT_MEASURED[title]) - used)} from NOT_MEASURED"


def test_a_number_typed_outside_a_block_fails():
    text = page_text("Simulating")
    body = section(text, "Simulating")
    assert not unquoted(text, "Simulating")
    typed = text.replace(body, body + "\nThe free-vibration frequency is 0.3014 Hz.\n")
    assert any("0.3014" in m for m in unquoted(typed, "Simulating"))
    # a figure that a linked experiment does not hold (its README says 4.41e-6 m)
    text = page_text("The main job")
    body = section(text, "The main job")
    assert "4.41e-6" in body
    typo = text.replace(body, body.replace("4.41e-6", "4.12e-6", 1))
    assert any("4.12e-6" in m for m in unquoted(typo, "The main job"))


@pytest.mark.parametrize(("path", "blocks"), apps.BLOCK_FILES)
def test_the_generated_blocks_are_what_the_committed_runs_render(path, blocks):
    found = apps.blocks_in(path.read_text(encoding="utf-8"))
    assert set(found) == set(blocks), f"{path.name}: blocks {sorted(found)}, expected {sorted(blocks)}"
    for name, render in blocks.items():
        assert found[name] == render(), (f"{path.name} block {name!r} differs from the committed runs; run "
                                         "`PYTHONPATH=. python scripts/readme_apps.py --render`")


def test_every_block_sits_in_an_app_section():
    inside = {name for title in SECTIONS for name in apps.blocks_in(section(page_text(title), title))}
    assert inside == set(apps.README_BLOCKS)


def test_the_runs_are_the_commands_the_readme_shows():
    text = "".join(p.read_text(encoding="utf-8") for p in [README, *sorted(DOCS.glob("*.md"))])
    flat = " ".join(text.replace("\\\n", " ").split())
    for run in apps.all_runs():
        assert run.command in flat, f"{run.name}: {run.command!r} is not a command of README.md or docs/"
        assert (apps.FOLDER / f"{run.name}.json").is_file(), f"experiments/apps/{run.name}.json is not committed"
        record = apps.load(run.name)
        assert record["command"] == run.command, f"{run.name}.json was made by another command; re-run it"


def test_the_example_file_size_quoted():
    size_kb = (ROOT / "examples" / "own_data" / "damper_loops.csv").stat().st_size / 1000
    for page in (README, DOCS / "own-data.md"):
        assert "`examples/own_data/damper_loops.csv` (150 KB)" in page.read_text(encoding="utf-8"), page.name
    assert round(size_kb, -1) == 150
