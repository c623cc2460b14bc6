"""The data-mistake rules never fire on legitimate data: bundled sets, spikes and decays, rates and amplitudes."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
import test_trust_data as trust

from hybridhyst.data import Record, load_builtin, read_table
from hybridhyst.data.scales import check_scales


# -- data mistakes: the rules never fire on legitimate data -------------------------------------------------
@pytest.mark.parametrize("name", ["brfd", "vpptd", "boucwen"])
def test_bundled_data_load_without_error_or_warning(name):
    options = {"pressures": [0.01, 0.05, 0.09], "cycles": 1, "samples_per_cycle": 60} if name == "vpptd" else {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        records = load_builtin(name, **options)
        check_scales(records, "column 't'", "column 'x'")
        stripped = [Record(r.name, r.t, r.x, r.y) for r in records]  # without the conditions that explain
        check_scales(stripped, "column 't'", "column 'x'")
    assert len(records) >= 3


def test_large_spikes_impulses_and_decays_are_not_absurd(tmp_path):
    t = np.arange(2000) / 1000.0
    spike = np.sin(2 * np.pi * t)
    spike[[500, 501, 1500]] = [5e3, -2e3, 1e4]  # a few samples 10^4 times the signal (a dropout or a shock)
    impulse = np.zeros_like(t)
    impulse[100] = 1.0
    decay = np.exp(-t / 0.01) * np.cos(2 * np.pi * 50 * t)  # free decay to ~1e-87 of its start
    quantised = np.round(np.sin(2 * np.pi * t) * 2**-23, 30) + np.where(t < 0.001, 1.0, 0.0)  # 24-bit range
    roundoff = 1e-16 * np.sin(2 * np.pi * 7 * t)  # an impulse among round-off: 99 % of the channel near 1e-16
    roundoff[[300, 301]] = [1.0, -0.5]
    free = np.zeros_like(t)  # a free vibration: no input at all, the response decays from where it was let go
    for x, y in ((spike, spike), (impulse, decay), (t + 1.0, quantised), (roundoff, decay), (free, decay)):
        frame = pd.DataFrame({"t": t, "x": x, "y": y})
        frame.to_csv(tmp_path / "r.csv", index=False)
        record = read_table(tmp_path / "r.csv")[0]
        np.testing.assert_allclose(record.y, y, rtol=1e-12, atol=0)


def test_sample_rates_and_amplitudes_that_conditions_explain_load(tmp_path):
    """A sweep sampled at 64 samples per cycle (0.1 to 100 Hz: sample intervals 1000× apart) and amplitudes
    57× apart load when the records carry their frequency and amplitude; BRFD-like amplitudes (0.5/1/1.5)
    load without any condition."""
    parts = []
    for f, amp in ((0.1, 10.0), (1.0, 10.0), (10.0, 10.0), (100.0, 10.0), (100.0, 0.1745)):
        t = np.arange(128) / (64 * f)
        parts.append(pd.DataFrame({"record": f"f{f}_a{amp}", "t": t, "x": amp * np.sin(2 * np.pi * f * t),
                                   "y": np.cos(2 * np.pi * f * t), "frequency_hz": f, "amplitude_deg": amp}))
    pd.concat(parts).to_csv(tmp_path / "sweep.csv", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(read_table(tmp_path / "sweep.csv", record="record",
                              conditions=["frequency_hz", "amplitude_deg"])) == 5
        frame = trust.loops()
        for p, amp in zip(trust.PRESSURES, (0.5, 1.0, 1.5, 1.0, 0.5), strict=True):
            frame.loc[frame.pressure_mpa == p, "angle_deg"] *= amp / 10
        frame.to_csv(tmp_path / "amps.csv", index=False)
        assert len(read_table(tmp_path / "amps.csv", **trust.COLUMNS)) == 5


def test_a_unit_factor_among_varied_records_is_a_warning(tmp_path):
    """Others that vary (amplitudes 6 to 15 deg) and one record about 57× below all of them: a warning that
    names the record and column, not an error (a much smaller test may be real)."""
    frame = trust.loops()
    for p, amp in zip(trust.PRESSURES, (6.0, 10.0, 15.0, 8.0, 10.0 / 57.3), strict=True):
        frame.loc[frame.pressure_mpa == p, "angle_deg"] *= amp / 10
    frame.to_csv(tmp_path / "loops.csv", index=False)
    with pytest.warns(UserWarning, match=r"record 'p0.09'.*input column 'angle_deg' in rad, not deg\?"):
        records = read_table(tmp_path / "loops.csv", **trust.COLUMNS)
    assert len(records) == 5
