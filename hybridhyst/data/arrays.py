"""npz / MAT files as tables: load the arrays, resolve the keys a reader asks for, build one frame per record.

Key references used by ``read_npz`` and ``read_mat``:

* ``"key"``: a 1-D array ``(time,)``; MATLAB row/column vectors ``(1, N)``/``(N, 1)`` count as 1-D;
* ``"key[i]"``: column ``i`` (0-based) of a 2-D ``(time, C)`` array;
* a size-1 array (scalar) is a condition value for the whole record;
* ``"{record}"`` inside a reference (``"{record}_u"``) reads one record per matching key.
"""

from __future__ import annotations

import difflib
import re
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["frame_from_arrays", "load_mat", "load_npz"]

PLACEHOLDER = "{record}"
_COLUMN = re.compile(r"^(?P<key>.+?)\[(?P<col>-?\d+)\]$")


def load_npz(file: Path) -> dict[str, np.ndarray]:
    """All arrays of an ``.npz`` archive (no pickled objects)."""
    with open(file, "rb") as handle:
        magic = handle.read(6)
    if magic.startswith(b"\x93NUMPY"):
        raise ValueError(f"file {str(file)!r} is a single .npy array, not an .npz archive of named arrays; save it "
                         "with numpy.savez(name, t=..., x=..., y=...)")
    if not magic.startswith(b"PK"):
        raise ValueError(f"file {str(file)!r} is not an .npz archive (it starts with {magic!r}); re-save it with "
                         "numpy.savez, or read a csv file under its own extension")
    try:
        with open(file, "rb") as handle, np.load(handle, allow_pickle=False) as archive:  # closed if not a zip
            arrays = {k: archive[k] for k in archive.files}
    except ValueError as err:
        if "allow_pickle" in str(err):
            raise ValueError(
                f"file {str(file)!r} holds pickled object arrays, which are not read for safety; "
                "save plain numeric or string arrays with numpy.savez"
            ) from None
        raise ValueError(f"file {str(file)!r} is not a valid .npz archive ({err}); re-save it with numpy.savez") \
            from None
    except (OSError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(f"file {str(file)!r} is not a valid .npz archive ({err}); re-save it with numpy.savez") \
            from None
    if not arrays:
        raise ValueError(f"file {str(file)!r} holds no arrays; re-export the data")
    return arrays


def load_mat(file: Path) -> dict[str, np.ndarray]:
    """The variables of a MATLAB v4-v7.2 file (``scipy.io.loadmat``), without the ``__header__`` entries."""
    import scipy.io

    try:
        data = scipy.io.loadmat(file, squeeze_me=False, chars_as_strings=True)
    except NotImplementedError:
        raise ValueError(
            f"file {str(file)!r} is a MATLAB v7.3 (HDF5) file; re-save it in MATLAB with save(name, '-v7') "
            "or export the variables to csv/npz"
        ) from None
    except (ValueError, TypeError, OSError, scipy.io.matlab.MatReadError) as err:  # corrupt or foreign file
        raise ValueError(
            f"file {str(file)!r} is not a readable MAT file ({err}); re-save it with save(name, '-v7')"
        ) from None
    arrays = {k: v for k, v in data.items() if not k.startswith("__")}
    if not arrays:
        raise ValueError(f"file {str(file)!r} holds no variables; re-export the data")
    return arrays


def _missing(arrays: dict, ref: str, where: str, role: str) -> ValueError:
    keys = sorted(arrays)
    lower = {k.lower(): k for k in keys}
    close = [lower[ref.lower()]] if ref.lower() in lower else difflib.get_close_matches(ref, keys, n=1)
    hint = f"did you mean {close[0]!r}? " if close else ""
    return ValueError(f"{where}: no key {ref!r} (the {role}); {hint}keys are: {keys}")


def resolve(arrays: dict, ref: str, where: str, role: str) -> np.ndarray:
    """The array a reference names, as 1-D ``(time,)`` (or size 1 for a scalar)."""
    match = _COLUMN.match(ref)
    if ref in arrays:
        key, col = ref, None
    elif match and match["key"] in arrays:
        key, col = match["key"], int(match["col"])
    else:
        raise _missing(arrays, ref, where, role)
    a = np.asarray(arrays[key])
    if a.dtype.names is not None or a.dtype == object:
        raise ValueError(f"{where}: key {key!r} (the {role}) is a struct/cell array; save its fields as plain arrays")
    if a.ndim == 2 and col is None and 1 in a.shape:
        a = a.reshape(-1)
    if col is not None:
        if a.ndim != 2 or not -a.shape[1] <= col < a.shape[1]:
            raise ValueError(f"{where}: {ref!r} (the {role}) asks for column {col} of key {key!r} with shape {a.shape}")
        a = a[:, col]
    if a.ndim > 1:
        raise ValueError(
            f"{where}: key {key!r} (the {role}) has shape {a.shape}; pick one column with '{key}[i]' (0-based)"
        )
    return np.atleast_1d(a)


def _substitute(mapping, rid: str):
    def sub(v: str | None) -> str | None:
        return None if v is None else v.replace(PLACEHOLDER, rid)

    return replace(mapping, time=sub(mapping.time), input=sub(mapping.input), output=sub(mapping.output),
                   extra={k: sub(v) for k, v in mapping.extra.items()},
                   conditions={k: sub(v) for k, v in mapping.conditions.items()},
                   controls={k: sub(v) for k, v in mapping.controls.items()})


def _record_ids(arrays: dict, mapping, file: str) -> list[str] | None:
    refs = [mapping.input, mapping.output, mapping.time, *mapping.extra.values(), *mapping.conditions.values(),
            *mapping.controls.values()]
    refs = [r for r in refs if r is not None and PLACEHOLDER in r]
    if not refs:
        return None
    if mapping.record is not None:
        raise ValueError(f"file {file!r}: use either record= or a {PLACEHOLDER} placeholder in the keys, not both")
    anchor = refs[0]
    match = _COLUMN.match(anchor)
    anchor = match["key"] if match else anchor
    pattern = re.compile(re.escape(anchor).replace(re.escape(PLACEHOLDER), "(.+)"))
    ids = [m.group(1) for k in arrays if (m := pattern.fullmatch(k))]
    if not ids:
        raise ValueError(f"file {file!r}: no key matches {anchor!r}; keys are: {sorted(arrays)}")
    return ids


def _frame(arrays: dict, mapping, file: str, rid: str | None) -> pd.DataFrame:
    where = f"file {file!r}" + (f", record {rid!r}" if rid is not None else "")
    condition_refs = set(mapping.conditions.values())
    series, n, first = {}, None, None
    for ref, role in mapping.roles().items():
        a = resolve(arrays, ref, where, role)
        if ref in condition_refs:
            continue
        if n is None:
            n, first = len(a), ref
        elif len(a) != n:
            raise ValueError(
                f"{where}: key {ref!r} (the {role}) has {len(a)} samples but key {first!r} has {n}; "
                "all channels of a record must have the same length: trim or fix the arrays"
            )
        series[ref] = a
    frame = pd.DataFrame(series)
    for ref in condition_refs:
        a = resolve(arrays, ref, where, mapping.roles()[ref])
        if len(a) == 1:
            frame[ref] = a[0].item() if isinstance(a[0], np.generic) else a[0]
        elif len(a) == n:
            frame[ref] = a
        else:
            raise ValueError(
                f"{where}: condition key {ref!r} has {len(a)} values; give one value (a scalar) or one per sample ({n})"
            )
    return frame


def frame_from_arrays(arrays: dict, mapping, file: str) -> list[tuple[str | None, pd.DataFrame, object]]:
    """``[(record id or None, frame, mapping with resolved keys)]``: one entry per ``{record}`` match, else one."""
    ids = _record_ids(arrays, mapping, file)
    if ids is None:
        return [(None, _frame(arrays, mapping, file, None), mapping)]
    out = []
    for rid in ids:
        local = _substitute(mapping, rid)
        out.append((rid, _frame(arrays, local, file, rid), local))
    return out
