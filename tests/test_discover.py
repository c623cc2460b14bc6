"""The discovery loop: names an undeclared effect, recovers it, adds nothing to a correct model, finds the trends
of parameters with a condition, refits, reports a diverging record and fails clearly on bad input. Candidates:
``tests/test_discover_candidates.py``; residual diagnostics and the acceptance rule:
``tests/test_discover_diagnostics.py``. Discovery on data the library did not make: ``tests/test_testbed.py`` and
``scripts/discovery_testbed.py``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import torch

from hybridhyst.data import Record, RecordSet
from hybridhyst.discover import discover
from hybridhyst.discover.report import write_discovery
from hybridhyst.simulate import simulate
from hybridhyst.synth.effects import CASES, SPLIT, base_model, make_records, true_model

NOISE = 0.02
FEW = ["coulomb", "cubic_stiffness", "backlash", "time_delay"]
FAST = {"max_steps": 2, "identify_options": {"pop": 16, "generations": 10, "seed": 0}, "progress": False}


@pytest.mark.parametrize("effect", ["coulomb", "cubic_stiffness"])
def test_undeclared_effect_is_named_first_recovered_and_brings_held_out_error_to_the_noise(effect, float64,
                                                                                         tmp_path):
    res = discover(make_records(effect, noise_sd=NOISE), base_model(effect), candidates=FEW, split=SPLIT,
                   conditions=False, noise_sd=NOISE, **FAST)
    rep = res.report
    assert [s["effect"] for s in rep["steps"]][:1] == [effect]
    values, key = CASES[effect]
    fitted = rep["steps"][0]["new_coordinates"][f"{effect}.{key}"]
    assert fitted == pytest.approx(values[key], rel=0.05)
    assert rep["after"]["test_rmse"] <= 1.2 * NOISE < rep["before"]["test_rmse"]
    # the other out-of-sample error, measured for the accepted step: a true effect carries over, no disagreement
    cross = rep["steps"][0]["cross_check"]
    assert cross["kind"] == "loco" and cross["after"] < cross["before"] and not cross["disagrees"]
    assert rep["noise"] == {"sd": NOISE, "source": "given", "floor_share": 0.5, "sd_at_the_end": NOISE}
    n_train = sum(len(r) for r in res.splits["train"])  # the BIC reported is the formula with k coordinates
    assert _coordinates_in_bic(rep["steps"][0], n_train) == pytest.approx(2 + len(rep["steps"][0]["new_coordinates"]))
    report = write_discovery(res, tmp_path, title="t", unit="kip")
    saved = json.loads((tmp_path / "discovery.json").read_text())
    assert set(saved) >= {"before", "after", "steps", "unexplained"} and saved["steps"][0]["effect"] == effect
    assert {"test_rmse", "per_condition"} <= set(saved["before"]) and "residual_network" in saved["unexplained"]
    assert (tmp_path / "residuals.png").exists() and (tmp_path / "loops.png").exists()
    assert f"**{effect}** (effect)" in report.read_text()
    compared = saved["steps"][0]["evidence"]["compared"]  # why this one: the refitted candidates' scores
    assert set(compared) == set(saved["steps"][0]["evidence"]["refitted"]) and len(compared) >= 2
    assert compared[effect]["val_rmse"] == pytest.approx(saved["steps"][0]["evidence"]["val_rmse_after"])
    other = next(n for n in compared if n != effect)
    assert compared[other]["val_rmse"] >= compared[effect]["val_rmse"] or \
        compared[other]["criterion"] > compared[effect]["criterion"]
    assert f"{other} {compared[other]['val_rmse']:.4g}" in report.read_text()


def test_nothing_is_added_to_a_model_that_already_explains_the_data(float64, tmp_path):
    res = discover(make_records(None, noise_sd=NOISE), base_model(None), candidates=FEW, split=SPLIT,
                   conditions=True, noise_sd=NOISE, leftover="dynamics", **FAST)
    assert res.report["steps"] == [] and res.report["rejected"]  # the best candidate was tried and refused
    assert res.report["after"]["test_rmse"] <= 1.2 * NOISE
    left = res.report["unexplained"]  # a network inside the dynamics finds nothing left either
    assert left["residual_network"]["network"] == "dynamics" and left["residual_network"]["on"] == "val"
    assert left["residual_network"]["explained_share"] < 0.1 and not left["structure_flagged"]
    assert res.report["settings"]["leftover"] == "dynamics"
    report = write_discovery(res, tmp_path, title="t", unit="kip").read_text()
    assert "A network inside the model's equations" in report and "not used for the flag" not in report


def test_a_parameter_that_follows_a_condition_is_found(float64):
    """Data whose friction level grows with amplitude: the loop makes Fc a linear function of it."""
    records = make_records("coulomb", noise_sd=NOISE)
    model = true_model("coulomb")
    out = []
    for r in records:
        with torch.no_grad():
            model.effects["coulomb"].params["Fc"].value.fill_(0.3 + 0.4 * r.conditions["amplitude_in"])
        y = simulate(model, np.asarray(r.x)[None], t=np.asarray(r.t), substeps=8)[0, :, 0].detach().numpy()
        out.append(type(r)(name=r.name, t=r.t, x=r.x, y=y + NOISE * np.random.default_rng(1).standard_normal(len(y)),
                           conditions=r.conditions, units=r.units))
    start = true_model("coulomb")  # the right law, but one friction level for all tests
    res = discover(RecordSet(out), start, candidates=[], split=SPLIT, conditions=["amplitude_in"], noise_sd=NOISE,
                   **FAST)
    steps = res.report["steps"]
    assert steps and steps[0]["effect"] == "coulomb.Fc~amplitude_in"
    assert steps[0]["new_coordinates"]["coulomb.Fc.c1"] == pytest.approx(0.4, rel=0.15)


def test_a_condition_with_three_training_levels_still_gets_its_trend(float64):
    """Three levels are too few for a trend chosen over the levels (AICc cannot prefer a line to a constant
    there): the condition must still be offered one parameter at a time, and the trend found. The data come
    from numpy alone (arctan sign, exact sines), not from the library's simulator."""
    rng = np.random.default_rng(3)
    out = []
    for amp in (0.5, 0.75, 1.0, 1.25, 1.5):  # 1.25 validates, 1.5 is held out: three training levels
        t = np.arange(0, 2.0, 1 / 200)
        x, v = amp * np.sin(2 * np.pi * t), 2 * np.pi * amp * np.cos(2 * np.pi * t)
        fc = 0.3 + 0.4 * amp
        y = 2.0 * x + 0.5 * v + fc * (2 / np.pi) * np.arctan(v / 0.01) + NOISE * rng.standard_normal(len(t))
        out.append(Record(name=f"a{amp}", t=t, x=x, y=y, conditions={"amplitude_in": amp},
                          units={"x": "in", "F": "kip", "t": "s"}))
    split = {"held_out": {"amplitude_in": [1.5]}, "val": {"amplitude_in": [1.25]}}
    res = discover(RecordSet(out), true_model("coulomb"), candidates=[], split=split, conditions=["amplitude_in"],
                   noise_sd=NOISE, **FAST)
    steps = res.report["steps"]
    assert [s["effect"] for s in steps][:1] == ["coulomb.Fc~amplitude_in"]
    assert steps[0]["new_coordinates"]["coulomb.Fc.c1"] == pytest.approx(0.4, rel=0.15)
    assert res.report["after"]["test_rmse"] <= 1.5 * NOISE


