"""How the first bed's cases make their data and nominals: records from a law, sine tests, noise; the nominal
dampers and oscillators built from effect specs; the standard test matrices and their splits (``STD``, ``SLOW``,
``SMALL``, ``OSC``, ``FREQS``); ``maxwell_records`` (also used by ``scripts/testbed_maxwell_variance.py``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import generators as g
from ..laws import maxwell_law, on_fine
from .case import DAMPER_UNITS, OSC_UNITS


def _noise(n: int, sd: float, phi: float | None, rng) -> np.ndarray:
    return g.white_noise(n, sd, rng) if phi is None else g.ar1_noise(n, sd, phi, rng)


def _records(name: str, tests: Sequence[tuple[str, g.Sines, dict, np.ndarray]], law, noise: float,
             phi: float | None, seed: int, units: dict):
    """RecordSet of ``tests`` = (record name, signal, conditions, sample times); y = law(t, signal) + noise."""
    from ...data.records import Record, RecordSet

    rng = np.random.default_rng(seed)
    out = []
    for rname, sig, cond, t in tests:
        y = law(t, sig)
        out.append(Record(name=rname, t=t, x=sig.x(t), y=y + _noise(len(t), noise, phi, rng), conditions=cond,
                          units=units))
    return RecordSet(out, name)


def _sine_tests(tests: Sequence[tuple[float, float]], spc: int, cycles: float, amplitude_key: str = "amplitude_in",
                phase: float = -math.pi / 2, prefix: str = "sine"):
    """(amplitude, frequency) sine tests sampled at ``spc`` samples per cycle for ``cycles`` cycles. The default
    phase starts each test from rest at −A (x = −A cos 2πft), as a displacement-controlled rig does; a whole
    number of cycles also ends it at rest."""
    out = []
    for a, f in tests:
        t = np.arange(int(round(cycles * spc)) + 1) / (f * spc)
        out.append((f"{prefix}_{a:g}_{f:g}Hz", g.sine(a, f, phase=phase), {amplitude_key: a, "frequency_hz": f}, t))
    return out


def _damper(effects: dict, name: str = "nominal", units: dict = DAMPER_UNITS):
    from ...physics.build import build_model

    return build_model("constitutive", effects, units=units, name=name).double()


def _oscillator(effects: dict, mass: float, name: str = "oscillator"):
    from ...physics.build import build_model

    return build_model("oscillator", effects, units=OSC_UNITS, name=name, mass=mass, fixed=["drive_gain"]).double()


def _spring(k):
    return {"effect": "linear_stiffness", "k": k}


def _visc(c):
    return {"effect": "viscous", "c": c}


def _coul(Fc, v_s=0.05):
    return {"effect": "coulomb", "Fc": Fc, "v_s": v_s, "fixed": ["v_s"]}


# standard damper test matrix [in, Hz]: 1.5 in held out (extrapolation in amplitude), 0.75 in validates
STD = [(0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (0.75, 1.5), (1.5, 1.0), (1.5, 2.0)]
STD_SPLIT = {"held_out": {"amplitude_in": [1.5]}, "val": {"amplitude_in": [0.75]}}
# low-speed matrix for velocity-weakening friction (Stribeck)
SLOW = [(0.5, 0.5), (1.0, 0.5), (0.5, 1.0), (1.0, 1.0), (0.75, 0.75), (1.5, 0.5), (1.5, 1.0)]
# smaller strokes for the presliding (Dahl, LuGre, Bouc–Wen) cases
SMALL = [(0.4, 1.0), (0.8, 1.0), (0.8, 2.0), (0.6, 1.5), (1.2, 1.0), (1.2, 2.0)]
SMALL_SPLIT = {"held_out": {"amplitude_in": [1.2]}, "val": {"amplitude_in": [0.6]}}
# oscillator drive matrix [kip, Hz]; natural frequency 3.2 Hz
OSC = [(0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (0.75, 1.5), (1.5, 1.0), (1.5, 2.0)]
OSC_SPLIT = {"held_out": {"amplitude_kip": [1.5]}, "val": {"amplitude_kip": [0.75]}}
# rate-dependence matrix (Maxwell, delay): four frequencies
FREQS = [(0.5, 0.5), (1.0, 0.5), (0.5, 2.0), (1.0, 1.0), (0.75, 4.0), (1.5, 1.0), (1.5, 3.0)]
FREQ_SPLIT = {"held_out": {"amplitude_in": [1.5]}, "val": {"amplitude_in": [0.75]}}


def _sine_records(name, tests, law, *, spc, cycles, noise, phi=None, seed=0, refine=None):
    law = on_fine(law, refine) if refine else law
    return _records(name, _sine_tests(tests, spc, cycles), law, noise, phi, seed, {"x": "in", "y": "kip"})


def _osc_records(name, tests, law, *, spc, cycles, noise, phi=None, seed=0):
    """Oscillators are driven by a force u = A sin 2πft from rest (x = ẋ = 0)."""
    return _records(name, _sine_tests(tests, spc, cycles, amplitude_key="amplitude_kip", phase=0.0, prefix="drive"),
                    law, noise, phi, seed, {"x": "kip", "y": "in"})


def maxwell_records(noise: float = 0.03, phi: float | None = 0.5, seed: int = 52):
    """The ``maxwell`` case's records (1.5x + 0.1v + a Maxwell element k_m 2, c_m 0.2, at FREQS); other noise
    levels and seeds for ``scripts/testbed_maxwell_variance.py``."""
    return _sine_records("maxwell", FREQS, maxwell_law(1.5, 0.1, km=2.0, cm=0.2), spc=100, cycles=2, noise=noise,
                         phi=phi, seed=seed, refine=10)


def _vpptd_nominal():
    from ...physics.compositions import vpptd_algebraic

    return vpptd_algebraic(c=7.5, k=1.0, k2=0.005, Ms=12.0).double()
