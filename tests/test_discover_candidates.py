"""Discovery's candidates: Bouc–Wen form, smoothing-width boxes, start states, fits side by side."""

from __future__ import annotations

import dataclasses
import math
import sys

import numpy as np
import pytest
import torch
from test_discover import FAST, NOISE, _damper_records

from hybridhyst.data import Record
from hybridhyst.discover import Scales, discover
from hybridhyst.simulate import SimulationSettings
from hybridhyst.synth.effects import base_model, make_records


def test_bouc_wen_candidate_is_the_identifiable_normalised_form(float64):
    """α, k1, D, A are held (discovery_fixed): only k, β, γ, n are searched, and the start adds a pure
    hysteretic element F = k z (no elastic share, no cubic term) to the fitted model."""
    from hybridhyst.discover.candidates import Scales, effect_candidates

    records = make_records(None, noise_sd=NOISE)
    model = base_model(None)
    (cand,) = effect_candidates(model, Scales.of(records.records), ["bouc_wen"])
    assert sorted(cand.free) == ["bouc_wen.beta", "bouc_wen.gamma", "bouc_wen.k", "bouc_wen.n"]
    from hybridhyst.physics.parameters import Fixed

    effect = cand.build(model).effects["bouc_wen"]
    held = {n: float(fn(None, 1)[0]) for n, fn in effect.params.items() if isinstance(fn, Fixed)}
    assert held == {"alpha": 0.0, "k1": 0.0, "D": 1.0, "A": 1.0}


def test_sign_smoothing_widths_are_searched_well_below_the_data_speeds():
    """A sign smoothed over the data's own speeds is a linear or |v|-like term: asymmetric Coulomb with
    v_s ≫ |v| is dF·|v|/v_s, a force of one sign either way (seen on the 30 lb BRFD tests, v_s = 2593 in/s).
    Every smoothing width's box ends at a tenth of the velocity scale; the other shape parameters keep theirs."""
    from hybridhyst.discover.candidates import SMOOTHING_MAX, Scales, effect_candidates
    from hybridhyst.physics.effects import EFFECTS

    records = make_records(None, noise_sd=NOISE)
    scales = Scales.of(records.records)
    names = ["asymmetric_coulomb", "coulomb", "stribeck", "travel_drift"]
    assert {n for n, cls in EFFECTS.items() if any(s.smoothing for s in cls.specs.values())} == set(names)
    model = base_model(None).with_effects({})  # no effect present: every one is a candidate
    for cand in effect_candidates(model, scales, names):
        key = cand.meta["key"]
        assert cand.bounds[f"{key}.v_s"][1] == pytest.approx(SMOOTHING_MAX * scales.v)
        assert all(s[f"{key}.v_s"] <= SMOOTHING_MAX * scales.v for s in cand.starts)
        assert len({tuple(sorted(s.items())) for s in cand.starts}) == len(cand.starts)  # no start twice
    (stribeck,) = effect_candidates(model, scales, ["stribeck"])
    assert stribeck.bounds["stribeck.vs"][1] > scales.v  # the Stribeck speed is not a smoothing width


def _clearance_start_records(n_periods: float = 2.0):
    """Two records from an exact gap + Dahl integration (numpy, ``testbed.generators``) on a refined path, each
    started with the gap closed on the negative side; a spring + clearance nominal polished on them."""
    from hybridhyst.discover.fitting import polish
    from hybridhyst.physics.effects import Clearance, LinearStiffness
    from hybridhyst.physics.models import Constitutive
    from hybridhyst.testbed.generators import clearance_dahl

    r, sigma0, up, down, noise = 0.06, 15.0, 0.5, 0.7, 0.01
    q0 = -(r + down / sigma0)
    rng = np.random.default_rng(3)
    records = []
    for amp in (0.5, 1.0):
        t = np.arange(0, n_periods, 1 / 150)
        fine = np.linspace(0, n_periods, 20 * len(t) - 19)  # exact on a refined path, sampled every 20th point
        x_fine = -amp * np.cos(2 * np.pi * fine)
        y = 2 * x_fine[::20] + clearance_dahl(x_fine, r, sigma0, up, down, q0)[::20]
        records.append(Record(f"a{amp}", t, x_fine[::20], y + noise * rng.standard_normal(len(t)),
                              conditions={"amplitude_in": amp}))
    model = Constitutive({"spring": LinearStiffness(k=2.0), "clearance": Clearance(sigma0=12.0, Fc=0.55, a=-0.1,
                                                                                    r=0.05)}).double()
    sim = SimulationSettings(substeps=2)
    return records, polish(model, records, sim, 25, 10.0), sim, q0, noise


