"""Regenerate the datasets bundled in ``hybridhyst/data/builtin/files/`` from the shared data folder.

Usage::

    PYTHONPATH=. python scripts/make_builtin_data.py [--shared ../shared]

This script may read the shared folder; the package never does at run time.

* ``brfd/brfd_dataset2.npz``: the 35 records of the BRFD dataset-2 repack at the full 1024 Hz rate.
  Per record ``<key>`` is a float32 array ``(3, N)`` = displacement [in], friction force [kip],
  velocity [in/s] (the two actuator-force columns are dropped). Time is ``arange(N) / fs``, which is
  bit-exact for 30 records; for the other 5 (whose upstream time column was printed with 8 decimals,
  within 1e-8 s of that grid) the float64 upstream time is kept as ``<key>__time_s``, so nothing is
  lost. ``index_*`` arrays hold the conditions of every record (see ``hybridhyst/data/builtin/brfd.py``).
* ``boucwen/boucwen_benchmark.npz``: byte-for-byte copy (float64).
* Output is byte-reproducible: rerunning the script leaves ``git status`` clean.
* Licence files and the upstream SOURCE.md are copied next to the data.
"""

from __future__ import annotations

import argparse
import re
import shutil
import zipfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
TARGET = REPO / "hybridhyst" / "data" / "builtin" / "files"
FS_BRFD = 1024.0
# upstream README: 0 lb tests with an incorrect band-tension measurement (f [Hz], A [in]); the two
# 0.1 Hz ones are not part of the repack, so 5 of these 7 exist here
TENSION_SUSPECT = {(0.1, 0.5), (0.25, 0.5), (0.5, 0.5), (1.0, 0.5), (2.0, 0.5), (0.1, 1.0), (0.25, 1.0)}


def _earthquake_conditions(key: str, x: np.ndarray) -> dict:
    match = re.fullmatch(r"eq(\d+)lb_([A-Za-z]+?)(DBE|MCE)", key)
    if match is None:
        raise ValueError(f"unexpected earthquake key {key!r}")
    return {"kind": "earthquake", "earthquake": match.group(2), "hazard_level": match.group(3),
            "frequency_hz": 0.0, "tension_lb": float(match.group(1)),
            "amplitude_in": round(float(np.abs(x).max()), 3), "tension_suspect": False}


def brfd(shared: Path) -> dict[str, np.ndarray]:
    """All 35 BRFD records as float32 channels plus the condition index."""
    src = np.load(shared / "data" / "brfd" / "brfd_dataset2.npz")
    out: dict[str, np.ndarray] = {}
    rows = []
    for i, key in enumerate(src["index_key"].tolist()):
        a = src[key]
        out[key] = np.ascontiguousarray(a[:, 1:4].T.astype(np.float32))
        t = a[:, 0]
        if not np.array_equal(t, np.arange(len(t)) / FS_BRFD):
            out[f"{key}__time_s"] = t.copy()
        if key.startswith("char_"):
            keys = ("index_freq_Hz", "index_band_tension_lb", "index_amplitude_in")
            f, tension, amp = (float(src[k][i]) for k in keys)
            rows.append({"kind": "characterisation", "earthquake": "", "hazard_level": "", "frequency_hz": f,
                         "tension_lb": tension, "amplitude_in": amp,
                         "tension_suspect": tension == 0.0 and (f, amp) in TENSION_SUSPECT})
        else:
            rows.append(_earthquake_conditions(key, a[:, 1]))
    out["index_key"] = src["index_key"]
    out["index_source_path"] = src["index_source_path"]
    for col in rows[0]:
        out[f"index_{col}"] = np.asarray([r[col] for r in rows])
    out["fs"] = np.float64(FS_BRFD)
    out["channels"] = np.asarray(["displacement_in", "friction_force_kip", "velocity_in_per_s"])
    return out


def save_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Like ``numpy.savez_compressed`` but byte-reproducible (fixed zip timestamps), so a rerun changes nothing."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as archive:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="shared folder (default ../shared)")
    args = parser.parse_args(argv)
    data = args.shared / "data"
    (TARGET / "brfd").mkdir(parents=True, exist_ok=True)
    (TARGET / "boucwen").mkdir(parents=True, exist_ok=True)

    save_npz(TARGET / "brfd" / "brfd_dataset2.npz", brfd(args.shared))
    for name in ("LICENSE_CC-BY-SA-4.0.txt", "SOURCE.md"):
        shutil.copyfile(data / "brfd" / name, TARGET / "brfd" / name)
    for name in ("boucwen_benchmark.npz", "LICENSE_dynonet_MIT.txt", "LICENSE_sysid-neural-manifold_MIT.txt",
                 "SOURCE.md"):
        shutil.copyfile(data / "boucwen" / name, TARGET / "boucwen" / name)
    for path in sorted(TARGET.rglob("*")):
        if path.is_file():
            print(f"{path.relative_to(REPO)}  {path.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
