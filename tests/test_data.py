"""Data layer: readers, validation messages, condition splits, data configs, records, and the fixes the data-mistake
messages quote; bundled datasets: ``tests/test_data_bundled.py``; the mistake rules on legitimate data:
``tests/test_data_legitimate.py``."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io
import test_trust_data as trust

from hybridhyst.data import Record, RecordSet, read, read_mat, read_npz, read_table, tables
from hybridhyst.data.decimate import decimation_factors

REPO = Path(__file__).parents[1]
SHARED = REPO.parent / "shared"
MAP = {"time": "time", "input": "angle", "output": "torque", "record": "rec"}


def _set(n_records: int = 3, n: int = 50) -> RecordSet:
    records = []
    for i in range(n_records):
        t = np.arange(n) * 0.01
        records.append(Record(
            name=f"r{i}", t=t, x=np.sin(t + i), y=np.cos(t) * (i + 1), extra={"v": t * i},
            conditions={"pressure_mpa": 0.01 * (i + 1), "mixture": "ABS" if i % 2 == 0 else "NBR"},
            units={"x": "deg", "y": "Nm", "v": "deg/s"},
        ))
    return RecordSet(records, name="demo")


def _table(path: Path, edit=None) -> Path:
    """Two records 'a' (rows 0-5) and 'b' (rows 6-11) in one csv, optionally edited."""
    frame = pd.DataFrame({
        "rec": ["a"] * 6 + ["b"] * 6, "time": np.r_[np.arange(6.0), np.arange(6.0)],
        "angle": np.arange(12.0), "torque": np.arange(12.0) * 2, "p": [0.01] * 6 + [0.02] * 6,
    })
    if edit is not None:
        edit(frame)
    frame.to_csv(path, index=False)
    return path


def _same(a: RecordSet, b: RecordSet) -> None:
    assert a.names == b.names
    for ra, rb in zip(a, b, strict=True):
        np.testing.assert_allclose(rb.t, ra.t, rtol=1e-12)
        np.testing.assert_allclose(rb.x, ra.x, rtol=1e-12)
        np.testing.assert_allclose(rb.y, ra.y, rtol=1e-12)
        assert rb.conditions == pytest.approx(ra.conditions)


# -- round trips --------------------------------------------------------------------------------------------
def test_csv_with_record_column_round_trip(tmp_path):
    records = _set()
    records.to_frame().to_csv(tmp_path / "all.csv", index=False)
    back = read_table(tmp_path / "all.csv", record="record", conditions=["pressure_mpa", "mixture"], extra=["v"],
                      units={"x": "deg", "y": "Nm", "v": "deg/s"})
    _same(records, back)
    assert back[1].units == {"t": "s", "x": "deg", "y": "Nm", "v": "deg/s"}
    np.testing.assert_allclose(back["r2"].extra["v"], records["r2"].extra["v"])


def test_a_table_can_give_every_record_a_warm_up(tmp_path):
    """``warmup``: leading samples of every record simulated, not scored (a periodic record extended by its own
    end); one longer than a record names it."""
    records = _set()
    records.to_frame().to_csv(tmp_path / "all.csv", index=False)
    back = read_table(tmp_path / "all.csv", record="record", conditions=["pressure_mpa", "mixture"], warmup=5)
    assert [r.warmup for r in back] == [5] * len(records)
    _same(records, back)
    shortest = min(records, key=len)
    with pytest.raises(ValueError, match=f"{shortest.name}.*warmup must be in"):
        read_table(tmp_path / "all.csv", record="record", conditions=["pressure_mpa", "mixture"],
                   warmup=len(shortest))


def test_glob_of_files_one_record_each(tmp_path):
    records = _set()
    for r in records:
        r_frame = RecordSet([r]).to_frame().drop(columns="record")
        r_frame.to_csv(tmp_path / f"{r.name}.csv", index=False)
    back = read_table(str(tmp_path / "r*.csv"), conditions=["pressure_mpa", "mixture"], name="demo")
    _same(records, back)
    assert back.conditions.loc["r1", "mixture"] == "NBR"


def test_parquet_npz_mat_and_dispatch(tmp_path):
    records = _set(1)
    r = records[0]
    records.to_frame().to_parquet(tmp_path / "r0.parquet")
    _same(records, read(tmp_path / "r0.parquet", conditions=["pressure_mpa", "mixture"]))
    np.savez(tmp_path / "r0.npz", t=r.t, x=r.x, y=r.y, pressure_mpa=0.01, mixture="ABS")
    _same(records, read(tmp_path / "r0.npz", conditions=["pressure_mpa", "mixture"]))
    scipy.io.savemat(tmp_path / "r0.mat", {"t": r.t[None, :], "x": r.x[:, None], "y": r.y,
                                           "pressure_mpa": 0.01, "mixture": "ABS"})
    _same(records, read_mat(tmp_path / "r0.mat", conditions=["pressure_mpa", "mixture"]))
    with pytest.raises(ValueError, match=r"unknown extension '\.xlsx'"):
        read(tmp_path / "r0.xlsx")


def test_npz_record_placeholder_and_matrix_columns(tmp_path):
    np.savez(tmp_path / "bw.npz", train_u=np.sin(np.arange(8.0)), train_y=np.zeros(8), test_u=np.arange(5.0),
             test_y=np.ones(5))
    sets = read_npz(tmp_path / "bw.npz", time=None, fs=750.0, input="{record}_u", output="{record}_y")
    assert sets.names == ["train", "test"] and len(sets["test"]) == 5
    assert sets["train"].t[-1] == pytest.approx(7 / 750)
    data = np.column_stack([np.arange(6.0), np.cos(np.arange(6.0)), np.arange(6.0) ** 2])
    np.savez(tmp_path / "m.npz", data=data, p=0.05)
    r = read_npz(tmp_path / "m.npz", time="data[0]", input="data[1]", output="data[2]", conditions=["p"])[0]
    np.testing.assert_array_equal(r.y, data[:, 2])
    assert r.conditions == {"p": 0.05}


# -- bad input: every message names file, record, column and rows ---------------------------------------------
def _nan(f):
    f.loc[[8, 9], "torque"] = np.nan
    f.loc[11, "torque"] = 1.0


def _short(f):
    f.loc[[10, 11], "torque"] = np.nan


def _inf(f):
    f.loc[3, "angle"] = np.inf


def _text(f):
    f["torque"] = f["torque"].astype(object)
    f.loc[4, "torque"] = "abc"


def _backwards(f):
    f.loc[8, "time"] = 0.5


def _duplicate(f):
    f.loc[8, "time"] = 1.0


def _varies(f):
    f.loc[9, "p"] = 0.03


BAD_TABLES = {
    "nan": (_nan, {}, ["'b'", "'torque'", "2 NaN", "rows 8-9", "interpolate"]),
    "mismatched length": (_short, {}, ["'b'", "'torque'", "rows 10-11", "mismatched lengths"]),
    "inf": (_inf, {}, ["'a'", "'angle'", "rows 3", "NaN/inf"]),
    "non-numeric": (_text, {}, ["'a'", "'torque'", "non-numeric", "rows 4", "'abc'"]),
    "time not increasing": (_backwards, {}, ["'b'", "'time'", "not increasing", "rows 7", "sort"]),
    "duplicate timestamps": (_duplicate, {}, ["'b'", "'time'", "duplicate timestamps", "rows 7"]),
    "condition varies": (_varies, {"conditions": ["p"]}, ["'b'", "'p'", "varies", "row 9", "record column"]),
    "too few samples": (None, {"min_samples": 7}, ["'a'", "6 sample(s)", "rows 0-5", "min_samples=7"]),
}


@pytest.mark.parametrize("case", list(BAD_TABLES))
def test_bad_table_messages(tmp_path, case):
    edit, options, expected = BAD_TABLES[case]
    path = _table(tmp_path / "loops.csv", edit)
    with pytest.raises(ValueError) as err:
        read_table(path, **MAP, **options)
    message = str(err.value)
    for text in [f"file '{path}'", *expected]:
        assert text in message, (text, message)


def test_missing_column_suggests_closest(tmp_path):
    path = _table(tmp_path / "loops.csv")
    with pytest.raises(ValueError, match=r"no column 'torqe' \(the output\); did you mean 'torque'\?"):
        read_table(path, **{**MAP, "output": "torqe"})
    with pytest.raises(ValueError, match=r"no column 'P' \(the condition 'P'\); did you mean 'p'"):
        read_table(path, **MAP, conditions=["P"])


def test_file_level_errors(tmp_path):
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(ValueError, match=r"'.*empty\.csv' is empty"):
        read_table(tmp_path / "empty.csv")
    (tmp_path / "header.csv").write_text("t,x,y\n")
    with pytest.raises(ValueError, match=r"header\.csv' has columns \['t', 'x', 'y'\] but no data rows"):
        read_table(tmp_path / "header.csv")
    with pytest.raises(FileNotFoundError, match="did you mean"):
        read_table(tmp_path / "emptx.csv")
    with pytest.raises(FileNotFoundError, match="no file matches"):
        read_table(str(tmp_path / "nothing*.csv"))
    path = _table(tmp_path / "loops.csv")
    with pytest.raises(ValueError, match=r"'time' is not increasing .* record-id column with record="):
        read_table(path, time="time", input="angle", output="torque")
    with pytest.raises(ValueError, match="give time="):
        read_table(path, time=None, input="angle", output="torque")


def test_unknown_unit_names_closest(tmp_path):
    path = _table(tmp_path / "loops.csv")
    with pytest.raises(ValueError, match=r"unknown unit 'Nm2' for channel 'y'; did you mean 'Nm'\?"):
        read_table(path, **MAP, units={"x": "deg", "y": "Nm2"})
    with pytest.raises(ValueError, match=r"unknown unit 'DEG' for channel 'x'; did you mean 'deg'\?"):
        read_table(path, **MAP, units={"x": "DEG"})
    with pytest.raises(ValueError, match="unknown channel 'z'"):
        read_table(path, **MAP, units={"z": "s"})


def test_npz_and_mat_errors(tmp_path):
    np.savez(tmp_path / "bad.npz", t=np.arange(4.0), x=np.ones(4), y=np.ones(3))
    with pytest.raises(ValueError, match=r"bad\.npz'.*key 'y' \(the output\) has 3 samples but key 'x' has 4"):
        read_npz(tmp_path / "bad.npz")
    np.savez(tmp_path / "nan.npz", t=np.arange(4.0), x=np.r_[1.0, np.nan, 1, 1], y=np.ones(4))
    with pytest.raises(ValueError, match=r"nan\.npz', record 'nan': key 'x' has 1 NaN values \(rows 1\)"):
        read_npz(tmp_path / "nan.npz")
    scipy.io.savemat(tmp_path / "m.mat", {"t": np.arange(4.0), "x": np.ones(4), "torque": np.ones(4)})
    with pytest.raises(ValueError, match=r"no key 'torqe' \(the output\); did you mean 'torque'"):
        read_mat(tmp_path / "m.mat", output="torqe")


# -- selecting and splitting by condition ----------------------------------------------------------------------
def test_select_by_conditions_and_callable():
    records = _set(4)
    assert records.select(mixture="ABS").names == ["r0", "r2"]
    assert records.select(pressure_mpa=[0.02, 0.03]).names == ["r1", "r2"]
    assert records.select(pressure_mpa=0.01 + 0.02).names == ["r2"]  # float tolerance
    assert records.select(lambda r: r.conditions["pressure_mpa"] > 0.025).names == ["r2", "r3"]
    with pytest.raises(ValueError, match=r"did you mean 'mixture'"):
        records.select(mixtur="ABS")


def test_split_by_held_out_condition():
    records = _set(5)
    train, val, test = records.split(held_out={"pressure_mpa": [0.03]}, val={"pressure_mpa": [0.05]})
    assert (train.names, val.names, test.names) == (["r0", "r1", "r3"], ["r4"], ["r2"])
    both = records.split(held_out={"mixture": ["NBR"], "pressure_mpa": [0.02, 0.03]})
    assert both.test.names == ["r1"] and len(both.val) == 0
    union = records.split(held_out=[{"pressure_mpa": 0.01}, {"mixture": "ABS", "pressure_mpa": 0.05}])
    assert union.test.names == ["r0", "r4"]  # a list of queries: any of them


def test_split_errors_name_the_condition():
    records = _set(3)
    with pytest.raises(ValueError) as err:
        records.split(held_out={"pressure_mpa": [0.025]})
    assert str(err.value) == (
        "held-out condition pressure_mpa=0.025 matches no record; available values: [0.01, 0.02, 0.03]"
    )
    with pytest.raises(ValueError, match="leaves no training records"):
        records.split(held_out={"mixture": ["ABS"]}, val={"mixture": ["NBR"]})


def test_to_frame_is_long_table():
    frame = _set(2, n=10).to_frame()
    assert list(frame.columns) == ["record", "t", "x", "y", "v", "pressure_mpa", "mixture"]
    assert len(frame) == 20 and frame.attrs["units"]["y"] == "Nm"


# -- configs ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("config", sorted(p.stem for p in (REPO / "conf" / "data").glob("*.yaml")))
def test_data_configs_instantiate(config, tmp_path):
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    cfg = OmegaConf.load(REPO / "conf" / "data" / f"{config}.yaml")
    if config == "table":
        path = _table(tmp_path / "loops.csv")
        cfg = OmegaConf.merge(cfg, {"path": str(path), **MAP, "conditions": ["p"], "units": {"x": "deg"}})
    if config == "vpptd":
        cfg = OmegaConf.merge(cfg, {"mixtures": ["ABS"], "pressures": [0.05], "cycles": 1, "samples_per_cycle": 40})
    records = instantiate(cfg)
    assert isinstance(records, RecordSet) and len(records) >= 1


def test_warmup_is_validated_and_follows_slices():
    t = np.arange(100) * 0.01
    rec = Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=10)
    assert rec.slice(step=2).warmup == 5 and rec.slice(4).warmup == 6 and rec.slice(20).warmup == 0
    np.testing.assert_array_equal(rec.scored(rec.y), rec.y[10:])  # the samples after the warm-up
    with pytest.raises(ValueError, match="warmup must be in"):
        Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=100)
    with pytest.raises(ValueError, match="whole number of samples"):  # not silently 50
        Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=50.5)
    assert Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=np.int64(4)).warmup == 4
    assert Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=4.0).warmup == 4
    for bad in (True, float("inf"), float("nan"), "3"):
        with pytest.raises(ValueError, match="whole number of samples"):
            Record(name="r", t=t, x=np.sin(t), y=np.cos(t), warmup=bad)


def test_with_noise_is_the_one_noise_injection():
    t = np.arange(20000) * 0.01
    rec = Record("r", t=t, x=np.sin(t), y=np.cos(t), units={"x": "deg", "y": "Nm"})
    noisy = rec.with_noise(0.2, [3, 1])
    e = noisy.y - rec.y
    assert abs(e.std() - 0.2) < 0.01 and abs(e.mean()) < 0.01
    assert np.array_equal(rec.with_noise(0.2, [3, 1]).y, noisy.y)  # the key alone fixes the noise
    assert not np.array_equal(rec.with_noise(0.2, [3, 2]).y, noisy.y)
    assert np.array_equal(noisy.x, rec.x) and noisy.units == rec.units and "noise sd 0.2" in noisy.source
    g = np.random.default_rng(5)  # a generator's stream continues from record to record
    a, b = rec.with_noise(0.1, g), rec.with_noise(0.1, g)
    assert not np.array_equal(a.y, b.y)
    assert rec.with_noise(0.0, 1) is rec
    with pytest.raises(ValueError, match="record 'r': noise sd must be a non-negative"):
        rec.with_noise(-0.1, 0)


def test_the_trust_matrix_lists_at_least_36_data_mistakes():
    assert len(trust.CASES) >= 36


# -- data mistakes (tests/test_trust_data.py): the fixes the messages quote work -----------------------------
def _quoted_override(message: str) -> dict:
    """The ``"data.read_options=..."`` override of a message, split as the shell does and parsed as Hydra does."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    text = re.search(r'on the command line: ("data\.read_options=[^"]*")', message).group(1)
    (word,) = shlex.split(text)
    return OverridesParser.create().parse_override(word).value()