def test_a_start_state_is_a_candidate_and_is_recovered_from_data_that_start_away_from_rest(float64):
    """Records from an exact gap + Dahl integration (numpy, ``testbed.generators``), each started as a rig
    starts a test: moved down to −A first, so the gap is closed on the negative side and the element fully
    deflected. From the clearance started at rest, the start candidate (``start_candidates``: one per effect
    with ``Effect.start``, not for one that has its start already, never a condition trend) recovers q0 and
    brings the error to the noise; the condition candidates leave the start state alone."""
    from hybridhyst.discover.candidates import condition_candidates, start_candidates
    from hybridhyst.discover.fitting import fit_candidate
    from hybridhyst.physics.effects import Dahl, LinearStiffness, LuGre
    from hybridhyst.physics.models import Constitutive

    records, fit, sim, q0, noise = _clearance_start_records()
    scales = Scales.of(records)
    (cand,) = start_candidates(fit.model, scales)
    assert cand.name == "clearance.start" and cand.kind == "start" and cand.free == ["clearance.q0"]
    c_fit = fit_candidate(cand, fit.model, records, sim.at(fit.substeps), 25, 10.0)
    assert c_fit.coords["clearance.q0"] == pytest.approx(q0, rel=0.05)
    assert math.sqrt(c_fit.sse / sum(len(r_) for r_ in records)) < 1.2 * noise < math.sqrt(fit.sse / 600)
    assert start_candidates(c_fit.model, scales) == []  # started already
    assert all(c.meta["param"] != "q0" for c in condition_candidates(c_fit.model, {"amplitude_in": [0.5, 1.0]}))
    # one per effect that may start away from rest; none for the rest (a spring has no state)
    many = Constitutive({"spring": LinearStiffness(k=1.0), "dahl": Dahl(sigma0=5.0, Fc=1.0),
                         "lugre": LuGre(sigma0=5.0, Fc=1.0, Fs=1.2, vs=0.1)}).double()
    assert [c.name for c in start_candidates(many, scales)] == ["dahl.start", "lugre.start"]


