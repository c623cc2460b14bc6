"""Write ``damper_loops.csv``: torque–angle loops of a vacuum-packed-particle damper at nine underpressures.

The example data set of docs/own-data.md, made with numpy only (no hybridhyst) so that it
stands in for data measured elsewhere. The law is seed 000's four-parameter model

    M = c·φ̇ + k·φ + k2·φ³ + Ms·sign(φ̇)      (φ in deg, φ̇ in rad/s, M in Nm)

with every parameter rising linearly with the underpressure p, from (c, k, k2, Ms) = (6.7 Nm·s/rad,
0.65 Nm/deg, 0.0055 Nm/deg³, 9.5 Nm) at 0.01 MPa to twice those values at 0.09 MPa. Each record is two
cycles of a ±10° sine at 0.8 Hz sampled at 200 Hz (501 samples) with Gaussian torque noise of sd 0.2 Nm.

Columns: record, t [s], angle_deg, torque_nm, pressure_mpa (one row per sample, records one after another).

    python examples/own_data/make_example.py            # rewrites examples/own_data/damper_loops.csv
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

PRESSURES = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09]   # underpressure [MPa]
AT_001 = {"c": 6.7, "k": 0.65, "k2": 0.0055, "Ms": 9.5}              # values at 0.01 MPa
AMPLITUDE_DEG, FREQUENCY_HZ, FS_HZ, CYCLES, NOISE_NM, SEED = 10.0, 0.8, 200.0, 2, 0.2, 0
OUT = Path(__file__).with_name("damper_loops.csv")


def parameters(p: float) -> dict[str, float]:
    """(c, k, k2, Ms) at underpressure ``p`` [MPa]: linear in p, doubling from 0.01 to 0.09 MPa."""
    scale = 1.0 + (p - 0.01) / (0.09 - 0.01)
    return {name: value * scale for name, value in AT_001.items()}


def loop(p: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time [s], angle [deg] and noisy torque [Nm] of one record at underpressure ``p``."""
    n = int(round(CYCLES * FS_HZ / FREQUENCY_HZ)) + 1
    t = np.arange(n) / FS_HZ
    w = 2.0 * np.pi * FREQUENCY_HZ
    phi = AMPLITUDE_DEG * np.sin(w * t)                           # deg
    phi_dot = np.deg2rad(AMPLITUDE_DEG * w * np.cos(w * t))       # rad/s
    q = parameters(p)
    torque = q["c"] * phi_dot + q["k"] * phi + q["k2"] * phi**3 + q["Ms"] * np.sign(phi_dot)
    return t, phi, torque + rng.normal(0.0, NOISE_NM, size=n)


def main(path: Path = OUT) -> Path:
    rng = np.random.default_rng(SEED)
    with open(path, "w", newline="") as f:
        out = csv.writer(f, lineterminator="\n")
        out.writerow(["record", "t", "angle_deg", "torque_nm", "pressure_mpa"])
        for p in PRESSURES:
            t, phi, torque = loop(p, rng)
            name = f"p{p:.2f}"
            out.writerows([name, f"{a:.3f}", f"{b:.5f}", f"{c:.4f}", f"{p:.2f}"] for a, b, c in zip(t, phi, torque))
    return path


if __name__ == "__main__":
    print(main())
