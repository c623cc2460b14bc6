"""Data mistakes, each refused with a message that names where (file, record, column, rows) and the fix.

``test_data_mistake_is_refused_with_its_fix`` runs one case per data mistake: a small file (or frame) written
to ``tmp_path`` and read through the public path the apps take (``read_table`` / ``read`` of ``data=table``,
the bundled loaders, the thinning of ``decimation_factors``), asserting the error and the words it must hold.
The case ids are the mistakes' names; ``scripts/trust_matrix.py`` counts every test of this file as a case, so
it holds nothing else: that the rules behind the new cases never fire on legitimate data (the bundled records,
large spikes, sample rates that follow the loading frequency, amplitudes that differ) and that the fixes the
messages quote work is tested in ``tests/test_data.py``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io

import hybridhyst  # noqa: F401 (registers the synthetic vpptd loader)
from hybridhyst.data import read, read_npz, read_table
from hybridhyst.data.decimate import decimation_factors
from hybridhyst.data.splits import Split, check_conditions

COLUMNS = {"record": "record", "input": "angle_deg", "output": "torque_nm", "conditions": ["pressure_mpa"]}
PRESSURES = (0.01, 0.03, 0.05, 0.07, 0.09)
N = 200  # samples per record: 1.6 cycles at 0.8 Hz, 200 Hz


def loops(edit: Callable[[pd.DataFrame], None] | None = None) -> pd.DataFrame:
    """Five torque-angle records (p0.01 ... p0.09, rows 0-199, 200-399, ...) in the README's own-data layout."""
    t = np.arange(N) / 200.0
    parts = []
    for p in PRESSURES:
        angle = 10.0 * np.sin(2 * np.pi * 0.8 * t)
        torque = 100 * p * angle + 10 * np.sign(np.cos(2 * np.pi * 0.8 * t))
        parts.append(pd.DataFrame({"record": f"p{p:.2f}", "t": t, "angle_deg": angle, "torque_nm": torque,
                                   "pressure_mpa": p}))
    frame = pd.concat(parts, ignore_index=True)
    if edit is not None:
        edit(frame)
    return frame


def row(record: str, i: int) -> int:
    """The 0-based data row of sample ``i`` of record ``record``."""
    return [f"p{p:.2f}" for p in PRESSURES].index(record) * N + i


@dataclass
class Case:
    """A mistake: ``make(tmp_path)`` writes it and returns the call that must fail with ``error`` holding ``words``."""

    make: Callable[[Path], Callable[[], object]]
    words: tuple[str, ...]
    error: type = ValueError


def csv(frame_or_text, name: str = "loops.csv", encoding: str = "utf-8", **read_kw) -> Callable:
    """A case maker: write ``frame_or_text`` (a frame, str or bytes) and read it as the README does."""
    def make(tmp: Path):
        path = tmp / name
        if isinstance(frame_or_text, pd.DataFrame):
            frame_or_text.to_csv(path, index=False)
        elif isinstance(frame_or_text, bytes):
            path.write_bytes(frame_or_text)
        else:
            path.write_text(frame_or_text, encoding=encoding)
        return lambda: read_table(path, **{**COLUMNS, **read_kw})
    return make


def edited(edit, **read_kw) -> Callable:
    return csv(loops(edit), **read_kw)


def npz(arrays: dict, **read_kw) -> Callable:
    def make(tmp: Path):
        np.savez(tmp / "loops.npz", **arrays)
        return lambda: read_npz(tmp / "loops.npz", **read_kw)
    return make


def thinning(frequency: str | None, conditions: dict, setting: str = "fit.frequency_condition") -> Callable:
    """Records with ``conditions`` thinned to 32 samples per cycle with ``frequency`` as the frequency condition."""
    def make(tmp: Path):
        frame = loops()
        for k, v in conditions.items():
            frame[k] = v
        frame.to_csv(tmp / "loops.csv", index=False)
        records = read_table(tmp / "loops.csv", **{**COLUMNS, "conditions": ["pressure_mpa", *conditions]})
        return lambda: decimation_factors(records, 32, 1, frequency, setting)
    return make


def _set(column, rows, value):
    def edit(f):
        if f[column].dtype != object and isinstance(value, str):
            f[column] = f[column].astype(object)
        f.loc[rows, column] = value
    return edit


def _rad(f):
    f.loc[f.record == "p0.07", "angle_deg"] = np.deg2rad(f.loc[f.record == "p0.07", "angle_deg"])