def test_long_records_screen_a_candidates_starts_on_their_leading_part(float64, monkeypatch):
    """``fitting.screened``: records holding at most ``SCREEN_SAMPLES`` samples are used as they are (every data set
    of the beds and BRFD); longer ones are cut to the leading part of each, in proportion to its length, warm-up
    kept, where each part spans its record's range (not a part of an amplitude ramp or a frequency sweep). A
    candidate fitted on records three times the screen (``SCREEN_SAMPLES`` lowered for the test) runs its many-row
    phases on the cut records and only its best ``keep`` rows on every sample, and ends where the fit without the
    screen ends: the start state of the clearance, at the noise. The rows that go on are the lowest on every
    sample; where none can be simulated there, every start's first round is run on every sample."""
    import hybridhyst.discover.fitting as fitting
    from hybridhyst.discover.candidates import start_candidates

    records, fit, sim, q0, noise = _clearance_start_records(n_periods=3.0)  # 450 samples each
    assert fitting.screened(records) is records  # below the default screen: untouched
    part = fitting.screened(records, samples=300)
    assert [len(r) for r in part] == [150, 150]
    assert all(np.array_equal(p.y, r.y[:150]) and np.array_equal(p.x, r.x[:150]) for p, r in zip(part, records))
    warm = [dataclasses.replace(records[0], warmup=200), records[1]]
    assert [len(r) for r in fitting.screened(warm, samples=300)] == [202, 150]  # the warm-up and a sample scored
    ramp = [dataclasses.replace(r, x=r.x * np.linspace(0.3, 1.0, len(r))) for r in records]
    assert fitting.screened(ramp, samples=300) is ramp  # a leading part without the record's larger amplitudes
    sweep = [dataclasses.replace(r, x=np.sin(2 * np.pi * (0.5 * r.t + 0.5 * r.t**2))) for r in records]
    assert fitting.screened(sweep, samples=300) is sweep  # ... or without its higher speeds

    (cand,) = start_candidates(fit.model, Scales.of(records))
    whole = fitting.fit_candidate(cand, fit.model, records, sim.at(fit.substeps), 25, 10.0)
    seen = []
    lm = fitting.levenberg_marquardt

    def spy(residuals, space, starts, **kw):
        seen.append((residuals.__self__.n_samples, starts.reshape(-1, space.dim).shape[0]))
        return lm(residuals, space, starts, **kw)

    monkeypatch.setattr(fitting, "levenberg_marquardt", spy)
    monkeypatch.setattr(fitting, "SCREEN_SAMPLES", 300)
    cut = fitting.fit_candidate(cand, fit.model, records, sim.at(fit.substeps), 25, 10.0)
    screened_calls = [rows for n, rows in seen if n == 300]
    full_calls = [rows for n, rows in seen if n == 900]
    assert screened_calls and max(screened_calls) > 3  # every start on the cut records
    assert full_calls and max(full_calls) <= 3  # the best three on every sample
    assert len(screened_calls) + len(full_calls) == len(seen)
    assert cut.coords["clearance.q0"] == pytest.approx(q0, rel=0.05)
    assert cut.sse == pytest.approx(whole.sse, rel=1e-3)
    assert math.sqrt(cut.sse / 900) < 1.2 * noise

    # rows fitted on the leading part that cannot be simulated on every sample (an amplitude that grows within the
    # record): the first round starts again on every sample, from every start
    sse = fitting._sse

    def unresolved(problem, X):
        out = sse(problem, X)
        return torch.full_like(out, math.inf) if problem.n_samples == 900 and X.shape[0] > 1 else out

    seen.clear()
    monkeypatch.setattr(fitting, "_sse", unresolved)
    again = fitting.fit_candidate(cand, fit.model, records, sim.at(fit.substeps), 25, 10.0)
    full_calls = [rows for n, rows in seen if n == 900]
    assert max(full_calls) == max(screened_calls)  # every start, on every sample
    assert again.sse == pytest.approx(whole.sse, rel=1e-3)


def test_the_start_state_of_an_effect_just_added_is_offered_at_once_and_its_refusal_is_said_as_such(float64):
    """``Loop.starts_of_added``: records that start with a gap closed (an exact gap + Dahl integration, numpy) and
    a spring nominal. The loop adds the clearance, then offers its start state at once, as a step of its own
    (``when``: ``AFTER_ADDED``), not after a whole ranking of the next step; it is accepted, q0 recovered. A start
    offer the rule refuses is reported as that, not as the candidate the loop stopped at."""
    from dataclasses import replace

    from hybridhyst.cli.discover import summary_lines
    from hybridhyst.discover.report import report_markdown
    from hybridhyst.discover.result import AFTER_ADDED
    from hybridhyst.physics.effects import LinearStiffness
    from hybridhyst.physics.models import Constitutive
    from hybridhyst.testbed.generators import clearance_dahl

    r, sigma0, up, down, noise = 0.06, 15.0, 0.5, 0.7, 0.01
    q0 = -(r + down / sigma0)
    rng = np.random.default_rng(5)
    records = []
    for amp in (0.5, 0.75, 1.0):
        t = np.arange(0, 2.0, 1 / 150)
        fine = np.linspace(0, 2.0, 20 * len(t) - 19)
        x_fine = -amp * np.cos(2 * np.pi * fine)
        y = 2 * x_fine[::20] + clearance_dahl(x_fine, r, sigma0, up, down, q0)[::20]
        records.append(Record(f"a{amp}", t, x_fine[::20], y + noise * rng.standard_normal(len(t)),
                              conditions={"amplitude_in": amp}))
    res = discover(records, Constitutive({"spring": LinearStiffness(k=2.0)}).double(), candidates=["clearance"],
                   split={"held_out": {"amplitude_in": [0.75]}}, conditions=False, noise_sd=noise, **FAST)
    steps = res.report["steps"]
    assert [s["effect"] for s in steps[:2]] == ["clearance", "clearance.start"]
    assert "when" not in steps[0] and steps[1]["when"] == AFTER_ADDED
    assert steps[1]["parameters"]["clearance.q0"]["value"] == pytest.approx(q0, rel=0.1)
    refused = {**steps[1], "accepted": False}
    last = {**steps[0], "effect": "coulomb", "accepted": False}  # the candidate that stopped the loop
    report = {**res.report, "steps": steps[:1], "rejected": [refused, last]}
    text = report_markdown(replace(res, report=report), "t", "N")
    assert f"The start state **clearance.start**, offered {AFTER_ADDED}, was not taken" in text
    assert "The loop stopped at the best remaining candidate, **clearance.start**" not in text
    assert "The loop stopped at the best remaining candidate, **coulomb**" in text
    cross = {"kind": "loco", "before": 1.0, "after": 1.1, "disagrees": True, "determined": True, "refused": True}
    text = report_markdown(replace(res, report={**report, "rejected": [{**refused, "cross_check": cross}]}), "t", "N")
    assert f"The start state **clearance.start**, offered {AFTER_ADDED}, was refused by its cross-check" in text
    first = summary_lines(report, "N", "run")[0]
    assert first.endswith("best remaining candidate not accepted: coulomb")


