"""Read measured loops from csv, parquet, npz and MAT files into a validated ``RecordSet``.

Every reader maps named columns (or keys) to a record's channels::

    read_table("loops.csv", time="time_s", input="angle", output="torque",
               conditions=["pressure_mpa"], record="test_id", units={"t": "s", "x": "deg", "y": "Nm"})

* one file holding many records: name the record-id column with ``record=``;
* many files, one record each (or several, with ``record=``): pass a glob pattern (``"runs/*.csv"``);
  records are named after the file stem (or ``<stem>/<record id>``).

Conditions are constant within a record; a condition column that varies inside one record is an error.
Nothing is dropped silently: NaN/inf, non-numeric cells, values absurd for their record (``Record``), time not
increasing, duplicate timestamps, columns of different lengths, a record with no motion (input and response
constant) and records shorter than ``min_samples`` all raise a ``ValueError`` that names the file, the record,
the column and the rows (0-based data rows; for npz/MAT sample indices), and says how to fix it. So do a file's
encoding, separator or size
(``tables``: files over ``max_file_mb``, 1024 MB unless set, are refused; text files over 16 MB are read in
chunks with a progress bar) and records of one data set in different units (``scales``: ms among s, rad
among deg).
"""

from __future__ import annotations

import difflib
import glob
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..units import check_units
from .arrays import frame_from_arrays, load_mat, load_npz
from .records import Record, RecordSet, _rows, validate_channels
from .scales import check_scales
from .tables import MAX_FILE_MB, decimal_comma_hint, read_frame

__all__ = ["read", "read_mat", "read_npz", "read_table"]

_NUMBER = re.compile(r"^\s*[-+]?(0|[1-9]\d*|0?\.\d+|[1-9]\d*\.\d*|0\.\d*)([eE][-+]?\d+)?\s*$")  # not '007'


@dataclass
class ColumnMap:
    """Which column (or npz/MAT key) feeds which channel, condition and record id."""

    time: str | None = "t"
    input: str = "x"
    output: str = "y"
    extra: dict[str, str] = field(default_factory=dict)
    conditions: dict[str, str] = field(default_factory=dict)
    record: str | None = None
    fs: float | None = None
    controls: dict[str, str] = field(default_factory=dict)

    @classmethod
    def build(cls, time, input, output, conditions, record, extra, fs, where: str = "reading",
              controls=None) -> ColumnMap:
        if time is None and fs is None:
            raise ValueError(f"{where}: give time= (the time column, data.time) or fs= (the sample rate in Hz, "
                             "data.fs: time = row / fs)")
        if fs is not None and not (np.isfinite(fs) and fs > 0):
            raise ValueError(f"{where}: fs (data.fs) must be a positive sample rate in Hz, got {fs!r}")
        extra, conditions = _as_map(extra), _as_map(conditions)
        clash = sorted(set(extra) & {"t", "x", "y"})
        if clash:
            raise ValueError(f"{where}: extra channel names {clash} (data.extra) are reserved for time/input/output; "
                             "rename them")
        controls = _as_map(controls)
        both = sorted(set(controls) & set(conditions))
        if both:
            raise ValueError(f"{where}: {both} given both as conditions (data.conditions, constant within a "
                             "record) and as controls (data.controls, varying in time); name each in one of them")
        clash = sorted(set(controls) & ({"t", "x", "y"} | set(extra)))
        if clash:
            raise ValueError(f"{where}: control names {clash} (data.controls) clash with a channel's; rename them")
        return cls(time, input, output, extra, conditions, record, None if fs is None else float(fs), controls)

    def channels(self) -> dict[str, str | None]:
        """``{channel: column}`` for t, x, y, the extra channels and the controls (``"control <name>"``; t is None
        when derived from fs)."""
        return {"t": self.time, "x": self.input, "y": self.output, **self.extra,
                **{f"control {k}": c for k, c in self.controls.items()}}

    def roles(self) -> dict[str, str]:
        """``{column: role}`` of every referenced column, for messages."""
        roles = {c: f"{ch} channel" for ch, c in self.extra.items()}
        roles.update({c: f"condition {k!r}" for k, c in self.conditions.items()})
        roles.update({c: f"control {k!r}" for k, c in self.controls.items()})
        roles.update({self.input: "input", self.output: "output"})
        if self.time is not None:
            roles[self.time] = "time"
        if self.record is not None:
            roles[self.record] = "record id"
        return roles

    def unit_channels(self) -> dict[str, str]:
        return {"t": "time", "x": f"input {self.input!r}", "y": f"output {self.output!r}",
                **{k: f"extra {c!r}" for k, c in self.extra.items()},
                **{k: f"control {c!r}" for k, c in self.controls.items()}}