def _coordinates_in_bic(entry: dict, n: int) -> float:
    """k solved from a step's reported ``bic_after`` and training RMSE: BIC = n ln(SSE/n) + k ln n with
    SSE/n = RMSE²; a whole number only if the loop computed the formula with a count of coordinates."""
    return (entry["evidence"]["bic_after"] - n * math.log(entry["train_rmse"] ** 2)) / math.log(n)


def _damper_records(noise_sd: float, seed: int = 0) -> RecordSet:
    """F = 2 x + 0.5 ẋ + 0.6 tanh(ẋ / 0.05) [kip, in, s] with white noise, written here in numpy (no library
    effect or simulator): sine tests at the amplitudes and frequencies of the synthetic cases."""
    rng = np.random.default_rng(seed)
    out = []
    for amp, f in [(0.5, 1.0), (1.0, 1.0), (1.0, 2.0), (0.75, 1.5), (1.5, 1.0), (1.5, 2.0)]:
        t = np.arange(201) / (100 * f)
        w = 2 * np.pi * f
        x, v = amp * np.sin(w * t), amp * w * np.cos(w * t)
        y = 2.0 * x + 0.5 * v + 0.6 * np.tanh(v / 0.05) + noise_sd * rng.standard_normal(len(t))
        out.append(Record(name=f"sine_{amp:g}in_{f:g}Hz", t=t, x=x, y=y, units={"x": "in", "y": "kip"},
                          conditions={"amplitude_in": amp, "frequency_hz": f}))
    return RecordSet(out, "numpy damper")


