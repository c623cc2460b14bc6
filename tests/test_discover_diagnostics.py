"""Discovery's residual diagnostics and acceptance rule: structure, whiteness, criterion, noise level."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_discover import FAST, NOISE

from hybridhyst.data import Record, RecordSet
from hybridhyst.discover import Scales, diagnose, discover, features, information_criterion, structure_explained
from hybridhyst.simulate import SimulationSettings
from hybridhyst.synth.effects import SPLIT, base_model, make_records


def test_diagnostics_measure_structure_and_whiteness():
    rng = np.random.default_rng(0)
    f = rng.uniform(-1, 1, 4000)
    assert structure_explained(f, f**2 + 0.01 * rng.standard_normal(4000)) > 0.95
    assert structure_explained(f, rng.standard_normal(4000)) < 0.02
    records = make_records(None, noise_sd=NOISE)
    preds = [r.y - NOISE * rng.standard_normal(len(r)) for r in records]  # white residual
    d = diagnose(records.records, preds, NOISE)
    assert d["whiteness"]["white"] and max(d["dependence"].values()) < 0.05
    assert Scales(F=2.0, x=0.5, v=4.0, u=0.5).of_unit("F*t/x") == pytest.approx(2.0 * (0.5 / 4.0) / 0.5)


def test_the_diagnostics_read_the_scored_samples_only():
    """A record's warm-up (simulated from rest, not scored) holds the settling transient: a structured residual there
    moves nothing the diagnostics report."""
    import dataclasses

    rng = np.random.default_rng(1)
    records = make_records(None, noise_sd=NOISE).records
    preds = [r.y - NOISE * rng.standard_normal(len(r)) for r in records]
    warm = [dataclasses.replace(r, warmup=len(r) // 4) for r in records]
    settling = [p + np.where(np.arange(len(p)) < len(p) // 4, 50 * NOISE * r.x, 0.0) for p, r in zip(preds, records)]
    d = diagnose(warm, settling, NOISE)
    scored = np.concatenate([(r.y - p)[len(r) // 4:] for r, p in zip(records, preds)])
    assert d["rmse"] == pytest.approx(float(np.sqrt(np.mean(scored**2))))
    assert d["whiteness"]["white"] and max(d["dependence"].values()) < 0.05


def test_the_loop_counts_the_samples_its_fits_score(float64):
    """With warm-ups, the training error the loop derives from a fit's sum of squares (steps, the rule's criterion
    and its noise cap) is the reported one over the scored samples."""
    import dataclasses

    from hybridhyst.discover.loop import Loop
    from hybridhyst.discover.settings import DiscoverSettings

    records = [dataclasses.replace(r, warmup=len(r) // 4) for r in make_records("coulomb", noise_sd=NOISE)]
    settings = DiscoverSettings().replace(split=SPLIT, conditions=False, noise_sd=NOISE, **FAST)
    loop = Loop(records, base_model("coulomb"), settings)
    loop.nominal()
    assert math.sqrt(loop.fit.sse / loop.n_train) == pytest.approx(loop.before["train"]["rmse"], rel=1e-9)
    assert loop.n_train == loop.before["train"]["n"]


def test_a_structure_whose_sign_changes_with_the_condition_is_still_seen():
    """A missing trend: the residual is (level − mean level) × a function of the loop phase, so pooled over the
    levels its mean in every phase bin is 0 while within each level it is a function of the phase; η² is
    measured within the levels (the pooled one saw nothing)."""
    rng = np.random.default_rng(2)
    records = make_records(None, noise_sd=NOISE).records
    amps = sorted({r.conditions["amplitude_in"] for r in records})
    weight = {a: i - (len(amps) - 1) / 2 for i, a in enumerate(amps)}
    preds = [r.y - weight[r.conditions["amplitude_in"]] * 10 * NOISE * np.sin(features(r.t, r.x)["phase"])
             - NOISE * rng.standard_normal(len(r)) for r in records]
    d = diagnose(records, preds, NOISE)
    assert d["dependence"]["phase"] > 0.5


def test_a_residual_that_follows_a_control_channel_is_seen_by_the_diagnostics_and_the_leftover_network():
    """An MR damper's yield level saturating with the coil current, where the model is linear in it: the residual
    is a function of (current, sign ẋ), invisible in the motion's features; the diagnostics and the leftover
    network read the records' control channels too."""
    import dataclasses

    from hybridhyst.discover.leftover import residual_network

    rng = np.random.default_rng(3)
    records, preds = [], []
    for i, r in enumerate(make_records(None, noise_sd=NOISE).records):
        current = 0.75 + 0.75 * np.sin(2 * np.pi * 0.37 * r.t + i)  # a slow current, another in every record
        miss = 0.5 * (np.tanh(current / 0.4) - current / 1.5) * np.sign(features(r.t, r.x)["v"])
        records.append(dataclasses.replace(r, controls={"current": current}, units={**r.units, "current": "A"}))
        preds.append(r.y - miss - NOISE * rng.standard_normal(len(r)))
    d = diagnose(records, preds, NOISE)
    assert d["dependence"]["control:current"] > 0.2
    half = len(records) // 2
    net = residual_network(records[:half], preds[:half], records[half:], preds[half:], steps=300)
    blind = residual_network([dataclasses.replace(r, controls={}) for r in records[:half]], preds[:half],
                             [dataclasses.replace(r, controls={}) for r in records[half:]], preds[half:], steps=300)
    assert net["explained_share"] > blind["explained_share"] + 0.2
    assert net["inputs"][-1] == "current" and "current" not in blind["inputs"]  # report.md names what it read