def _as_map(value) -> dict[str, str]:
    """A list of columns (named after themselves), one column, or ``{name: column}`` -> ``{name: column}``."""
    if value is None:
        return {}
    if isinstance(value, str):
        return {value: value}
    if isinstance(value, Mapping):
        return {str(k): str(v) for k, v in value.items()}
    return {str(c): str(c) for c in value}


# -- files -----------------------------------------------------------------------------------------------
def expand_files(path) -> list[Path]:
    """One path, or the sorted files matching a glob pattern; an error names close file names."""
    text = str(path)
    files = sorted(Path(p) for p in glob.glob(text)) if glob.has_magic(text) else [Path(text)]
    files = [f for f in files if f.is_file()] if glob.has_magic(text) else files
    if not files or not files[0].exists():
        parent = Path(text).parent
        names = sorted(p.name for p in parent.iterdir()) if parent.is_dir() else []
        close = difflib.get_close_matches(Path(text).name, names, n=3)
        hint = f"; did you mean {close}?" if close else (f"; {parent} holds {names[:10]}" if names else "")
        what = "no file matches the pattern" if glob.has_magic(text) else "no such file"
        raise FileNotFoundError(f"{what} {text!r}{hint}")
    for f in files:
        if f.is_dir():
            raise ValueError(f"{str(f)!r} is a folder; give a file or a glob pattern such as '{f / '*.csv'}'")
        if f.stat().st_size == 0:
            raise ValueError(f"file {str(f)!r} is empty (0 bytes); remove it or re-export the data")
    return files


# -- one table -> records ----------------------------------------------------------------------------------
def _check_columns(frame: pd.DataFrame, mapping: ColumnMap, where: str, noun: str) -> None:
    columns = [str(c) for c in frame.columns]
    for column, role in mapping.roles().items():
        if column in frame.columns:
            continue
        lower = {c.lower(): c for c in columns}
        close = [lower[column.lower()]] if column.lower() in lower else difflib.get_close_matches(column, columns, n=1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise ValueError(f"{where}: no {noun} {column!r} (the {role}); {hint}{noun}s are: {columns}")


def _numeric(frame: pd.DataFrame, column: str, where: str, noun: str) -> np.ndarray:
    """The column as float64; non-numeric cells and a column shorter than the others are errors."""
    raw = frame[column]
    values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=np.float64, na_value=np.nan)
    rows = frame.index.to_numpy()
    text = raw.notna().to_numpy() & np.isnan(values)
    if text.any():
        example = raw[text].iloc[0]
        raise ValueError(
            f"{where}: {noun} {column!r} has {int(text.sum())} non-numeric values (rows {_rows(text, rows)}, "
            f"e.g. {example!r}); fix or remove those cells{decimal_comma_hint(example)}"
        )
    missing = np.isnan(values)
    first = int(np.argmax(missing))
    if missing.any() and first > 0 and missing[first:].all() and frame.shape[1] > 1 \
            and frame.drop(columns=[column]).iloc[first:].notna().any(axis=1).all():
        raise ValueError(
            f"{where}: {noun} {column!r} has {int(missing.sum())} fewer values than the other {noun}s "
            f"(rows {_rows(missing, rows)} are empty): mismatched lengths; trim the other {noun}s or fill this one"
        )
    return values


