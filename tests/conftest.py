import os
from pathlib import Path

import pytest
import torch

# The tests run in several processes on few cores (pytest-xdist): torch's intra-op threads would only wait for
# each other's (the apps, identify and discover set one thread each themselves; hybridhyst.settings).
torch.set_num_threads(1)
os.environ.setdefault("HYBRIDHYST_FAST_THREADS", "1")  # the compiled loops' row threads likewise
# the apps the tests start as subprocesses import this checkout, installed or not (and not another install)
os.environ["PYTHONPATH"] = os.pathsep.join(
    p for p in (str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")) if p)


@pytest.fixture
def float64():
    """Run a test in float64 and restore the default dtype afterwards."""
    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    yield
    torch.set_default_dtype(old)


@pytest.fixture(scope="module")
def reduced_study(request, tmp_path_factory):
    """The reduced run (``reduced=true``) of the study named by the test module's ``STUDY``, once per
    module: ``(summary, run_dir)``."""
    from hybridhyst.cli import study as study_cli

    name = request.module.STUDY
    run_dir = tmp_path_factory.mktemp(name)
    cfg = study_cli.compose_study(name, f"run_dir={run_dir}", "reduced=true", "progress=false")
    return study_cli.run(cfg), run_dir


@pytest.fixture
def drawn(monkeypatch) -> list:
    """Every figure ``draw_loops`` makes during a test (also when reached through ``write_loops``)."""
    from hybridhyst.report import figures

    made, draw = [], figures.draw_loops

    def spy(*args, **kwargs):
        made.append(draw(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(figures, "draw_loops", spy)
    return made