def test_a_fit_leaves_sub_steps_its_model_no_longer_needs(float64):
    """Sub-steps found by doubling only rise; a model whose stiff element has gone (removed, or given up by its
    fit) is refitted at the fewest that resolve it (``polish``, ``resolve``: ``simulate.coarsest_substeps``), so
    the later candidates are not fitted at steps the model no longer needs."""
    from hybridhyst.discover.candidates import effect_candidates
    from hybridhyst.discover.fitting import fit_candidate, polish, sse_at
    from hybridhyst.physics.effects import LinearStiffness, Viscous
    from hybridhyst.physics.models import Constitutive

    records = _damper_records(NOISE)
    model = Constitutive({"spring": LinearStiffness(k=1.0), "damper": Viscous(c=0.1)}).double()
    fit = polish(model, records, SimulationSettings(substeps=16), 25, 10.0)
    assert fit.substeps == 1 and math.isfinite(fit.sse)
    assert fit.sse == pytest.approx(sse_at(fit, records, SimulationSettings(), 1), rel=1e-12)  # the SSE at its steps
    # a candidate's fit (``resolve``) halves too: a Coulomb element added to the model at 16
    (cand,) = effect_candidates(model, Scales.of(records), ["coulomb"])
    c_fit = fit_candidate(cand, model, records, SimulationSettings(substeps=16), 25, 10.0)
    assert c_fit.substeps < 16


def test_candidates_fitted_side_by_side_give_the_same_result_as_one_after_another(float64):
    """``workers``: each candidate's fit in a thread of its own; the compiled loops release the GIL, and every fit
    is deterministic, so the steps, refusals, parameters and errors are the same numbers."""
    records = _damper_records(NOISE)
    kw = dict(candidates=["coulomb", "cubic_stiffness", "backlash"], split={"held_out": {"amplitude_in": [1.5]}},
              conditions=False, noise_sd=NOISE, **FAST)
    one = discover(records, base_model("coulomb"), workers=1, **kw).report
    three = discover(records, base_model("coulomb"), workers=3, **kw).report
    for key in ("steps", "rejected"):
        assert [s["effect"] for s in one[key]] == [s["effect"] for s in three[key]]
        for a, b in zip(one[key], three[key]):
            assert a["evidence"]["ranking"] == b["evidence"]["ranking"]
            assert a["parameters"] == b["parameters"]
    assert one["after"]["test_rmse"] == three["after"]["test_rmse"]