def test_the_criterion_adds_the_missing_term_and_refuses_a_useless_one(float64):
    """Data with three terms (spring, damper, Coulomb friction), a nominal with two, candidates Coulomb and a
    cubic spring that the data do not have. No validation split and no margin: the training error falls with
    any added coordinate, so the information criterion alone has to refuse the cubic spring."""
    records = _damper_records(NOISE)
    res = discover(records, base_model("coulomb"), candidates=["coulomb", "cubic_stiffness"],
                   split={"held_out": {"amplitude_in": [1.5]}}, conditions=False, margin=0.0, noise_sd=NOISE, **FAST)
    rep = res.report
    assert [s["effect"] for s in rep["steps"]] == ["coulomb"] and rep["removed"] == []
    assert sorted(rep["effects"]["final"]) == ["coulomb", "linear_stiffness", "viscous"]
    assert rep["steps"][0]["new_coordinates"]["coulomb.Fc"] == pytest.approx(0.6, rel=0.05)
    (useless,) = rep["rejected"]
    ev = useless["evidence"]
    assert useless["effect"] == "cubic_stiffness"
    assert ev["val_rmse_after"] < ev["val_rmse_before"] and ev["bic_after"] > ev["bic_before"]
    n_train = sum(len(r) for r in res.splits["train"])
    assert n_train == 4 * 201
    assert _coordinates_in_bic(rep["steps"][0], n_train) == pytest.approx(4, abs=1e-9)  # c, k, Fc, v_s
    assert _coordinates_in_bic(useless, n_train) == pytest.approx(5, abs=1e-9)  # ... and k3
    assert rep["after"]["test_rmse"] <= 1.2 * NOISE