def _two_rad(f):
    for p in ("p0.03", "p0.07"):
        f.loc[f.record == p, "angle_deg"] = np.deg2rad(f.loc[f.record == p, "angle_deg"])


def _ms(f):
    f.loc[f.record == "p0.03", "t"] *= 1000.0


def _drop_rows(frame: pd.DataFrame, rows) -> pd.DataFrame:
    return frame.drop(index=rows).reset_index(drop=True)


def _long_text() -> str:
    return loops().to_csv(index=False)


def _non_numeric_condition(tmp: Path):
    frame = loops()
    frame["pressure_mpa"] = frame["pressure_mpa"].astype(object)
    frame.loc[frame.record == "p0.05", "pressure_mpa"] = "high"
    frame.to_csv(tmp / "loops.csv", index=False)
    records = read_table(tmp / "loops.csv", **COLUMNS)
    return lambda: check_conditions(Split(records, [], []), ["pressure_mpa"], "datamodule.conditions")


def _through_the_apps_loader(tmp: Path):
    """The absurd value in a record that the split would hold out, read the way every app reads ``data=table``."""
    from omegaconf import OmegaConf

    from hybridhyst.cli.common import load_records

    loops(_set("torque_nm", [row("p0.09", 5)], 1e300)).to_csv(tmp / "loops.csv", index=False)
    cfg = OmegaConf.create({"data": {"_target_": "hybridhyst.data.read_table", "path": str(tmp / "loops.csv"),
                                     **COLUMNS}, "split": {"held_out": [{"pressure_mpa": [0.09]}]}})
    return lambda: load_records(cfg)


def _folder(tmp: Path):
    (tmp / "runs").mkdir()
    return lambda: read_table(tmp / "runs", **COLUMNS)


def _glob(tmp: Path):
    loops().to_csv(tmp / "run1.csv", index=False)
    return lambda: read_table(str(tmp / "runz_*.csv"), **COLUMNS)


def _missing(tmp: Path):
    loops().to_csv(tmp / "loops.csv", index=False)
    return lambda: read_table(tmp / "loop.csv", **COLUMNS)


def _unknown_extension(tmp: Path):
    (tmp / "loops.xlsx").write_bytes(b"PK\x03\x04")
    return lambda: read(tmp / "loops.xlsx", **COLUMNS)


def _json(tmp: Path):
    (tmp / "loops.json").write_text("{}")
    return lambda: read_table(tmp / "loops.json", **COLUMNS)


def _npz_pickle(tmp: Path):
    np.savez(tmp / "loops.npz", t=np.arange(4.0), x=np.array([{"a": 1}] * 4, dtype=object), y=np.ones(4))
    return lambda: read_npz(tmp / "loops.npz")


def _npz_corrupt(tmp: Path):
    (tmp / "loops.npz").write_bytes(b"PK\x03\x04 not really a zip archive")
    return lambda: read_npz(tmp / "loops.npz")


def _npy(tmp: Path):
    np.save(tmp / "loops.npy", np.arange(6.0))
    (tmp / "loops.npy").rename(tmp / "loops.npz")
    return lambda: read_npz(tmp / "loops.npz")


def _text_npz(tmp: Path):
    (tmp / "loops.npz").write_text("t,x,y\n1,2,3\n")
    return lambda: read(tmp / "loops.npz")


def _mat_corrupt(tmp: Path):
    (tmp / "loops.mat").write_bytes(b"MATLAB 5.0 MAT-file, broken" + bytes(100))
    return lambda: read(tmp / "loops.mat")


def _mat_short(tmp: Path):
    scipy.io.savemat(tmp / "loops.mat", {"t": np.arange(5.0), "x": np.sin(np.arange(5.0)), "y": np.ones(4)})
    return lambda: read(tmp / "loops.mat")


T = np.arange(6.0)
SINE = np.sin(T)
P07 = row("p0.07", 0)