def _condition(frame: pd.DataFrame, column: str, where: str, noun: str):
    values = frame[column]
    rows = frame.index.to_numpy()
    bad = values.isna().to_numpy()
    if bad.any():
        raise ValueError(
            f"{where}: condition {noun} {column!r} has {int(bad.sum())} missing values (rows {_rows(bad, rows)}); "
            "fill them (a condition is constant within a record)"
        )
    first = values.iloc[0]
    changed = (values != first).to_numpy()
    if changed.any():
        distinct = [v.item() if isinstance(v, np.generic) else v for v in pd.unique(values)[:5]]
        raise ValueError(
            f"{where}: condition {noun} {column!r} varies within the record (values {distinct}, first change at "
            f"row {rows[changed][0]}); conditions must be constant per record: if it is a control that varies "
            f"in time (a voltage, a pressure schedule), name it in data.controls (controls=[{column!r}]) instead; "
            "else give a record column that separates the records"
        )
    first = first.item() if isinstance(first, np.generic) else first
    if isinstance(first, str) and _NUMBER.match(first):
        return float(first)  # a number in a column that pandas read as text because another record's is text
    return first


def records_from_frame(frame: pd.DataFrame, mapping: ColumnMap, file: str, stem: str, units: dict,
                       min_samples: int = 2, noun: str = "column") -> list[Record]:
    """Split a table into records (by the record column, else one record named ``stem``) and validate them.

    ``frame.index`` holds the row numbers reported in messages.
    """
    where = f"file {file!r}"
    _check_columns(frame, mapping, where, noun)
    if mapping.record is None:
        groups = [(stem, frame)]
    else:
        ids = frame[mapping.record]
        if ids.isna().any():
            bad = ids.isna().to_numpy()
            raise ValueError(
                f"{where}: record id {noun} {mapping.record!r} is empty at rows {_rows(bad, frame.index.to_numpy())}; "
                "fill in the record id of every row"
            )
        groups = [(str(key.item() if isinstance(key, np.generic) else key), part)
                  for key, part in frame.groupby(ids, sort=False)]
    return [_one_record(part, mapping, file, name, units, min_samples, noun) for name, part in groups]


def _one_record(part: pd.DataFrame, mapping: ColumnMap, file: str, name: str, units: dict,
                min_samples: int, noun: str) -> Record:
    where = f"file {file!r}, record {name!r}"
    channels, labels = {}, {}
    for channel, column in mapping.channels().items():
        if column is None:
            channels[channel] = np.arange(len(part)) / mapping.fs
            labels[channel] = f"time (row / fs, fs={mapping.fs:g} Hz)"
        else:
            channels[channel] = _numeric(part, column, where, noun)
            labels[channel] = f"{noun} {column!r}"
    rows = part.index.to_numpy()
    try:
        arrays = validate_channels(where, channels, labels=labels, rows=rows)
    except ValueError as err:
        if mapping.record is None and ("not increasing" in str(err) or "duplicate timestamps" in str(err)):
            raise ValueError(f"{err}; if the file holds several records, name its record-id {noun} with record=") \
                from None
        raise
    if len(part) < min_samples:
        raise ValueError(
            f"{where}: {len(part)} sample(s) (rows {_rows(np.ones(len(part), bool), rows)}) but at least "
            f"{min_samples} are needed (min_samples={min_samples}); drop this record or merge it with its neighbour"
        )
    if len(part) > 1 and np.all(arrays["x"] == arrays["x"][0]) and np.all(arrays["y"] == arrays["y"][0]):
        # a constant input alone is a free vibration or a relaxation test: its response still carries the dynamics
        raise ValueError(
            f"{where}: {labels['x']} (the input) is {arrays['x'][0]:g} and {labels['y']} (the response) "
            f"{arrays['y'][0]:g} at every one of its {len(part)} rows ({_rows(np.ones(len(part), bool), rows)}): "
            f"the record holds no motion, so no model can be fitted to it; check that the input {noun} is the "
            f"excitation (not a condition or a status {noun}), or drop the "
            "record"
        )
    conditions = {key: _condition(part, column, where, noun) for key, column in mapping.conditions.items()}
    extra = {k: arrays[k] for k in mapping.extra}
    controls = {k: arrays[f"control {k}"] for k in mapping.controls}
    return Record(name=name, t=arrays["t"], x=arrays["x"], y=arrays["y"], conditions=conditions,
                  units=units, extra=extra, source=file, controls=controls)


