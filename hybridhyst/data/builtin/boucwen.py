"""The Bouc–Wen nonlinear system-identification benchmark (Noël & Schoukens 2016), simulated data.

Source and licences: ``files/boucwen/SOURCE.md``, ``ATTRIBUTION.md`` and the two MIT licence files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..records import Record, RecordSet

__all__ = ["load_boucwen"]

FILE = Path(__file__).parent / "files" / "boucwen" / "boucwen_benchmark.npz"
# record name -> (npz key prefix, split, signal)
RECORDS = {
    "train": ("train", "train", "multisine"),
    "multisine": ("test_multisine", "test", "multisine"),
    "sinesweep": ("test_sinesweep", "test", "sinesweep"),
}


PERIODIC = {"multisine"}  # test records given as one period of the periodic steady state


def load_boucwen() -> RecordSet:
    """The benchmark's training and two test records, float64 as published.

    Records ``"train"`` (40960 samples: 5 periods plus 1 transient period of a 5-150 Hz, 50 N RMS
    random-phase multisine), ``"multisine"`` (8192, official multisine test) and ``"sinesweep"``
    (153000, official 20→50 Hz, 40 N sine-sweep test), all at fs = 750 Hz, t = sample / fs [s].

    The multisine test output is the periodic steady state (SOURCE.md), so that record is extended at the
    front by its own last quarter period (2048 samples, input and output: the signal is periodic) and
    those samples are its ``warmup``: a model simulated from rest settles on them and is scored on the
    official 8192 samples only, as the published results are.

    Channels: x = input force u [N], y = output displacement [m]. Conditions: ``split`` ("train" or
    "test") and ``signal`` ("multisine" or "sinesweep"), so ``records.split(held_out={"split":
    ["test"]})`` gives the benchmark's own protocol.

    Returns
    -------
    RecordSet named "boucwen".
    """
    with np.load(FILE) as data:
        fs = float(data["fs"])
        records = []
        for name, (key, split, signal) in RECORDS.items():
            u, y = data[f"{key}_u"], data[f"{key}_y"]
            warmup = len(u) // 4 if name in PERIODIC else 0
            if warmup:
                u, y = np.concatenate([u[-warmup:], u]), np.concatenate([y[-warmup:], y])
            records.append(Record(
                name=name, t=np.arange(len(u)) / fs, x=u, y=y, conditions={"split": split, "signal": signal},
                units={"t": "s", "x": "N", "y": "m"}, source=f"Bouc-Wen benchmark ({key}_u/{key}_y)",
                warmup=warmup,
            ))
    return RecordSet(records, name="boucwen")