CASES = {
    # -- the file ---------------------------------------------------------------------------------------------
    "missing-file": Case(_missing, ("loop.csv", "did you mean", "loops.csv"), FileNotFoundError),
    "glob-matches-no-file": Case(_glob, ("no file matches the pattern", "runz_*.csv", "run1.csv"), FileNotFoundError),
    "folder-instead-of-file": Case(_folder, ("runs' is a folder", "glob pattern", "*.csv")),
    "empty-file-0-bytes": Case(csv(""), ("loops.csv' is empty (0 bytes)", "re-export")),
    "blank-lines-only": Case(csv("\n\n\n"), ("loops.csv' has no header and no data", "header row")),
    "header-only": Case(csv("record,t,angle_deg,torque_nm,pressure_mpa\n"),
                        ("loops.csv' has columns", "no data rows", "re-export")),
    "unknown-extension": Case(_unknown_extension, ("loops.xlsx", "unknown extension '.xlsx'", "supported")),
    "table-reader-given-json": Case(_json, ("loops.json", "read_table reads", "use read()")),
    "utf16-with-byte-order-mark": Case(csv(_long_text(), encoding="utf-16"),
                                       ("loops.csv' is UTF-16", "byte-order mark",
                                        "\"data.read_options={encoding: utf-16}\"", "re-save it as UTF-8")),
    "utf16-without-byte-order-mark": Case(csv(_long_text(), encoding="utf-16-le"),
                                          ("loops.csv' is UTF-16", "NUL bytes", "{encoding: utf-16}")),
    "latin1-not-utf8": Case(csv(_long_text().replace("angle_deg", "angle_°"), encoding="latin-1"),
                            ("loops.csv' is not utf-8 text", "\\xb0", "\"data.read_options={encoding: latin-1}\"")),
    "excel-workbook-named-csv": Case(csv(b"PK\x03\x04\x14\x00\x06\x00" + bytes(50)),
                                     ("loops.csv' is a zip archive", "Excel", "export the sheet as csv")),
    "binary-file-named-csv": Case(csv(b"\x93NUMPY\x01\x00v\x00{'descr': '<f8'" + bytes(64)),
                                  ("loops.csv' holds binary data", "export it as csv")),
    "semicolon-separated": Case(csv(loops().to_csv(index=False, sep=";")),
                                ("loops.csv' was read as one column 'record;t;angle_deg", "semicolon-separated",
                                 "\"data.read_options={sep: ';'}\"")),
    "semicolon-separated-decimal-comma": Case(csv(loops().to_csv(index=False, sep=";", decimal=",")),
                                              ("semicolon-separated",
                                               "\"data.read_options={sep: ';', decimal: ','}\"")),
    "tab-separated-named-csv": Case(csv(loops().to_csv(index=False, sep="\t")),
                                    ("was read as one column", "tab-separated", "rename it to .tsv")),
    "decimal-comma-in-comma-separated": Case(csv("record,t,angle_deg,torque_nm,pressure_mpa\n"
                                                 "a,0,0,1,5,2,0,0,01\na,0,5,1,6,2,1,0,01\n"),
                                             ("loops.csv'", "4 more field(s) than the header", "decimal comma",
                                              "complete the header")),
    "decimal-comma-in-tab-separated": Case(csv(loops().to_csv(index=False, sep="\t", decimal=","), name="loops.tsv"),
                                           ("loops.tsv', record 'p0.01'", "column 't'", "non-numeric", "rows 0-199",
                                            "'0,0'", "decimal comma", "\"data.read_options={decimal: ','}\"")),
    "ragged-rows": Case(csv("record,t,angle_deg,torque_nm,pressure_mpa\na,0,0,1,0.01\na,1,2,3,0.01,7,8\n"),
                        ("loops.csv' is not a regular table", "line 3", "as many fields as the header")),
    "file-over-size-limit": Case(csv(_long_text(), max_file_mb=0.01),
                                 ("loops.csv' is 0.0", "MB, over the 0.01 MB limit", "data.max_file_mb=1",
                                  "several times its size")),
    # -- columns --------------------------------------------------------------------------------------------------
    "missing-column": Case(csv(loops(), output="torque"),
                           ("loops.csv'", "no column 'torque' (the output)", "did you mean 'torque_nm'?")),
    "condition-column-case": Case(csv(loops(), conditions=["Pressure_MPa"]),
                                  ("no column 'Pressure_MPa'", "did you mean 'pressure_mpa'?")),
    "non-numeric-cell": Case(edited(_set("torque_nm", [row("p0.03", 7)], "oops")),
                             ("record 'p0.03'", "column 'torque_nm'", "non-numeric", f"rows {row('p0.03', 7)}",
                              "'oops'", "fix or remove")),
    "nan-values": Case(edited(_set("torque_nm", [row("p0.05", 10), row("p0.05", 11)], np.nan)),
                       ("record 'p0.05'", "column 'torque_nm'", "2 NaN", f"rows {row('p0.05', 10)}-{row('p0.05', 11)}",
                        "interpolate")),
    "inf-value": Case(edited(_set("angle_deg", [row("p0.01", 3)], np.inf)),
                      ("record 'p0.01'", "column 'angle_deg'", "NaN/inf", "rows 3", "drop or interpolate")),
    "column-shorter-than-the-others": Case(edited(_set("torque_nm", list(range(row("p0.09", 190), 5 * N)), np.nan)),
                                           ("record 'p0.09'", "column 'torque_nm'", "mismatched lengths",
                                            f"rows {row('p0.09', 190)}-{5 * N - 1}", "fill this one")),
    "absurd-value-in-training-record": Case(edited(_set("torque_nm", [row("p0.03", 50)], 1e300)),
                                            ("record 'p0.03'", "column 'torque_nm'", "absurd for this record",
                                             f"rows {row('p0.03', 50)}", "1e+300", "fix or remove those rows")),
    "absurd-value-in-held-out-record": Case(edited(_set("torque_nm", [row("p0.09", 120)], -1e300)),
                                            ("record 'p0.09'", "column 'torque_nm'", "absurd",
                                             f"rows {row('p0.09', 120)}", "fix or remove")),
    "absurd-value-in-held-out-record-through-the-apps-loader": Case(
        _through_the_apps_loader, ("record 'p0.09'", "column 'torque_nm'", "1 value(s) absurd",
                                   f"rows {row('p0.09', 5)}", "fix or remove")),
    "float32-fill-value-in-input": Case(edited(_set("angle_deg", [row("p0.05", 0), row("p0.05", 1)], 3.4e38)),
                                        ("record 'p0.05'", "column 'angle_deg'", "2 value(s) absurd",
                                         f"rows {row('p0.05', 0)}-{row('p0.05', 1)}", "fill value")),
    "no-motion-constant-input-and-response": Case(
        edited(lambda f: (f.__setitem__("angle_deg", 0.0), f.__setitem__("torque_nm", 1.5))),
        ("record 'p0.01'", "column 'angle_deg' (the input) is 0 and column 'torque_nm' (the response) 1.5 at every",
         "200 rows (0-199)", "holds no motion", "drop the record")),
    "input-in-rad-among-deg": Case(edited(_rad), ("record 'p0.07'", "input column 'angle_deg' is in rad, not deg",
                                                  "0.01745× the other records'", "multiply it by 57.3",
                                                  "data.units")),
    "two-records-in-rad-among-deg": Case(edited(_two_rad), ("record 'p0.03'", "input column 'angle_deg' is in rad",
                                                            "multiply it by 57.3")),
    "time-in-ms-among-s": Case(edited(_ms), ("record 'p0.03'", "time column 't' is in ms, not s",
                                             "sample interval is 1000×", "divide it by 1000", "data.units")),
    # -- time -----------------------------------------------------------------------------------------------------
    "duplicate-timestamp": Case(edited(_set("t", [row("p0.05", 6)], 0.025)),
                                ("record 'p0.05'", "column 't'", "duplicate timestamps", f"rows {row('p0.05', 5)}",
                                 "drop the repeated samples")),
    "time-not-increasing": Case(edited(_set("t", [row("p0.07", 9)], 0.01)),
                                ("record 'p0.07'", "column 't'", "not increasing", f"rows {row('p0.07', 8)}",
                                 "sort the samples")),
    "several-records-without-record-column": Case(csv(loops(), record=None),
                                                  ("record 'loops'", "not increasing", f"rows {N - 1}",
                                                   "record-id column with record=")),
    "no-time-column-and-no-sample-rate": Case(csv(loops(), time=None), ("loops.csv': give time=", "data.time",
                                                                        "data.fs")),
    "negative-sample-rate": Case(csv(loops(), time=None, fs=-200.0),
                                 ("loops.csv': fs (data.fs) must be a positive", "-200")),
    # -- records and conditions ------------------------------------------------------------------------------------
    "record-too-short": Case(csv(_drop_rows(loops(), range(row("p0.05", 3), row("p0.07", 0))), min_samples=10),
                             ("record 'p0.05'", "3 sample(s)", f"rows {row('p0.05', 0)}-{row('p0.05', 2)}",
                              "min_samples=10", "merge it")),
    "empty-record-id": Case(edited(_set("record", [row("p0.03", 4)], np.nan)),
                            ("record id column 'record' is empty", f"rows {row('p0.03', 4)}", "fill in the record id")),
    "missing-condition-value": Case(edited(_set("pressure_mpa", [row("p0.05", 20)], np.nan)),
                                    ("record 'p0.05'", "condition column 'pressure_mpa'", "1 missing values",
                                     f"rows {row('p0.05', 20)}", "fill them")),
    "condition-varies-within-record": Case(edited(_set("pressure_mpa", [row("p0.05", 30)], 0.06)),
                                           ("record 'p0.05'", "condition column 'pressure_mpa'", "varies",
                                            f"row {row('p0.05', 30)}", "record column")),
    "non-numeric-condition": Case(_non_numeric_condition, ("datamodule.conditions", "'pressure_mpa'",
                                                           "not a number in 1 of 5 records (p0.05)")),
    # -- units and channels -----------------------------------------------------------------------------------------
    "unknown-unit-name": Case(csv(loops(), units={"t": "s", "x": "deg", "y": "N.m"}),
                              ("loops.csv'", "unknown unit 'N.m' for channel 'y'", "did you mean 'Nm'?")),
    "units-not-a-mapping": Case(csv(loops(), units="t: s"),
                                ("units must be a mapping", "'data.units={t: s, x: mm, y: N}'", "quoted")),
    "unit-for-unknown-channel": Case(csv(loops(), units={"v": "deg/s"}), ("unknown channel 'v'", "'x' (input")),
    "extra-channel-named-like-input": Case(csv(loops(), extra={"x": "torque_nm"}),
                                           ("loops.csv': extra channel names ['x'] (data.extra) are reserved",
                                            "rename")),
    # -- npz and MAT ---------------------------------------------------------------------------------------------------
    "npz-arrays-of-different-lengths": Case(npz({"t": T, "x": SINE, "y": np.ones(5)}),
                                            ("loops.npz'", "key 'y' (the output) has 5 samples but key", "has 6",
                                             "trim or fix")),
    "npz-missing-key": Case(npz({"t": T, "x": SINE, "torque": SINE}, output="torq"),
                            ("loops.npz'", "no key 'torq'", "did you mean 'torque'")),
    "npz-matrix-without-column": Case(npz({"t": T, "x": np.column_stack([SINE, SINE]), "y": SINE}),
                                      ("key 'x' (the input) has shape (6, 2)", "'x[i]'")),
    "npz-nan-value": Case(npz({"t": T, "x": np.r_[SINE[:4], np.nan, SINE[5]], "y": SINE}),
                          ("loops.npz', record 'loops'", "key 'x'", "1 NaN", "rows 4")),
    "npz-pickled-objects": Case(_npz_pickle, ("loops.npz' holds pickled object arrays", "numpy.savez")),
    "npz-not-an-archive": Case(_npz_corrupt, ("loops.npz' is not a valid .npz archive", "re-save it")),
    "npy-named-npz": Case(_npy, ("loops.npz' is a single .npy array", "numpy.savez(name, t=..., x=..., y=...)")),
    "text-file-named-npz": Case(_text_npz, ("loops.npz' is not an .npz archive", "b't,x,y\\n'",
                                            "read a csv file under its own extension")),
    "mat-not-readable": Case(_mat_corrupt, ("loops.mat' is not a readable MAT file", "save(name, '-v7')")),
    "mat-arrays-of-different-lengths": Case(_mat_short, ("loops.mat'", "key 'y' (the output) has 4 samples")),
    # -- thinning per loading cycle ----------------------------------------------------------------------------------
    "frequency-condition-named-freq_hz": Case(thinning("frequency_hz", {"freq_hz": 0.8}),
                                              ("fit.frequency_condition='frequency_hz' (the default)", "'freq_hz'",
                                               "not be thinned", "fit.frequency_condition=freq_hz")),
    "frequency-condition-configured-but-absent": Case(thinning("f_load", {"freq_hz": 0.8},
                                                               "thinning.frequency_condition"),
                                                      ("thinning.frequency_condition='f_load'",
                                                       "no record has a condition 'f_load'", "did you mean 'freq_hz'",
                                                       "thinning.frequency_condition=null")),
    "frequency-condition-not-a-number": Case(thinning("freq_hz", {"freq_hz": "fast"}, "datamodule.frequency_condition"),
                                             ("datamodule.frequency_condition='freq_hz'",
                                              "not a positive number [Hz] in any record", "'fast'")),
}


@pytest.mark.parametrize("case", list(CASES))
def test_data_mistake_is_refused_with_its_fix(case, tmp_path):
    spec = CASES[case]
    call = spec.make(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a mistake is an error, not a warning
        with pytest.raises(spec.error) as err:
            call()
    message = str(err.value)
    assert "\n" not in message and "Traceback" not in message
    for word in spec.words:
        assert word in message, (word, message)