# -- public readers ----------------------------------------------------------------------------------------
def _collect(files: list[Path], per_file, name: str | None, default: str) -> RecordSet:
    records: list[Record] = []
    many = len(files) > 1
    stems = [f.stem for f in files]
    for f in files:
        stem = f.stem if stems.count(f.stem) == 1 else f.with_suffix("").as_posix()
        found = per_file(f, stem)
        if many and (len(found) > 1 or found[0].name != stem):
            for r in found:
                r.name = f"{stem}/{r.name}"
        records += found
    return RecordSet(records, name=name if name is not None else default)


def read_table(path, time: str | None = "t", input: str = "x", output: str = "y", conditions=(),
               record: str | None = None, units: dict | None = None, extra=None, name: str | None = None,
               fs: float | None = None, min_samples: int = 2, read_options: dict | None = None,
               max_file_mb: float | None = MAX_FILE_MB, controls=None, warmup: int = 0) -> RecordSet:
    """Read csv/tsv/parquet files into a ``RecordSet``.

    Parameters
    ----------
    path : a file, or a glob pattern (``"runs/*.csv"``): one record per file unless ``record`` is given.
    time, input, output : columns of time [s], excitation x and response y. ``time=None`` with ``fs``
        derives time as ``row / fs``.
    conditions : condition columns (list; the condition is named after the column) or
        ``{condition: column}``; each must be constant within a record.
    controls : control columns that vary in time (a coil voltage, an underpressure schedule): a list or
        ``{control: column}``, ``Record.controls``; a parameter function of one is evaluated at every step.
    record : column holding a record id: the file holds several records, in order of first appearance.
    units : ``{channel: unit}`` for "t", "x", "y" and extra channels, checked against ``KNOWN_UNITS``.
    extra : additional channels: a list of columns or ``{channel: column}`` (e.g. ``{"velocity": "v"}``).
    name : name of the record set (default: the file stem, or the pattern).
    fs : sample rate [Hz] when there is no time column.
    min_samples : records with fewer samples are an error.
    read_options : passed to ``pandas.read_csv`` / ``pandas.read_parquet``, e.g. ``{"sep": ";"}``,
        ``{"encoding": "utf-16"}``, ``{"decimal": ","}``; a file that needs one is an error naming it.
    max_file_mb : larger files are refused (with their size) before they are read; None: no limit. Text
        files above 16 MB are read in chunks, with their progress shown.
    warmup : leading samples of every record that are simulated but not scored (``Record.warmup``): a periodic
        steady-state record extended at the front by its own last samples, so that a model started from rest
        has settled when scoring begins.

    Returns
    -------
    RecordSet
        Float64 records; the file path is each record's ``source``.
    """
    mapping = ColumnMap.build(time, input, output, conditions, record, extra, fs, f"file {str(path)!r}", controls)
    files = expand_files(path)
    units = check_units(units, f"file {str(path)!r}", mapping.unit_channels())

    def per_file(f: Path, stem: str) -> list[Record]:
        return records_from_frame(read_frame(f, read_options, max_file_mb), mapping, str(f), stem, units,
                                  min_samples)

    records = _checked(_collect(files, per_file, name, Path(str(path)).stem), mapping, "column")
    if warmup:
        records = RecordSet([replace(r, warmup=warmup) for r in records], name=records.name)
    return records