def test_bad_input_is_a_clear_error(float64):
    records = make_records(None, noise_sd=NOISE)
    with pytest.raises(ValueError, match="unknown candidate effect"):
        discover(records, base_model(None), candidates=["friction_of_doom"], split=SPLIT, **FAST)
    with pytest.raises(ValueError, match=r"unknown leftover measure 'dynamic'; choose one of \['static', 'dynamics'\]"):
        discover(records, base_model(None), split=SPLIT, leftover="dynamic", **FAST)
    with pytest.raises(ValueError, match="leaves no training records"):
        discover(records, base_model(None), split={"held_out": {"frequency_hz": [1.0, 1.5, 2.0]}}, **FAST)
    short = RecordSet([r.slice(stop=8) for r in records])
    with pytest.raises(ValueError, match="discovery"):
        discover(short, base_model(None), split=SPLIT, **FAST)
    with pytest.raises(ValueError, match="discover conditions: no record has a condition 'tension'; numeric"):
        discover(records, base_model(None), split=SPLIT, conditions=["tension"], **FAST)
    with pytest.raises(ValueError, match=r"no record has a condition 'amplitude' \(did you mean 'amplitude_in'\?\)"):
        discover(records, base_model(None), split=SPLIT, conditions=["amplitude"], **FAST)
    with pytest.raises(ValueError, match=r"'amplitude_in' takes 1 value\(s\) \[0.5\] on the training"):
        discover(records, base_model(None), split={"held_out": {"amplitude_in": [0.75, 1.0, 1.5]}, "val": None},
                 conditions=["amplitude_in"], **FAST)
    from hybridhyst.physics.build import build_model

    trended = build_model("constitutive", {"v": {"effect": "viscous", "c": {"kind": "linear", "slope": 0.1,
                                                                          "intercept": 0.5, "condition": "tension"}},
                                           "k": {"effect": "linear_stiffness", "k": 2.0}}).double()
    with pytest.raises(ValueError, match=r"the nominal model \(a parameter as a function of a condition\): "
                                         r"no record has a condition 'tension'"):
        discover(records, trended, split=SPLIT, **FAST)
    # a trend of the nominal below zero at a training amplitude (c = 0.5 − 1.0 · A < 0 at A = 1): a start no local
    # refit could leave (it simulates nothing there)
    below = build_model("constitutive", {"v": {"effect": "viscous", "c": {"kind": "linear", "slope": -1.0,
                                                                        "intercept": 0.5, "condition": "amplitude_in"}},
                                         "k": {"effect": "linear_stiffness", "k": 2.0}}).double()
    with pytest.raises(ValueError, match=r"the nominal model's parameter v.c = -0.5 at amplitude_in=1, frequency_hz=1"
                                         r".*outside its domain on a training record.*fit_nominal"):
        discover(records, below, split=SPLIT, **{**FAST, "fit_nominal": False})
    with pytest.raises(ValueError, match="unknown effect 'dahll'"):
        build_model("constitutive", {"f": {"effect": "dahll"}})


def test_discover_app_on_the_measured_brfd_data(tmp_path, capsys):
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli import discover as app
    from hybridhyst.cli.common import CONF_DIR

    overrides = [f"run_dir={tmp_path}", "progress=false", "discover.candidates=[asymmetric_coulomb]",
                 "discover.conditions=false", "discover.max_steps=1", "discover.identify.pop=8",
                 "discover.identify.generations=3", "discover.lm_steps=10", "thinning.samples_per_cycle=16"]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(config_name="discover", overrides=overrides)
        wrong = compose(config_name="discover", overrides=[*overrides, "experiment=vpptd_dynamics"])
    report = app.run(cfg)
    saved = json.loads((tmp_path / "discovery.json").read_text())
    assert saved["steps"] == report["steps"] and len(saved["records"]["test"]) == 4  # the earthquakes
    assert saved["after"]["val_rmse"] <= saved["before"]["val_rmse"]
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Discovery: BRFD")
    # asymmetric Coulomb is accepted at the one step allowed: the report and the terminal say the cap ended it
    assert [s["effect"] for s in saved["steps"]] == ["asymmetric_coulomb"] and saved["stopped"] == "max_steps"
    assert "stopped at its cap on effects added (`discover.max_steps` = 1)" in text
    assert "  stopped at the cap on effects added (discover.max_steps=1)" in capsys.readouterr().out
    with pytest.raises(ValueError, match="is for hybridhyst-study, not hybridhyst-discover"):
        app.run(wrong)


def test_trend_per_parameter_is_chosen_by_aicc_over_the_levels():
    """Per-level estimates with scatter (50 draws each): a constant, a linear and an exponential law are told
    apart at the rates the loop relies on; three levels never get a three-coefficient form."""
    from hybridhyst.discover.trends import choose_trend

    c = np.linspace(0.01, 0.09, 9)
    laws = {"constant": 2.0 + 0.0 * c, "linear": 0.5 + 12.5 * c, "exp_growth": 1.0 + 0.2 * np.exp(40 * c)}
    for truth, y in laws.items():
        picks = [choose_trend(c, y + 1e-3 * np.random.default_rng(s).standard_normal(9)) for s in range(50)]
        share = np.mean([kind == truth for kind, _ in picks])
        assert share >= (0.95 if truth == "exp_growth" else 0.8), (truth, share)
    kind, coef = choose_trend(c, laws["linear"])
    assert kind == "linear" and coef["slope"] == pytest.approx(12.5)
    kind, coef = choose_trend(c, laws["exp_growth"])
    assert kind == "exp_growth" and coef["b"] == pytest.approx(40, rel=1e-3)
    assert choose_trend(c[:4], laws["exp_growth"][:4])[0] in ("constant", "linear")  # exponentials from 5 levels
    assert choose_trend(c[:5], laws["exp_growth"][:5])[0] == "exp_growth"


