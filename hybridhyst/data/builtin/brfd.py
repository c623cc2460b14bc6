"""Banded rotary friction damper (BRFD), measured: dataset-2 of Coble et al. (ARTS Laboratory), CC BY-SA 4.0.

Attribution and licence: ``files/brfd/ATTRIBUTION.md`` and ``files/brfd/LICENSE_CC-BY-SA-4.0.txt``.
The bundled file is made by ``scripts/make_builtin_data.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..records import Record, RecordSet

__all__ = ["CONDITIONS", "load_brfd"]

FILE = Path(__file__).parent / "files" / "brfd" / "brfd_dataset2.npz"
CONDITIONS = ("frequency_hz", "tension_lb", "amplitude_in", "kind", "earthquake", "hazard_level", "tension_suspect")
KINDS = ("characterisation", "earthquake")


def load_brfd(kind: str | None = None) -> RecordSet:
    """The 35 BRFD records at 1024 Hz: 31 characterisation tests and 4 earthquake histories.

    Channels: x = displacement [in], y = friction force [kip], extra ``velocity`` [in/s] (stored as
    float32, returned as float64), t [s].

    Conditions (one row per record in ``records.conditions``):

    * ``frequency_hz`` — sine frequency {0.25, 0.5, 1, 2}; 0.0 for earthquake records (no single
      frequency);
    * ``tension_lb`` — band tension {0, 30, 36} (earthquakes: 36);
    * ``amplitude_in`` — nominal amplitude {0.5, 1, 1.5}; for earthquake records the peak |x| rounded
      to 0.001 in (0.585, 1.334, 0.184, 0.372), so no nominal value matches them by accident;
    * ``kind`` — "characterisation" or "earthquake";
    * ``earthquake`` — "" or "ImperialValley" / "Kocaeli"; ``hazard_level`` — "" or "DBE" / "MCE";
    * ``tension_suspect`` — True for the 0 lb tests that upstream flags for an incorrect band-tension
      measurement (5 here: 0.5 in at 0.25/0.5/1/2 Hz and 1 in at 0.25 Hz; the other two flagged tests
      are 0.1 Hz ones, not part of the data).

    Record names are the upstream keys, e.g. ``"char_0.5Hz_36lb_1in"``, ``"eq36lb_KocaeliDBE"``.

    Parameters
    ----------
    kind : keep only "characterisation" or "earthquake" records (default: all).
    """
    if kind is not None and kind not in KINDS:
        raise ValueError(f"brfd: kind must be one of {KINDS} or None, got {kind!r}")
    records = []
    with np.load(FILE) as data:
        fs = float(data["fs"])
        index = {c: data[f"index_{c}"].tolist() for c in CONDITIONS}
        paths = data["index_source_path"].tolist()
        for i, key in enumerate(data["index_key"].tolist()):
            if kind is not None and index["kind"][i] != kind:
                continue
            channels = data[key].astype(np.float64)
            time_key = f"{key}__time_s"
            t = data[time_key] if time_key in data.files else np.arange(channels.shape[1]) / fs
            records.append(Record(
                name=key, t=t, x=channels[0], y=channels[1], extra={"velocity": channels[2]},
                conditions={c: index[c][i] for c in CONDITIONS},
                units={"t": "s", "x": "in", "y": "kip", "velocity": "in/s"},
                source=f"BRFD dataset-2, {paths[i]}",
            ))
    return RecordSet(records, name="brfd")