def _read_arrays(path, loader, time, input, output, conditions, record, units, extra, name, fs,
                 min_samples, controls=None) -> RecordSet:
    mapping = ColumnMap.build(time, input, output, conditions, record, extra, fs, f"file {str(path)!r}", controls)
    files = expand_files(path)
    units = check_units(units, f"file {str(path)!r}", mapping.unit_channels())

    def per_file(f: Path, stem: str) -> list[Record]:
        out = []
        for rid, frame, local in frame_from_arrays(loader(f), mapping, str(f)):
            out += records_from_frame(frame, local, str(f), stem if rid is None else rid, units, min_samples, "key")
        return out

    return _checked(_collect(files, per_file, name, Path(str(path)).stem), mapping, "key")


def _checked(records: RecordSet, mapping: ColumnMap, noun: str) -> RecordSet:
    """The records, once their scales agree (``scales.check_scales``: no unit mix between them)."""
    check_scales(records, None if mapping.time is None else f"{noun} {mapping.time!r}", f"{noun} {mapping.input!r}")
    return records


def read_npz(path, time: str | None = "t", input: str = "x", output: str = "y", conditions=(),
             record: str | None = None, units: dict | None = None, extra=None, name: str | None = None,
             fs: float | None = None, min_samples: int = 2, controls=None) -> RecordSet:
    """Read ``.npz`` files: the same mapping as ``read_table`` with array keys instead of columns.

    A key is a 1-D array (time,), ``"key[i]"`` (column i, 0-based, of an ``(time, C)`` array) or a
    scalar (a condition). A ``{record}`` placeholder reads several records from one file, e.g.
    ``read_npz("bw.npz", time=None, fs=750, input="{record}_u", output="{record}_y")`` finds the
    records ``train``, ``test_multisine``, ... from keys ``train_u``, ``train_y``, ...
    Arrays of different lengths are an error naming both keys. See ``read_table`` for the parameters.
    """
    return _read_arrays(path, load_npz, time, input, output, conditions, record, units, extra, name, fs, min_samples,
                        controls)


def read_mat(path, time: str | None = "t", input: str = "x", output: str = "y", conditions=(),
             record: str | None = None, units: dict | None = None, extra=None, name: str | None = None,
             fs: float | None = None, min_samples: int = 2, controls=None) -> RecordSet:
    """Read MATLAB ``.mat`` files (v4-v7.2, via ``scipy.io.loadmat``); keys as in ``read_npz``.

    Row and column vectors (1, N) / (N, 1) are both read as (N,). Structs are not unpacked: save the
    fields as top-level variables. v7.3 (HDF5) files are an error that says how to re-save them.
    """
    return _read_arrays(path, load_mat, time, input, output, conditions, record, units, extra, name, fs, min_samples,
                        controls)


READERS = {".csv": read_table, ".txt": read_table, ".tsv": read_table, ".parquet": read_table, ".pq": read_table,
           ".npz": read_npz, ".mat": read_mat}


def read(path, **mapping) -> RecordSet:
    """Read any supported file (or glob pattern) by its extension: csv/tsv/txt/parquet, npz or mat.

    ``mapping`` is passed on: ``time``, ``input``, ``output``, ``conditions``, ``controls``, ``record``, ``units``,
    ``extra``, ``name``, ``fs``, ``min_samples`` (and ``read_options`` for tables).
    """
    suffix = re.sub(r"[*?\]]+$", "", Path(str(path)).suffix.lower())
    reader = READERS.get(suffix)
    if reader is None:
        raise ValueError(f"cannot read {str(path)!r}: unknown extension {suffix!r}; supported: {sorted(READERS)}")
    return reader(path, **mapping)
