"""Every Hydra command in the bash blocks of README.md and docs/*.md composes: a renamed or misspelt key in the
documentation fails here (as ``hybridhyst-identify method=de`` once did), not on a reader's machine."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from hybridhyst.cli.common import CONF_DIR

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = [README, *sorted((ROOT / "docs").glob("*.md"))]
HYDRA_APPS = ("identify", "fit", "discover", "train", "simulate", "study")
# a folder of the reader's own that a documented command adds to the search path (the route is run on a copy of
# it in tests/test_docs.py); such commands are composed there, not here
OWN_FOLDER = re.compile(r"^hydra\.searchpath=\[file://my_conf\]$")


def readme_commands(pages=PAGES) -> list[tuple[str, list[str]]]:
    """(page, words) of every command of a Hydra app in the bash blocks of ``pages``."""
    commands = []
    for page in pages:
        for block in re.findall(r"```bash\n(.*?)```", page.read_text(encoding="utf-8"), flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                words = shlex.split(line, comments=True)
                if words and words[0].removeprefix("hybridhyst-") in HYDRA_APPS:
                    commands.append((str(page.relative_to(ROOT)), words))
    return commands


COMMANDS = readme_commands()
COMPOSED = [(page, words) for page, words in COMMANDS if not any(OWN_FOLDER.match(w) for w in words)]


def test_the_documentation_has_commands_of_every_app():
    assert {c[0].removeprefix("hybridhyst-") for _, c in COMMANDS} == set(HYDRA_APPS)


def test_the_readme_has_commands_of_the_main_apps():
    apps = {c[0].removeprefix("hybridhyst-") for _, c in readme_commands([README])}
    assert {"discover", "fit", "identify", "train", "simulate", "study"} <= apps


def test_only_the_own_folder_route_is_left_to_another_test():
    skipped = [" ".join(w) for p, w in COMMANDS if (p, w) not in COMPOSED]
    assert all(p == "docs/own-data.md" for p, w in COMMANDS if (p, w) not in COMPOSED), skipped


@pytest.mark.parametrize("page,words", COMPOSED, ids=[f"{p}: {' '.join(c)[:70]}" for p, c in COMPOSED])
def test_every_documented_command_composes(page, words):
    overrides = [w for w in words[1:] if w != "-m" and not w.startswith("hydra.")]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        compose(words[0].removeprefix("hybridhyst-"), overrides=overrides)
