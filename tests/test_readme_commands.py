"""Every Hydra command in README.md's code blocks composes: a renamed or misspelt key in the documentation fails
here (as ``hybridhyst-identify method=de`` once did), not on a reader's machine."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from hybridhyst.cli.common import CONF_DIR

README = Path(__file__).resolve().parents[1] / "README.md"
HYDRA_APPS = ("identify", "fit", "discover", "train", "simulate", "study")


def readme_commands() -> list[list[str]]:
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and words[0].removeprefix("hybridhyst-") in HYDRA_APPS:
                commands.append(words)
    return commands


COMMANDS = readme_commands()


def test_the_readme_has_commands_of_every_app():
    assert {c[0].removeprefix("hybridhyst-") for c in COMMANDS} == set(HYDRA_APPS)


@pytest.mark.parametrize("words", COMMANDS, ids=[" ".join(c)[:80] for c in COMMANDS])
def test_every_readme_command_composes(words):
    overrides = [w for w in words[1:] if w != "-m" and not w.startswith("hydra.")]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        compose(words[0].removeprefix("hybridhyst-"), overrides=overrides)