def test_a_trend_is_chosen_among_those_its_parameters_domain_admits_at_the_levels():
    """A nonnegative level rising from zero, convex (a gap or a friction excess that appears with the condition):
    the least-squares line dips below zero at the lowest level, a start no refit could leave (it simulates
    nothing there). With the parameter's spec the line is not offered; without it, it is."""
    from hybridhyst.discover.trends import choose_trend
    from hybridhyst.physics.parameters import ParameterSpec

    c = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    y = np.array([0.0, 0.1, 0.3, 0.75, 1.3])
    kind, coef = choose_trend(c, y)
    assert kind == "linear" and coef["intercept"] == pytest.approx(-0.16)
    nonnegative = ParameterSpec(0.0, "x", (0.0, 1e6), "nonnegative")
    kind, coef = choose_trend(c, y, nonnegative)
    assert kind != "linear"
    assert kind == "constant" and coef["value"] == pytest.approx(y.mean())
    assert choose_trend(c, y + 1.0, nonnegative)[0] == "linear"  # a line that stays above zero is still one


def test_the_chosen_structure_is_refitted_on_training_and_validation_records(float64):
    """A spring + dashpot fitted at 0.5-1 Hz, validated at 3 Hz, tested at 2 Hz (data from the closed form,
    not the library's simulator). With ``refit`` the final parameters use the 3 Hz record as well; the
    reported validation error stays the training-only fit's (out of sample), the test error and the
    predictions are the returned model's."""
    from hybridhyst.physics.build import build_model

    rng = np.random.default_rng(3)
    recs = []
    for amp, f in [(1.0, 0.5), (0.5, 1.0), (0.8, 3.0), (0.6, 2.0)]:
        t = np.arange(201) / (100 * f)
        x, v = amp * np.sin(2 * np.pi * f * t), 2 * np.pi * f * amp * np.cos(2 * np.pi * f * t)
        y = 1.5 * x + 0.1 * v + 0.01 * rng.standard_normal(t.size)
        recs.append(Record(name=f"s{f:g}", t=t, x=x, y=y, conditions={"frequency_hz": f},
                           units={"x": "in", "y": "kip"}))
    split = {"held_out": {"frequency_hz": [2.0]}, "val": {"frequency_hz": [3.0]}}

    def run(refit):
        nominal = build_model("constitutive", {"spring": {"effect": "linear_stiffness", "k": 1.0},
                                               "viscous": {"effect": "viscous", "c": 0.3}},
                              units={"x": "in", "F": "kip", "t": "s"}).double()
        return discover(RecordSet(recs), nominal, split=split, conditions=False, max_steps=0, fit_nominal=False,
                        refit=refit, progress=False)

    plain, refitted = run(False), run(True)
    a, b = plain.report, refitted.report
    assert a["refit"] is None and b["settings"]["refit"] and b["refit"]["records"] == ["s0.5", "s1", "s3"]
    assert b["after"]["val_rmse"] == pytest.approx(a["after"]["val_rmse"])  # out of sample, not the refit's
    assert b["refit"]["after"]["val_rmse_in_sample"] < a["after"]["val_rmse"]
    assert b["refit"]["after"]["test_rmse_without_refit"] == pytest.approx(a["after"]["test_rmse"])
    assert b["refit"]["after"]["parameters_without_refit"] == a["after"]["parameters"]
    assert b["after"]["parameters"] != a["after"]["parameters"]
    test = refitted.splits["test"][0]
    with torch.no_grad():
        pred = simulate(refitted.model, [test])[0][:, 0].numpy()
    assert math.sqrt(np.mean((pred - test.y) ** 2)) == pytest.approx(b["after"]["test_rmse"], rel=1e-6)
    np.testing.assert_allclose(refitted.predictions["after"]["test"][0], pred, rtol=1e-9, atol=1e-12)