def test_a_nominal_declared_far_from_the_data_is_followed_out_of_its_box_and_the_report_says_so(float64):
    """A spring declared at 1/60 of what the loops show (numpy closed form, k x + c v + white noise): the nominal's
    first fit re-centres its box (``recentre``, on in the loop's first fit) and starts the loop at the data's
    stiffness, not at the box's edge; discovery.json's ``before.first_fit`` and report.md say so. The terminal
    names an edge only when the re-centring ran to its cap with the edge still held."""
    from dataclasses import replace

    from hybridhyst.cli.discover import summary_lines
    from hybridhyst.discover.report import report_markdown
    from hybridhyst.physics.effects import LinearStiffness, Viscous
    from hybridhyst.physics.models import Constitutive

    rng = np.random.default_rng(11)
    records = []
    for amp, f in ((2.0, 1.0), (1.0, 3.0), (1.5, 2.0)):
        t = np.arange(0.0, 2.0, 1 / 200)
        x, v = amp * np.sin(2 * np.pi * f * t), amp * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
        records.append(Record(f"a{amp}f{f}", t, x, 600.0 * x + 40.0 * v + 0.5 * rng.standard_normal(t.size),
                              conditions={"amplitude": amp}))
    nominal = Constitutive({"spring": LinearStiffness(k=10.0), "viscous": Viscous(c=30.0)}).double()
    res = discover(records, nominal, candidates=["coulomb"], conditions=False, noise_sd=0.5,
                   split={"held_out": {"amplitude": [1.5]}}, **FAST)
    first = res.report["before"]["first_fit"]
    assert first["recentred"] >= 1 and not first["at_bounds"] and first["recentre"] == 3
    assert res.report["before"]["parameters"]["spring.k"]["value"] == pytest.approx(600.0, rel=0.01)
    assert "searched again around values at the edge of its search box" in report_markdown(res, "t", "N")
    assert not any("first fit" in line for line in summary_lines(res.report, "N", "run"))
    held = {**res.report, "before": {**res.report["before"],
                                     "first_fit": {**first, "recentred": 3, "at_bounds": {"spring.k": "upper"}}}}
    assert any("spring.k (upper edge)" in line for line in summary_lines(held, "N", "run"))
    text = report_markdown(replace(res, report=held), "t", "N")
    assert "left values at an edge of its search box: `spring.k` (upper)" in text


def test_the_terminal_names_structure_left_and_a_noise_estimate_a_coloured_residual_puts_in_doubt():
    from hybridhyst.cli.discover import leftover_lines

    coloured = {"unexplained": {"structure_flagged": True, "whiteness": {"lag_1": 0.8}},
                "noise": {"sd": 0.53, "source": "estimated from the training responses' differences"}}
    text = " ".join(leftover_lines(coloured))
    assert "structure is left" in text and "sd 0.53" in text and "0.80" in text and "discover.noise_sd" in text
    given = {**coloured, "noise": {"sd": 1.5, "source": "given"}}
    assert "noise" not in " ".join(leftover_lines(given))
    white = {"unexplained": {"structure_flagged": False, "whiteness": {"lag_1": 0.05}}, "noise": coloured["noise"]}
    assert leftover_lines(white) == []


def test_a_constant_the_nominal_pushed_to_an_edge_follows_it_once_the_missing_effect_is_in(float64, monkeypatch):
    """``fitting._followed``: friction that falls with speed (numpy: a Gaussian Stribeck drop, an arctan sign) makes
    the best damping of a nominal without it small (here it starts, as a user declares it, at 0.02 and its first
    fit ends at the box's floor, 0.002). The Stribeck candidate's fit boxes each fitted constant ``box_factor``
    about its value: without following that edge the damping stays at 0.02 and the error far above the noise;
    followed, it returns to its value and the error to the noise."""
    from hybridhyst.discover.candidates import effect_candidates
    from hybridhyst.discover.fitting import EDGE_PASSES, fit_candidate, polish
    from hybridhyst.physics.effects import Coulomb, LinearStiffness, Viscous
    from hybridhyst.physics.models import Constitutive

    rng = np.random.default_rng(5)
    noise, records = 0.01, []
    for amp, f in ((0.5, 0.05), (0.75, 0.2)):  # slow sines at 50 Hz, one cycle each
        t = np.arange(0, 1 / f, 1 / 50)
        x, v = amp * np.sin(2 * np.pi * f * t), 2 * np.pi * f * amp * np.cos(2 * np.pi * f * t)
        level = 1.2 + 0.8 * np.exp(-((v / 0.15) ** 2))
        y = 3 * x + 0.4 * v + level * (2 / np.pi) * np.arctan(v / 0.002) + noise * rng.standard_normal(len(t))
        records.append(Record(f"a{amp}", t, x, y, conditions={"amplitude": amp}))
    model = Constitutive({"spring": LinearStiffness(k=3.0), "viscous": Viscous(c=0.02),
                          "coulomb": Coulomb(Fc=1.0, v_s=0.002)}).double()
    sim = SimulationSettings()
    fit = polish(model, records, sim, 25, 10.0)
    assert fit.coords["viscous.c"] == pytest.approx(0.002, rel=1e-3)  # at the floor of its box
    (cand,) = effect_candidates(fit.model, Scales.of(records), ["stribeck"])
    n = sum(len(r) for r in records)
    got = fit_candidate(cand, fit.model, records, sim, 25, 10.0)
    assert got.coords["viscous.c"] == pytest.approx(0.4, rel=0.1) and math.sqrt(got.sse / n) < 1.5 * noise
    assert EDGE_PASSES >= 2  # 0.002 -> 0.4 is more than one box of factor 10
    monkeypatch.setattr("hybridhyst.discover.fitting.EDGE_PASSES", 0)  # the same fit without following the edge
    held = fit_candidate(cand, fit.model, records, sim, 25, 10.0)
    assert held.coords["viscous.c"] == pytest.approx(0.02, rel=1e-3) and math.sqrt(held.sse / n) > 3 * noise
    assert got.sse < held.sse