def test_a_residual_whose_size_grows_with_a_condition_is_named():
    """Zero-mean noise three times larger at the largest amplitude: its mean depends on nothing (η² ≈ 0), its
    size does, and the report's sentence names the condition with the RMS at both ends."""
    from hybridhyst.discover.report import _scale_sentence

    rng = np.random.default_rng(1)
    records = make_records(None, noise_sd=NOISE).records
    amps = sorted({r.conditions["amplitude_in"] for r in records})
    gain = {a: 1.0 + 2.0 * (a - amps[0]) / (amps[-1] - amps[0]) for a in amps}
    preds = [r.y - gain[r.conditions["amplitude_in"]] * NOISE * rng.standard_normal(len(r)) for r in records]
    d = diagnose(records, preds, NOISE)
    assert d["dependence"]["condition:amplitude_in"] < 0.02
    rms = d["scale"]["amplitude_in"]
    assert rms[f"{amps[-1]:g}"] / rms[f"{amps[0]:g}"] == pytest.approx(3.0, rel=0.15)
    sentence = _scale_sentence(d["scale"], "kip")
    assert "changes with amplitude_in" in sentence and f"at amplitude_in = {amps[0]:g}" in sentence
    flat = diagnose(records, [r.y - NOISE * rng.standard_normal(len(r)) for r in records], NOISE)
    assert _scale_sentence(flat["scale"], "kip") == ""


def test_information_criterion_is_the_gaussian_formula():
    """n = 50, SSE = 2.5, k = 3 by hand: 50 ln(0.05) = -149.78661367769954, 3 ln 50 = 11.736069016284438."""
    assert information_criterion(2.5, 50, 3) == pytest.approx(-138.0505446614151, rel=1e-12)
    assert information_criterion(2.5, 50, 3, "aic") == pytest.approx(-149.78661367769954 + 6, rel=1e-12)
    # one more coordinate pays only if the SSE falls by more than the factor n^(-1/n) (0.955 at n = 100; AIC:
    # e^(-2/n) = 0.980): 5 % less SSE is worth it under BIC, 4 % is not, though both are under AIC
    assert information_criterion(0.95, 100, 4) < information_criterion(1.0, 100, 3)
    assert information_criterion(0.96, 100, 4) > information_criterion(1.0, 100, 3)
    assert information_criterion(0.97, 100, 4, "aic") < information_criterion(1.0, 100, 3, "aic")
    assert information_criterion(0.99, 100, 4, "aic") > information_criterion(1.0, 100, 3, "aic")
    assert all(information_criterion(*bad, 3) == math.inf for bad in ((0.0, 50), (-1.0, 50), (math.nan, 50),
                                                                      (2.5, 0)))


def test_structure_is_flagged_above_the_known_noise_or_by_the_residual_network():
    from hybridhyst.discover.leftover import structure_flagged

    assert structure_flagged({"explained_share": 0.0}, train_rmse=0.3, noise_sd=0.2)
    assert not structure_flagged({"explained_share": 0.9}, train_rmse=0.21, noise_sd=0.2)
    assert structure_flagged({"explained_share": 0.3}, train_rmse=0.3, noise_sd=None)
    assert not structure_flagged({"explained_share": 0.05}, train_rmse=0.3, noise_sd=None)
    # a network in the dynamics scored on the records it was fitted to (no validation records) does not flag
    assert not structure_flagged({"network": "dynamics", "explained_share": 0.5, "on": "train"}, 0.3, None)
    assert structure_flagged({"network": "dynamics", "explained_share": 0.5, "on": "val"}, 0.3, None)


def test_an_estimated_noise_level_is_capped_by_what_the_model_already_leaves(float64):
    """Without ``noise_sd`` the rule's σ is estimated from the data (``analysis.noise``); sampled at 12 points per
    cycle a sine's own shape shows in its differences (the estimate several times the noise). The missing friction
    is still named, and once a model leaves less than the estimate its training RMSE is the level the rule uses;
    a level the user gave is kept."""
    from hybridhyst.discover.fitting import Fit
    from hybridhyst.discover.loop import DiscoverSettings, Loop

    rng = np.random.default_rng(0)
    out = []
    for amp, f in [(0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (0.75, 1.5), (1.5, 1.0), (1.5, 2.0)]:
        t = np.arange(49) / (12 * f)
        x, v = amp * np.sin(2 * np.pi * f * t), 2 * np.pi * f * amp * np.cos(2 * np.pi * f * t)
        y = 2.0 * x + 0.5 * v + 0.6 * np.tanh(v / 0.05) + NOISE * rng.standard_normal(len(t))
        out.append(Record(name=f"s{amp:g}_{f:g}", t=t, x=x, y=y, conditions={"amplitude_in": amp, "frequency_hz": f}))
    records = RecordSet(out)
    res = discover(records, base_model("coulomb"), candidates=["coulomb"], split=SPLIT, conditions=False,
                   simulation=SimulationSettings(backend="reference"), **FAST)
    noise = res.report["noise"]
    assert noise["source"].startswith("estimated") and noise["sd"] > 2 * NOISE
    assert [s["effect"] for s in res.report["steps"]] == ["coulomb"]
    loop = Loop(records, base_model("coulomb"), DiscoverSettings(split=SPLIT, conditions=False))
    n = loop.n_train
    loop.fit = Fit(loop.model, sse=n * (0.5 * noise["sd"]) ** 2, k=3)
    assert loop.rule.noise == pytest.approx(0.5 * noise["sd"])  # capped by the model's training RMSE
    loop.fit = Fit(loop.model, sse=n * (2 * noise["sd"]) ** 2, k=3)
    assert loop.rule.noise == pytest.approx(noise["sd"])
    given = Loop(records, base_model("coulomb"), DiscoverSettings(split=SPLIT, conditions=False, noise_sd=1.0))
    given.fit = loop.fit
    assert given.rule.noise == 1.0
