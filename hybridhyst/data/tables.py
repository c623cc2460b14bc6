"""One csv/tsv/parquet file as a ``pandas.DataFrame``, with the file-level mistakes named and their fix.

What is refused, each with the option that reads the file (``read_options`` of ``read_table``, passed to
``pandas.read_csv``; ``data.read_options`` on an app's command line, quoted for the shell):

* UTF-16 text (a byte-order mark or NUL bytes) and text that is not UTF-8: ``{encoding: utf-16}`` /
  ``{encoding: latin-1}``;
* a zip archive (an Excel workbook renamed .csv) or other binary data: export it as csv;
* a semicolon-separated file read as one column: ``{sep: ';'}`` (and ``decimal: ','`` when the numbers have
  a decimal comma);
* rows with more fields than the header (a decimal comma in a comma-separated file) and ragged rows;
* a file larger than ``max_file_mb`` (default 1024 MB), before anything is read: its size and the option.
  Text files above ``CHUNK_MB`` are read in chunks, with their progress shown (``hybridhyst.progress``), so a
  Ctrl-C stops the read at once.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pandas as pd

from ..progress import progress

__all__ = ["CHUNK_MB", "MAX_FILE_MB", "TABLE_SUFFIXES", "read_frame"]

TABLE_SUFFIXES = {".csv": "csv", ".txt": "csv", ".tsv": "tsv", ".parquet": "parquet", ".pq": "parquet"}
MAX_FILE_MB = 1024.0  # larger files are refused unless max_file_mb says otherwise (memory: several times the size)
CHUNK_MB = 16.0  # larger text files are read in chunks with a progress bar
CHUNK_ROWS = 200_000
_MB = 2**20
_DECIMAL_COMMA = re.compile(r"^\s*[-+]?\d+,\d+([eE][-+]?\d+)?\s*$")


def option(python: str, command_line: str) -> str:
    """The fix as ``read_table``'s argument and as the app's override, quoted for the shell."""
    return f"read_options={python} (on the command line: \"data.read_options={command_line}\")"


def decimal_comma_hint(cell) -> str:
    """The sentence for a non-numeric cell that is a number with a decimal comma (``'0,005'``), else ''."""
    if isinstance(cell, str) and _DECIMAL_COMMA.match(cell):
        return f"; {cell!r} has a decimal comma: read it with " + option("{'decimal': ','}", "{decimal: ','}")
    return ""


def read_frame(file: Path, read_options: dict | None, max_file_mb: float | None = MAX_FILE_MB) -> pd.DataFrame:
    """The table in ``file`` with a fresh 0-based index (the data rows reported in messages).

    Raises
    ------
    ValueError
        Naming the file and the fix: an unknown extension, a file over ``max_file_mb`` (None: no limit), an
        encoding or separator it was not read with, rows with more fields than the header, no data rows.
    """
    kind = TABLE_SUFFIXES.get(file.suffix.lower())
    if kind is None:
        raise ValueError(f"file {str(file)!r}: read_table reads {sorted(TABLE_SUFFIXES)} files; use read() for npz/mat")
    options = dict(read_options or {})
    _check_size(file, max_file_mb)
    if kind != "parquet" and "encoding" not in options:
        _check_text(file)
    try:
        frame = pd.read_parquet(file, **options) if kind == "parquet" else _read_text(file, kind, options)
    except pd.errors.EmptyDataError:
        raise ValueError(f"file {str(file)!r} has no header and no data; re-export it with a header row") from None
    except UnicodeDecodeError as err:
        encoding = options.get("encoding", "utf-8")
        raise ValueError(
            f"file {str(file)!r} is not {encoding} text (byte {err.object[err.start:err.start + 1]!r} at byte "
            f"{err.start}); give its encoding, e.g. " + option("{'encoding': 'latin-1'}", "{encoding: latin-1}")
        ) from None
    except pd.errors.ParserError as err:
        raise ValueError(f"file {str(file)!r} is not a regular table ({_first_line(err)}): every row needs as many "
                         "fields as the header; fix those rows, or give the separator, e.g. "
                         + option("{'sep': ';'}", "{sep: ';'}")) from None
    _check_shape(file, frame, kind, options)
    if len(frame) == 0:
        raise ValueError(
            f"file {str(file)!r} has columns {list(frame.columns)} but no data rows; remove it or re-export the data"
        )
    return frame.reset_index(drop=True)


def _first_line(err: Exception) -> str:
    return str(err).strip().splitlines()[-1].removeprefix("Error tokenizing data. C error: ")


def _check_size(file: Path, max_file_mb: float | None) -> None:
    size = file.stat().st_size / _MB
    if max_file_mb is not None and size > float(max_file_mb):
        need = math.ceil(size * 1.1)
        raise ValueError(
            f"file {str(file)!r} is {size:.3g} MB, over the {float(max_file_mb):g} MB limit: held in memory it "
            f"takes several times its size; thin it or split it into one file per record (a glob "
            f"pattern reads them), or raise the limit with max_file_mb={need} (data.max_file_mb={need})"
        )


def _check_text(file: Path) -> None:
    with open(file, "rb") as handle:
        head = handle.read(4096)
    if head.startswith((b"\xff\xfe", b"\xfe\xff")) or (head.count(b"\x00") > len(head) // 4 and
                                                       b"\x00" in head[:2]):
        raise ValueError(f"file {str(file)!r} is UTF-16 text (" +
                         ("a byte-order mark" if head[:2] in (b"\xff\xfe", b"\xfe\xff") else "NUL bytes") +
                         "); read it with " + option("{'encoding': 'utf-16'}", "{encoding: utf-16}") +
                         ", or re-save it as UTF-8")
    if head.startswith(b"PK\x03\x04"):
        raise ValueError(f"file {str(file)!r} is a zip archive (an Excel workbook?), not text; export the sheet as "
                         "csv (one row per sample) and read that")
    if b"\x00" in head:
        raise ValueError(f"file {str(file)!r} holds binary data (NUL bytes), not a text table; export it as csv, "
                         "or read npz/mat files with read()")


def _read_text(file: Path, kind: str, options: dict) -> pd.DataFrame:
    options = {**({"sep": "\t"} if kind == "tsv" else {}), **options}
    size = file.stat().st_size
    if size <= CHUNK_MB * _MB or "chunksize" in options or "nrows" in options:
        return pd.read_csv(file, **options)
    parts = []
    with open(file, "rb") as handle, progress(total=max(1, round(size / _MB)), desc=f"reading {file.name} [MB]") as bar:
        for chunk in pd.read_csv(handle, chunksize=CHUNK_ROWS, **options):
            parts.append(chunk)
            bar.update(max(0, round(handle.tell() / _MB) - bar.n))
    return pd.concat(parts) if parts else pd.DataFrame()


def _check_shape(file: Path, frame: pd.DataFrame, kind: str, options: dict) -> None:
    if kind != "parquet" and frame.shape[1] == 1 and "sep" not in options:
        _check_separator(file, str(frame.columns[0]), options)
    if "index_col" not in options and not isinstance(frame.index, pd.RangeIndex):
        levels = frame.index.nlevels
        raise ValueError(
            f"file {str(file)!r}: the data rows have {levels} more field(s) than the header {list(frame.columns)}; "
            "a decimal comma in a comma-separated file? re-export it with decimal points (or another separator "
            "and " + option("{'sep': ';', 'decimal': ','}", "{sep: ';', decimal: ','}") + "), or complete the header"
        )


def _check_separator(file: Path, header: str, options: dict) -> None:
    """A table read as one column whose header holds a semicolon or a tab: name the separator to use."""
    for sep, name in ((";", "semicolon"), ("\t", "tab")):
        if sep not in header:
            continue
        with open(file, encoding=options.get("encoding", "utf-8"), errors="replace") as handle:
            handle.readline()
            first = handle.readline()
        comma = any(_DECIMAL_COMMA.match(cell) for cell in first.strip().split(sep))
        if sep == "\t":
            fix = "rename it to .tsv (read as tab-separated)"
        elif comma:
            fix = "read it with " + option("{'sep': ';', 'decimal': ','}", "{sep: ';', decimal: ','}")
        else:
            fix = "read it with " + option("{'sep': ';'}", "{sep: ';'}")
        raise ValueError(f"file {str(file)!r} was read as one column {header!r}: it is {name}-separated; {fix}")