def test_an_effect_whose_level_depends_on_the_condition_gets_its_trend_after_it_is_added(float64):
    """Numpy data, F = k x + c(p) ẋ + Fc(p) sign ẋ (exact sign), both c and Fc linear in the pressure, 6
    training pressures, 2 held out (one beyond them). The nominal lacks the friction: its c gets its trend in
    the first trend step, the Coulomb level (added as an effect, constant) gets its own in the trend step
    after the effects, and the held-out error reaches the noise."""
    rng = np.random.default_rng(7)
    noise, records = 0.02, []
    for i, p in enumerate((0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09)):
        t = np.arange(0.0, 2.0, 1 / 200)
        x = 0.6 * np.sin(2 * np.pi * t + 0.4 * i)
        v = 0.6 * 2 * np.pi * np.cos(2 * np.pi * t + 0.4 * i)
        y = 2.0 * x + (0.1 + 4.0 * p) * v + (0.2 + 10.0 * p) * np.sign(v) + noise * rng.standard_normal(len(t))
        records.append(Record(f"p{p}", t, x, y, conditions={"pressure_mpa": p}))
    from hybridhyst.physics.effects import LinearStiffness, Viscous
    from hybridhyst.physics.models import Constitutive

    nominal = Constitutive({"spring": LinearStiffness(k=1.5), "viscous": Viscous(c=0.3)}).double()
    res = discover(RecordSet(records), nominal, candidates=["coulomb"], noise_sd=noise, fit_nominal=False,
                   split={"held_out": {"pressure_mpa": [0.05, 0.09]}}, max_steps=1, progress=False)
    rep = res.report
    steps = [(s["effect"], s.get("when")) for s in rep["steps"]]
    assert steps == [("trends~pressure_mpa", "before effects"), ("coulomb", None),
                     ("trends~pressure_mpa", "after effects")]
    assert rep["steps"][2]["trends"] == {"coulomb.Fc": "linear"}
    assert rep["after"]["test_rmse"] <= 1.2 * noise < rep["steps"][1]["test_rmse"]


def test_a_record_the_discovered_model_diverges_on_is_named_in_the_report_and_discovery_json(float64, tmp_path):
    """A test record the models cannot be simulated on (its sample interval far beyond the oscillator's explicit
    stability limit) is named with the sample it diverged from, in report.md and discovery.json, never dropped
    behind a "—"; ``check_discovery`` makes it the app's error, or a warning with keep_going."""
    from hybridhyst.analysis.finite import DivergenceError
    from hybridhyst.discover.report import check_discovery, diverged_records
    from hybridhyst.physics import build_model

    def oscillator():
        return build_model(structure="oscillator", units={"x": "m", "F": "N", "u": "N", "t": "s"}, mass=2.0,
                           fixed=["drive_gain"], effects={"viscous": {"effect": "viscous", "c": 10.0},
                                                          "stiffness": {"effect": "linear_stiffness", "k": 1e6}})

    def record(name, amp, dt, n):
        t = np.arange(n) * dt
        u = 1e3 * amp * np.sin(2 * np.pi * (5.0 if dt < 0.1 else 0.01) * t)
        if dt < 0.1:
            with torch.no_grad():
                y = simulate(oscillator(), u[None], t=t, substeps=8)[0, :, 0].numpy()
        else:  # quasi-static: no explicit scheme resolves ω·dt = 707 at any sub-steps scoring tries
            y = u / 1e6
        return Record(name, t, u, y, conditions={"amp": amp}, units={"t": "s", "x": "N", "y": "m"})

    records = RecordSet([record("fine_a", 1.0, 1e-3, 300), record("fine_b", 2.0, 1e-3, 300),
                         record("coarse", 9.0, 1.0, 40)], "oscillator")
    result = discover(records, oscillator(), candidates=["cubic_stiffness"], split={"held_out": {"amp": [9.0]}},
                      conditions=False, max_steps=1, lm_steps=3, fit_nominal=False, start_states=False, progress=False)
    (after,) = diverged_records(result, "after")
    assert (after.record, after.split) == ("coarse", "test") and 0 < after.sample < 40
    write_discovery(result, tmp_path, unit="m")
    report = (tmp_path / "report.md").read_text()
    assert f"**The discovered model's simulation diverged** on 1 record: 'coarse' (test) from sample {after.sample}" \
        in report
    assert json.loads((tmp_path / "discovery.json").read_text())["diverged"]["after"][0]["record"] == "coarse"
    with pytest.raises(DivergenceError, match=r"diverged on 1 of 3 records: 'coarse' \(test\) from sample"):
        check_discovery(result)
    said = []
    assert check_discovery(result, keep_going=True, warn=said.append)[0].record == "coarse"
    assert said and said[0].startswith("warning: the discovered model's simulation diverged")


