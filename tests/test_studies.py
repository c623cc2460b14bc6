"""The study framework: registry, output (tables, figures, results page), publishing, the app."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from hydra import compose, initialize_config_dir

from hybridhyst.cli import study as study_cli
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.studies import STUDIES, StudyOutput, get_study
from hybridhyst.studies.output import END, START


def test_unknown_study_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown study 'nope'.*vpptd_pinn_identification"):
        get_study("nope")


def test_every_seed_has_a_registered_study():
    """One study per seed paper, named by its subject; the module that implements it is the paper's (seed00N)."""
    assert sorted(spec.split(":")[0] for spec in STUDIES.values()) == [f"seed00{i}" for i in range(5)]
    assert not any(name.startswith("seed") for name in STUDIES)


def test_output_writes_tables_figures_and_publishes_between_markers(tmp_path):
    import matplotlib.pyplot as plt

    out = StudyOutput(tmp_path / "run", "demo")
    out.table("errors", pd.DataFrame({"p": [0.01, 0.02], "rmse": [1.23456, float("nan")]}), caption="Errors")
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    out.figure("loops", fig, caption="Loops")
    out.csv("long", pd.DataFrame({"t": [0.0, 0.5]}), "every sample")
    out.finish({"a": 1})
    text = (tmp_path / "run" / "results.md").read_text()
    assert "| 0.01 | 1.235 |" in text and "| 0.02 | — |" in text and "![Loops](loops.png)" in text
    assert "[long.csv](long.csv): every sample" in text and "| 0.5 |" not in text
    assert pd.read_csv(tmp_path / "run" / "long.csv")["t"].tolist() == [0.0, 0.5]
    assert json.loads((tmp_path / "run" / "summary.json").read_text()) == {"a": 1}

    dest = tmp_path / "experiments" / "demo"
    dest.mkdir(parents=True)
    (dest / "README.md").write_text(f"# Demo\n\nintro\n\n{START}\nold numbers\n{END}\n\nafter\n")
    out.publish(dest)
    readme = (dest / "README.md").read_text()
    assert "old numbers" not in readme and "| 0.01 | 1.235 |" in readme
    assert readme.startswith("# Demo\n\nintro") and readme.rstrip().endswith("after")
    assert (dest / "errors.csv").exists() and (dest / "loops.png").exists()
    out.publish(dest)  # idempotent: one block
    assert (dest / "README.md").read_text().count(START) == 1


def test_app_refuses_missing_study_and_runs_a_registered_one(tmp_path, monkeypatch):
    def demo(options, out):
        out.table("t", pd.DataFrame({"x": [1.0]}))
        return {"reduced": options["reduced"], "answer": 42}

    monkeypatch.setitem(STUDIES, "demo", "x:y")
    monkeypatch.setattr(study_cli, "get_study", lambda name: demo)
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("study", overrides=[f"run_dir={tmp_path / 'run'}"])
        with pytest.raises(ValueError, match="no study selected"):
            study_cli.run(cfg)
        cfg = compose("study", overrides=[f"run_dir={tmp_path / 'run'}", "study=demo", "reduced=true",
                                          f"publish={tmp_path / 'pub'}"])
    summary = study_cli.run(cfg)
    assert summary["answer"] == 42 and summary["reduced"] is True
    assert "reduced=true" in (tmp_path / "pub" / "README.md").read_text()


def test_resolve_options_merges_the_reduced_options_one_level_deep():
    from hybridhyst.studies import resolve_options

    options = {"epochs": 100, "identify": {"pop": 32, "rounds": 3}, "reduced": True,
               "reduced_options": {"epochs": 2, "identify": {"pop": 8}}}
    assert resolve_options(options, ["epochs"], "demo") == {"epochs": 2, "identify": {"pop": 8, "rounds": 3},
                                                             "reduced": True}
    assert resolve_options({**options, "reduced": False}, ["epochs"], "demo")["identify"] == {"pop": 32, "rounds": 3}
    with pytest.raises(ValueError, match=r"demo study: missing option\(s\) \['lr'\]"):
        resolve_options(options, ["epochs", "lr"], "demo")
