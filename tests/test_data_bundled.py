"""The bundled datasets: BRFD, the Bouc–Wen benchmark and the VPPTD generator, and load_builtin's errors."""

from __future__ import annotations

import numpy as np
import pytest
from test_data import SHARED

from hybridhyst.data import load_builtin


# -- bundled data -------------------------------------------------------------------------------------------
def test_brfd_records_and_conditions():
    brfd = load_builtin("brfd")
    cond = brfd.conditions
    assert len(brfd) == 35 and (cond["kind"] == "characterisation").sum() == 31
    assert cond.loc[cond["kind"] == "earthquake"].index.tolist() == [
        "eq36lb_ImperialValleyDBE", "eq36lb_ImperialValleyMCE", "eq36lb_KocaeliDBE", "eq36lb_KocaeliMCE"]
    assert set(cond.columns) == {"frequency_hz", "tension_lb", "amplitude_in", "kind", "earthquake",
                                 "hazard_level", "tension_suspect"}
    assert not cond.isna().any().any()
    assert cond.loc["char_0.5Hz_36lb_1in", ["frequency_hz", "tension_lb", "amplitude_in"]].tolist() == [0.5, 36, 1]
    assert cond.loc["char_2Hz_30lb_0.5in", ["frequency_hz", "tension_lb", "amplitude_in"]].tolist() == [2, 30, 0.5]
    assert cond.loc["eq36lb_KocaeliMCE", "frequency_hz"] == 0.0
    assert cond.loc["eq36lb_KocaeliMCE", "hazard_level"] == "MCE"
    assert sorted(cond.index[cond["tension_suspect"]]) == [
        "char_0.25Hz_0lb_0.5in", "char_0.25Hz_0lb_1in", "char_0.5Hz_0lb_0.5in", "char_1Hz_0lb_0.5in",
        "char_2Hz_0lb_0.5in"]
    r = brfd["char_1Hz_36lb_1in"]
    assert len(r) == 7169 and r.units == {"t": "s", "x": "in", "y": "kip", "velocity": "in/s"}
    assert r.dt == pytest.approx(1 / 1024) and abs(r.x).max() == pytest.approx(1.0, abs=0.05)
    assert len(load_builtin("brfd", kind="earthquake")) == 4


@pytest.mark.skipif(not (SHARED / "data").is_dir(), reason="shared data folder not present")
def test_brfd_and_boucwen_equal_the_shared_files():
    brfd = load_builtin("brfd")
    with np.load(SHARED / "data" / "brfd" / "brfd_dataset2.npz") as src:
        for r in brfd:
            a = src[r.name]
            np.testing.assert_array_equal(r.t, a[:, 0])
            for got, col in ((r.x, 1), (r.y, 2), (r.extra["velocity"], 3)):
                np.testing.assert_array_equal(got, a[:, col].astype(np.float32).astype(np.float64))
    bw = load_builtin("boucwen")
    with np.load(SHARED / "data" / "boucwen" / "boucwen_benchmark.npz") as src:
        for name, key in (("train", "train"), ("multisine", "test_multisine"), ("sinesweep", "test_sinesweep")):
            np.testing.assert_array_equal(bw[name].x[bw[name].warmup:], src[f"{key}_u"])
            np.testing.assert_array_equal(bw[name].y[bw[name].warmup:], src[f"{key}_y"])


def test_boucwen_shapes_and_split():
    bw = load_builtin("boucwen")
    assert {r.name: len(r) - r.warmup for r in bw} == {"train": 40960, "multisine": 8192, "sinesweep": 153000}
    ms = bw["multisine"]  # periodic steady state: extended by its own last quarter period, not scored
    assert ms.warmup == 2048 and np.array_equal(ms.y[:2048], ms.y[-2048:])
    assert bw["multisine"].dt == pytest.approx(1 / 750) and bw["train"].units == {"t": "s", "x": "N", "y": "m"}
    train, _, test = bw.split(held_out={"split": ["test"]})
    assert train.names == ["train"] and test.names == ["multisine", "sinesweep"]


def test_load_builtin_errors():
    with pytest.raises(ValueError, match=r"unknown built-in dataset 'brdf'; did you mean 'brfd'"):
        load_builtin("brdf")
    with pytest.raises(ValueError, match=r"no option 'noise'; did you mean 'noise_sd'"):
        load_builtin("vpptd", noise=0.1)


def test_vpptd_generator_layout_and_noise():
    clean = load_builtin("vpptd", mixtures=["1:3"], pressures=[0.01, 0.09], cycles=1, samples_per_cycle=60)
    assert clean.names == ["1:3_p0.01", "1:3_p0.09"] and len(clean[0]) == 61
    assert clean[1].conditions == {"mixture": "1:3", "pressure_mpa": 0.09, "frequency_hz": 0.79, "amplitude_deg": 10.0}
    assert clean[0].units == {"t": "s", "x": "deg", "y": "Nm"} and clean[0].t[-1] == pytest.approx(1 / 0.79)
    assert abs(clean[1].y).max() > abs(clean[0].y).max()
    noisy = load_builtin("vpptd", mixtures="1:3", pressures=[0.01, 0.09], cycles=1, samples_per_cycle=60,
                         noise_sd=0.5, seed=3)
    one = load_builtin("vpptd", mixtures="1:3", pressures=[0.09], cycles=1, samples_per_cycle=60, noise_sd=0.5, seed=3)
    np.testing.assert_array_equal(one[0].y, noisy[1].y)  # a record's noise does not depend on the others
    assert np.std(noisy[1].y - clean[1].y) == pytest.approx(0.5, rel=0.3)
    with pytest.raises(ValueError, match="unknown mixture"):
        load_builtin("vpptd", mixtures=["2:1"])
    with pytest.raises(ValueError, match="simulation diverged"):
        load_builtin("vpptd", mixtures="NBR", pressures=[0.01], cycles=1, samples_per_cycle=60, substeps=1)


def test_vpptd_peak_torque_of_seed_001():
    """Seed 001 (the paper): 1:3 loops at ±10°, 0.79 Hz peak at about 19 Nm (0.01 MPa) and 38 Nm (0.09 MPa)."""
    loops = load_builtin("vpptd", mixtures=["1:3"], pressures=[0.01, 0.09], cycles=2, samples_per_cycle=300)
    peaks = [abs(r.y[300:]).max() for r in loops]
    assert peaks[0] == pytest.approx(19.0, rel=0.2) and peaks[1] == pytest.approx(38.0, rel=0.2)