def _softening_damper(noise: float = 0.5, seed: int = 3) -> list[Record]:
    """A damper whose spring softens with use and remembers it from record to record, made with numpy alone:
    F = k(S) x + c v + AR(1) noise, k(S) = k0 (1 − a (1 − exp(−S / L))), S the exact travel of the sine (4 A per
    period, piecewise within one) from 60 mm of use before the first record; seven sine records in the order they
    were measured."""
    def travel(A, f, t):
        ph, n = (f * t) % 1.0, np.floor(f * t)
        s = np.sin(2 * np.pi * ph)
        return 4 * A * n + np.where(ph < 0.25, A * s, np.where(ph < 0.75, 2 * A - A * s, 4 * A + A * s))

    rng = np.random.default_rng(seed)
    k0, a, L, c, used = 12.0, 0.4, 250.0, 0.8, 60.0
    out = []
    for A, f in [(4, 1.0), (8, 0.5), (6, 1.5), (3, 2.0), (8, 1.0), (5, 0.5), (6, 1.0)]:
        fs = 200.0
        t = np.arange(int((4.0 / f if f < 1.5 else 3.0) * fs)) / fs
        x, v = A * np.sin(2 * np.pi * f * t), 2 * np.pi * f * A * np.cos(2 * np.pi * f * t)
        k = k0 * (1 - a * (1 - np.exp(-(used + travel(A, f, t)) / L)))
        e = np.empty(len(t))
        e[0], w = rng.normal(0, noise), rng.normal(0, noise * math.sqrt(1 - 0.25), len(t))
        for i in range(1, len(t)):
            e[i] = 0.5 * e[i - 1] + w[i]
        out.append(Record(name=f"A{A}_f{f}", t=t, x=x, y=k * x + c * v + e,
                          conditions={"amplitude": float(A), "frequency_hz": f}, units={"x": "mm", "y": "N"}))
        used += travel(A, f, np.array([len(t) / fs]))[0]
    return out


def test_a_drift_with_travel_carried_from_record_to_record_is_named_and_predicts_a_later_record(float64):
    """Records in the order they were measured (``carried_travel``, the default): the stiffness's drift with travel
    starts each record at the travel before it, names the softening and predicts the held-out record (the fourth
    of seven) at the noise; started afresh in every record (``carried_travel=False``) the drift cannot follow the
    records and nothing is named. The travel before a record is no trend condition."""
    from hybridhyst.physics.build import build_model

    def run(carried: bool):
        nominal = build_model("constitutive", {"spring": {"effect": "linear_stiffness", "k": 10.0},
                                               "viscous": {"effect": "viscous", "c": 1.0}})
        return discover(_softening_damper(), nominal, candidates=["travel_stiffness", "coulomb", "cubic_stiffness"],
                        split={"held_out": [{"amplitude": [3.0]}], "val": [{"amplitude": [5.0]}]}, conditions=True,
                        noise_sd=0.5, carried_travel=carried, **FAST).report

    rep = run(True)
    assert [s["effect"] for s in rep["steps"]] == ["travel_stiffness"]
    assert rep["after"]["test_rmse"] <= 1.2 * 0.5 < rep["before"]["test_rmse"]
    new = rep["steps"][0]["new_coordinates"]
    assert new["travel_stiffness.s0.c1"] == pytest.approx(1.0, abs=0.1)  # the records' travel carries over whole
    assert new["travel_stiffness.lam"] == pytest.approx(1 / 250, rel=0.2)
    assert not any("travel_before" in s["effect"] for s in rep["steps"] + rep["rejected"])
    off = run(False)
    assert off["steps"] == [] and off["after"]["test_rmse"] > 2 * 0.5