def test_side_by_side_hands_a_closure_to_forked_workers_and_keeps_the_order(monkeypatch):
    """``side_by_side``: each item in a forked process (a closure over the caller's state needs no pickling; its
    results come back in the items' order), the same results in threads (``HYBRIDHYST_WORKERS=threads``)."""
    import multiprocessing
    import os

    from hybridhyst.discover.fitting import side_by_side

    monkeypatch.delenv("HYBRIDHYST_WORKERS", raising=False)
    offset = {"value": 10}  # a closure's state: a forked worker holds it as the caller did

    def job(i):
        return i * i + offset["value"], os.getpid()

    in_processes = side_by_side(job, range(5), workers=2)
    assert [r for r, _ in in_processes] == [i * i + 10 for i in range(5)]
    if sys.platform == "linux" and not multiprocessing.current_process().daemon:
        assert os.getpid() not in {pid for _, pid in in_processes}
    monkeypatch.setenv("HYBRIDHYST_WORKERS", "threads")
    in_threads = side_by_side(job, range(5), workers=2)
    assert [r for r, _ in in_threads] == [r for r, _ in in_processes]
    assert {pid for _, pid in in_threads} == {os.getpid()}


def _polish_or_swap(alt):
    """A stand-in for ``simplify``'s refit: a removal polishes its reduced model in place (what ``polish`` does);
    a swap reports the value of the model it starts from."""
    from types import SimpleNamespace

    _, _, reduced, cand, _ = alt
    if cand is None:
        reduced["value"] = 42.0
        return SimpleNamespace(model=reduced)
    return SimpleNamespace(model=None, started_at=reduced["value"])



@pytest.mark.parametrize("kind", ["processes", "threads"])
def test_a_swap_starts_from_its_removals_refit_for_any_number_of_workers(kind, monkeypatch):
    """``refit_alternatives``: one after another, an effect's swaps start from the reduced model its removal has
    just polished; side by side (in processes, whose changes stay there, or in threads, which would race) they
    must too, and an effect whose removal is not tried is swapped from its reduced model as it is."""
    from hybridhyst.discover.selection import refit_alternatives

    monkeypatch.setenv("HYBRIDHYST_WORKERS", kind)

    def alternatives():
        a, b = {"value": 1.0}, {"value": 2.0}
        return [("a", (), a, None, None), ("a", ("x",), a, "cand", "special_case"),
                ("a", ("y",), a, "cand", "rival_swap"), ("b", ("x",), b, "cand", "rival_swap")]

    one = refit_alternatives(_polish_or_swap, alternatives(), workers=1)
    side = refit_alternatives(_polish_or_swap, alternatives(), workers=2)
    assert [getattr(f, "started_at", None) for f in one] == [None, 42.0, 42.0, 2.0]
    assert [getattr(f, "started_at", None) for f in side] == [None, 42.0, 42.0, 2.0]


def test_workers_are_threads_where_a_forked_child_could_not_run_autograd(monkeypatch):
    """On a machine with a CUDA device torch refuses autograd in a forked child once the parent has run a backward
    pass (identification does); the fits' Jacobians need it, so the workers are threads there."""
    import os

    from hybridhyst.discover.fitting import side_by_side

    if sys.platform == "linux":  # processes here (CPU only)
        assert set(side_by_side(lambda _: os.getpid(), range(4), 2)) != {os.getpid()}
    monkeypatch.setattr("torch.cuda.is_available", lambda: True)
    assert set(side_by_side(lambda _: os.getpid(), range(4), 2)) == {os.getpid()}