@pytest.mark.parametrize("case", ["utf16-with-byte-order-mark", "utf16-without-byte-order-mark", "latin1-not-utf8",
                                  "semicolon-separated", "semicolon-separated-decimal-comma",
                                  "decimal-comma-in-tab-separated"])
def test_the_quoted_read_option_reads_the_file(case, tmp_path):
    trust.CASES[case].make(tmp_path)
    path = next(tmp_path.iterdir())
    columns = {**trust.COLUMNS, "input": "angle_°"} if case == "latin1-not-utf8" else trust.COLUMNS
    with pytest.raises(ValueError) as err:
        read_table(path, **columns)
    options = _quoted_override(str(err.value))
    if case == "utf16-without-byte-order-mark":
        options = {"encoding": "utf-16-le"}  # without a mark the byte order must be named
    records = read_table(path, **columns, read_options=options)
    assert records.names == [f"p{p:.2f}" for p in trust.PRESSURES]
    assert records[2].x.max() == pytest.approx(10, rel=0.01)


def test_a_larger_limit_reads_the_file_in_chunks(tmp_path, monkeypatch):
    trust.loops().to_csv(tmp_path / "loops.csv", index=False)
    whole = read_table(tmp_path / "loops.csv", **trust.COLUMNS)
    monkeypatch.setattr(tables, "CHUNK_MB", 0.001)
    monkeypatch.setattr(tables, "CHUNK_ROWS", 64)
    chunked = read_table(tmp_path / "loops.csv", **trust.COLUMNS, max_file_mb=1)
    assert chunked.names == whole.names
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a.y, b.y)


def test_a_configured_frequency_condition_thins_per_cycle(tmp_path):
    frame = trust.loops().assign(freq_hz=0.8)
    frame.to_csv(tmp_path / "f.csv", index=False)
    records = read_table(tmp_path / "f.csv", **{**trust.COLUMNS, "conditions": ["pressure_mpa", "freq_hz"]})
    assert set(decimation_factors(records, 25, 1, "freq_hz").values()) == {10}  # 200 Hz / (0.8 Hz · 25)
    assert set(decimation_factors(records, 25, 3, None).values()) == {3}
    assert set(decimation_factors(records, 25, 3, "none").values()) == {3}  # the experiments' spelling
    plain = read_table(tmp_path / "f.csv", **trust.COLUMNS)  # no frequency condition at all: downsample, no error
    assert set(decimation_factors(plain, 25, 2).values()) == {2}