def test_the_travel_before_each_record_is_the_input_travel_of_those_before_it():
    from hybridhyst.data import with_travel_before

    t = np.linspace(0.0, 1.0, 5)
    recs = [Record(name=n, t=t, x=x, y=np.zeros(5)) for n, x in
            (("a", np.array([0.0, 1.0, 0.0, -1.0, 0.0])), ("b", np.array([0.0, 2.0, 2.0, 2.0, 0.0])),
             ("c", np.zeros(5)))]
    out = with_travel_before(recs)
    assert [r.conditions["travel_before"] for r in out] == [0.0, 4.0, 8.0]
    assert "travel_before" not in recs[0].conditions  # new records
    # a history, not an operating point: one group to leave out, no label
    from hybridhyst.data.datamodule import condition_label
    from hybridhyst.discover.validation import condition_groups

    assert len(condition_groups(out)) == 1 and condition_label(out[1]) == "b" and out[1].operating == {}
    assert with_travel_before(out) == out  # given already: kept
    recs[1].conditions["travel_before"] = 3.0
    with pytest.raises(ValueError, match="some records only"):
        with_travel_before(recs)
    # a warm-up is simulated first but was not measured: the record starts that much earlier, and adds only its
    # scored travel to those after it
    warm = [Record(name="w", t=t, x=np.array([0.0, 1.0, 0.0, 2.0, 0.0]), y=np.zeros(5), warmup=2),
            Record(name="z", t=t, x=np.zeros(5), y=np.zeros(5))]
    assert [r.conditions["travel_before"] for r in with_travel_before(warm)] == [-2.0, 4.0]
    # a slice (a training window, a record cut short) starts where the travel before its first sample left it
    w = with_travel_before(warm)[0]
    assert w.slice(3).conditions["travel_before"] == -2.0 + 4.0 and w.slice(step=2).conditions == w.conditions
    assert w.slice(1, 4).conditions["travel_before"] == -1.0 and w.slice(0).conditions["travel_before"] == -2.0


def test_a_carried_drift_offers_no_shared_start_state_and_can_be_swapped_out():
    """With the travel carried between records the drift's start follows each record's history: no start state
    shared by every record is offered for it (nor without carry-over), and replacing it (a rival swap, a special
    case) does not read it as one fitted start."""
    from hybridhyst.discover.candidates import Candidate, Scales, effect_candidates, start_candidates
    from hybridhyst.discover.selection import _with_starts
    from hybridhyst.physics.build import build_model

    nominal = build_model("constitutive", {"spring": {"effect": "linear_stiffness", "k": 10.0}})
    carried, plain = Scales(F=1.0, x=1.0, v=1.0, u=1.0, travel=100.0), Scales(F=1.0, x=1.0, v=1.0, u=1.0)
    (cand,) = effect_candidates(nominal, carried, ["travel_stiffness"])
    assert {"travel_stiffness.s0.c0", "travel_stiffness.s0.c1"} <= set(cand.free)
    model = cand.build(nominal)
    # the travel carried in never falls with the travel before, nor turns negative, in any later fit
    assert model.effects["travel_stiffness"].params["s0"].nonnegative
    (alone,) = effect_candidates(nominal, plain, ["travel_stiffness"])
    assert "s0" not in alone.build(nominal).effects["travel_stiffness"].params
    assert start_candidates(model, carried) == [] and start_candidates(alone.build(nominal), plain) == []
    swap = _with_starts(effect_candidates(nominal, carried, ["coulomb"]), nominal, carried,
                        model.effects["travel_stiffness"])
    assert isinstance(swap, Candidate) and "coulomb" in swap.name
