"""Synthetic vacuum-packed-particle torsional damper (VPPTD) loops from seed 001 Table 1.

Generated on the fly by simulating the ``modified_bouc_wen`` composition (seed 001's modified
Bouc–Wen damper law with Table 1's parameter functions of the underpressure p) as a ``Constitutive``
model under the experiments' excitation: a ±10°, 0.79 Hz sine (seed 001, Figs. 3a-3e).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import torch

from ..data.records import Record, RecordSet
from ..physics.compositions.seed001 import MIXTURES, modified_bouc_wen
from ..simulate import simulate

__all__ = ["MIXTURES", "PRESSURES", "load_vpptd"]

PRESSURES = tuple(round(0.01 * i, 2) for i in range(1, 10))
# largest RK4 step [s]: explicit RK4 on this law diverges above about 7 ms (NBR at 0.01 MPa first);
# at 2.5 ms the torque is within about 4e-3 Nm of a converged solution
MAX_STEP = 2.5e-3


def _check_options(mixtures, pressures, cycles, samples_per_cycle, noise_sd, frequency_hz,
                   amplitude_deg) -> tuple[list[str], list[float]]:
    mixtures = list(MIXTURES if mixtures is None else ([mixtures] if isinstance(mixtures, str) else mixtures))
    bad = [m for m in mixtures if m not in MIXTURES]
    if bad:
        raise ValueError(f"vpptd: unknown mixture(s) {bad}; choose from {list(MIXTURES)} (ABS:NBR volume ratios)")
    if len(set(mixtures)) != len(mixtures):
        raise ValueError(f"vpptd: mixtures {mixtures} contain duplicates")
    if pressures is None:
        pressures = PRESSURES
    pressures = [float(p) for p in ([pressures] if np.isscalar(pressures) else list(pressures))]
    if any(not (0.0 <= p <= 0.1) for p in pressures) or len(set(pressures)) != len(pressures):
        raise ValueError(
            f"vpptd: pressures {pressures} must be distinct underpressures in [0, 0.1] MPa "
            "(Table 1 is fitted on 0.01-0.09)"
        )
    if int(cycles) < 1 or int(samples_per_cycle) < 8:
        raise ValueError(f"vpptd: need cycles >= 1 and samples_per_cycle >= 8, got {cycles} and {samples_per_cycle}")
    if not (math.isfinite(frequency_hz) and frequency_hz > 0 and math.isfinite(amplitude_deg)):
        raise ValueError(f"vpptd: need frequency_hz > 0 and a finite amplitude_deg, got {frequency_hz}, "
                         f"{amplitude_deg}")
    if not (math.isfinite(noise_sd) and noise_sd >= 0):
        raise ValueError(f"vpptd: noise_sd must be a non-negative torque [Nm], got {noise_sd!r}")
    return mixtures, pressures


@functools.lru_cache(maxsize=16)
def _simulate(mixture: str, pressures: tuple[float, ...], n: int, samples_per_cycle: int, frequency_hz: float,
              amplitude_deg: float, substeps: int) -> np.ndarray:
    """Torque [Nm], ``(len(pressures), n)``, of one mixture at every pressure in one batched run (cached)."""
    t = np.arange(n) / (frequency_hz * samples_per_cycle)
    w = 2 * math.pi * frequency_hz
    x = amplitude_deg * np.sin(w * t)
    inputs = np.stack([x, amplitude_deg * w * np.cos(w * t), -(w**2) * x], axis=-1)  # deg, deg/s, deg/s^2
    inputs = np.repeat(inputs[None], len(pressures), axis=0)
    model = modified_bouc_wen(mixture).double()
    with torch.no_grad():
        y = simulate(model, torch.as_tensor(inputs), t=torch.as_tensor(t),
                     conditions={"pressure_mpa": np.asarray(pressures)}, method="rk4", substeps=substeps,
                     backend="fast")
    torque = y[..., 0].numpy()
    if not np.isfinite(torque).all():
        step_ms = 1e3 / (frequency_hz * samples_per_cycle * substeps)
        raise ValueError(
            f"vpptd: the {mixture!r} simulation diverged (RK4 step {step_ms:.2g} ms); use more samples_per_cycle "
            "or substeps"
        )
    torque.flags.writeable = False
    return torque


def load_vpptd(mixtures=None, pressures=None, cycles: int = 3, samples_per_cycle: int = 570,
               noise_sd: float = 0.0, seed: int = 0, frequency_hz: float = 0.79, amplitude_deg: float = 10.0,
               substeps: int | None = None) -> RecordSet:
    """Simulated torque–angle loops of the five ABS/NBR mixtures at several underpressures.

    Parameters
    ----------
    mixtures : subset of ``("ABS", "3:1", "1:1", "1:3", "NBR")`` (ABS:NBR volume ratio); default all.
    pressures : underpressures p [MPa]; default 0.01, 0.02, ..., 0.09 (Table 1's range).
    cycles, samples_per_cycle : length and resolution; the record has ``cycles * samples_per_cycle + 1``
        samples so it spans exactly ``cycles`` periods (3 × 570 ≈ seed 000's ~1700 points per loop).
    noise_sd : standard deviation [Nm] of Gaussian noise added to the torque.
    seed : noise seed; each record's noise depends only on (seed, mixture, p), so a subset reproduces
        the same records as the full set.
    frequency_hz, amplitude_deg : the sine excitation x(t) = A sin(2π f t), starting at rest (z = 0).
    substeps : RK4 sub-steps per sample; default: the fewest that keep the step <= 2.5 ms (1 at the default
        resolution). Results are cached per (mixture, pressures, grid) within a process.

    Returns
    -------
    RecordSet "vpptd", one record per (mixture, p) named ``"<mixture>_p<p>"`` (e.g. ``"1:3_p0.05"``);
    x = angle [deg], y = torque [Nm], t [s]; conditions ``mixture`` (str), ``pressure_mpa``,
    ``frequency_hz``, ``amplitude_deg``.
    """
    mixtures, pressures = _check_options(mixtures, pressures, cycles, samples_per_cycle, noise_sd, frequency_hz,
                                         amplitude_deg)
    n = int(cycles) * int(samples_per_cycle) + 1
    t = np.arange(n) / (frequency_hz * int(samples_per_cycle))
    if substeps is None:
        substeps = math.ceil(t[1] / MAX_STEP - 1e-9)
    x = amplitude_deg * np.sin(2 * math.pi * frequency_hz * t)
    records = []
    for mixture in mixtures:
        torque = _simulate(mixture, tuple(pressures), n, int(samples_per_cycle), float(frequency_hz),
                           float(amplitude_deg), int(substeps))
        for p, y in zip(pressures, torque, strict=True):
            conditions = {"mixture": mixture, "pressure_mpa": p, "frequency_hz": float(frequency_hz),
                          "amplitude_deg": float(amplitude_deg)}
            record = Record(name=f"{mixture}_p{p:g}", t=t.copy(), x=x.copy(), y=y.copy(), conditions=conditions,
                            units={"t": "s", "x": "deg", "y": "Nm"},
                            source=f"synthetic: modified_bouc_wen({mixture!r}), seed 001 Table 1")
            records.append(record.with_noise(noise_sd, [int(seed), MIXTURES.index(mixture), round(p * 1e4)]))
    return RecordSet(records, name="vpptd")
