"""The one loop figure (draw_loops / write_loops) and the fit, identify, discovery and training callers of it."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
from test_report import _legend, _panels

matplotlib.use("Agg")

# -- the one loop figure (report.figures.draw_loops / write_loops) and every caller of it ---------------------


def _record(i: int, n: int = 50):
    from hybridhyst.data import Record

    t = np.linspace(0.0, 1.0, n)
    x = (i + 1) * np.sin(2 * np.pi * t)
    return Record(name=f"r{i}", t=t, x=x, y=3.0 * x + np.cos(2 * np.pi * t), units={"x": "deg", "y": "Nm"},
                  conditions={"pressure_mpa": 0.01 * (i + 1), "mixture": "1:3"})


def test_loop_figure_labels_lines_titles_and_panels():
    from hybridhyst.report.figures import Loop, draw_loops

    records = [_record(i) for i in range(4)]
    model = [r.y + 0.1 for r in records]
    other_x = np.linspace(-1.0, 1.0, 7)
    fig = draw_loops(records, {"model": model, "other": [(other_x, 2 * other_x), None, None, None]})
    panels = _panels(fig)
    assert len(panels) == 4 and len(fig.axes) == 6  # a 3-column grid: two unused axes hidden
    for ax, rec, y_model in zip(panels, records, model):
        assert ax.get_xlabel() == "angle x [deg]" and ax.get_ylabel() == "torque y [Nm]"
        assert ax.get_title() == f"pressure_mpa={rec.conditions['pressure_mpa']:.4g}, mixture=1:3"
        measured, predicted = ax.get_lines()[:2]
        np.testing.assert_array_equal(measured.get_xdata(), rec.x)
        np.testing.assert_array_equal(measured.get_ydata(), rec.y)
        np.testing.assert_array_equal(predicted.get_xdata(), rec.x)
        np.testing.assert_array_equal(predicted.get_ydata(), y_model)
    assert [len(ax.get_lines()) for ax in panels] == [3, 2, 2, 2]  # "other" only where given, on its own grid
    np.testing.assert_array_equal(panels[0].get_lines()[2].get_xydata(), np.c_[other_x, 2 * other_x])
    assert _legend(fig) == ["measured", "model", "other"]
    # no units in the data: the role of the channel; a units argument overrides the loops' own
    bare = draw_loops([Loop(np.arange(3.0), np.arange(3.0), name="bare")])
    assert (bare.axes[0].get_xlabel(), bare.axes[0].get_ylabel()) == ("excitation x", "response y")
    assert bare.axes[0].get_title() == "bare"
    forced = draw_loops(records[:1], units={"y": "kN"})
    assert (forced.axes[0].get_xlabel(), forced.axes[0].get_ylabel()) == ("angle x [deg]", "force y [kN]")
    with pytest.raises(ValueError, match="has 1 entries for 4 loops"):
        draw_loops(records, {"model": model[:1]})


def test_axis_labels_come_from_the_one_unit_table():
    from hybridhyst.data import KNOWN_UNITS, check_units
    from hybridhyst.report.figures import axis_label
    from hybridhyst.units import UNIT_QUANTITY

    # one table: every unit the reader accepts has an entry the labels read (None: no single quantity)
    assert {"Hz", "Ohm", "degC"} <= KNOWN_UNITS and UNIT_QUANTITY["Hz"] == "frequency"
    assert axis_label("u", "V") == "voltage u [V]" and axis_label("x", "um") == "displacement x [um]"
    assert axis_label("f", "Hz") == "frequency f [Hz]" and axis_label("T", "degC") == "temperature T [degC]"
    assert axis_label("y", "%") == "response y [%]"  # a unit without one quantity: the channel's role
    check_units({"y": "kip"}, "test")
    with pytest.raises(ValueError, match="did you mean 'kip'"):
        check_units({"y": "Kip"}, "test")
    # data.units=y:N (or an unquoted {t:s,y:N} the shell expanded) arrives as a string
    with pytest.raises(ValueError, match="units must be a mapping .* got 'y:N'"):
        check_units("y:N", "test")


def test_write_loops_is_atomic(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from hybridhyst.report.figures import write_loops

    path = tmp_path / "loops.png"
    assert write_loops(path, [_record(0)], {"model": [_record(0).y]}) == path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    before = path.read_bytes()

    def interrupted(self, fname, **kwargs):
        Path(fname).write_bytes(b"\x89PNG half")
        raise KeyboardInterrupt

    monkeypatch.setattr(Figure, "savefig", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_loops(path, [_record(1)])
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["loops.png"]


def test_fit_loop_figure_comes_from_the_loop_figure(tmp_path, drawn):
    from hybridhyst.cli.fit_report import write_loop_figure

    rec, other = _record(0), _record(1)
    frames = [pd.DataFrame({"x": r.x, "y": r.y, "y_model": r.y - 0.2}) for r in (rec, other)]
    write_loop_figure(tmp_path / "loop.png", frames, {"x": "in", "y": "kip"}, ["char_1Hz", "char_2Hz"])
    (fig,) = drawn
    ax, second = _panels(fig)
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) == ("displacement x [in]", "force y [kip]", "char_1Hz")
    assert second.get_title() == "char_2Hz"
    np.testing.assert_array_equal(ax.get_lines()[1].get_ydata(), rec.y - 0.2)
    assert _legend(fig) == ["measured", "model"] and (tmp_path / "loop.png").exists()


def test_identify_loops_come_from_the_loop_figure(tmp_path, drawn):
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli import identify as identify_cli
    from hybridhyst.cli.common import CONF_DIR

    overrides = [f"run_dir={tmp_path}", "progress=false", "data.mixtures=[1:3]", "data.pressures=[0.05]",
                 "data.cycles=1", "data.samples_per_cycle=240", "identify.pop=8", "identify.generations=2",
                 "identify.restarts=2", "identify.lm_steps=2", "simulation.substeps=2"]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        identify_cli.run(compose(config_name="identify", overrides=overrides))
    (fig,) = drawn
    (ax,) = _panels(fig)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("angle x [deg]", "torque y [Nm]")
    assert "pressure_mpa=0.05" in ax.get_title() and _legend(fig) == ["data", "identified"]
    assert (tmp_path / "loops.png").read_bytes()[:4] == b"\x89PNG"


def test_discovery_loops_come_from_the_loop_figure(tmp_path, drawn):
    from types import SimpleNamespace

    from hybridhyst.discover.report import loops_figure

    test = [_record(0), _record(1)]
    preds = {"before": {"test": [r.y * 0.5 for r in test]}, "after": {"test": [r.y * 0.9 for r in test]}}
    loops_figure(SimpleNamespace(splits={"train": [_record(2)], "test": test}, predictions=preds),
                 tmp_path / "loops.png")
    (fig,) = drawn
    panels = _panels(fig)
    assert len(panels) == 2
    for ax, rec in zip(panels, test):
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("angle x [deg]", "torque y [Nm]")
        np.testing.assert_array_equal(ax.get_lines()[2].get_ydata(), rec.y * 0.9)
    assert _legend(fig) == ["measured", "before", "after"] and (tmp_path / "loops.png").exists()


def test_training_callback_loops_come_from_the_loop_figure(monkeypatch):
    from types import SimpleNamespace

    from hybridhyst.report import figures
    from hybridhyst.training import callbacks

    rec = _record(0)
    made = []
    monkeypatch.setattr(callbacks, "draw_loops", lambda *a, **k: made.append(figures.draw_loops(*a, **k)) or made[-1])
    pred = {"condition": "pressure_mpa=0.01", "x": rec.x[:, None], "y": rec.y[:, None], "y_pred": rec.y[:, None] + 1,
            "y_nominal": rec.y[:, None] - 1}
    monkeypatch.setattr(callbacks, "predict_split", lambda module, dm, split: [pred])
    logged = []
    logger = SimpleNamespace(experiment=SimpleNamespace(add_figure=lambda tag, fig, global_step: logged.append(tag)))
    trainer = SimpleNamespace(logger=logger, datamodule=SimpleNamespace(records=lambda split: [rec]), global_step=3)
    module = SimpleNamespace(units={"x": "mm", "y": "N"}, kind="hybrid")
    callbacks.LoopFigures(every_n_epochs=1)._draw(trainer, module)
    (fig,) = made
    (ax,) = _panels(fig)
    assert logged == ["loops/pressure_mpa=0.01"] and ax.get_title() == "pressure_mpa=0.01"
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("displacement x [mm]", "force y [N]")
    np.testing.assert_array_equal(ax.get_lines()[1].get_ydata(), rec.y + 1)
    assert _legend(fig) == ["measured", "prediction", "nominal"]
