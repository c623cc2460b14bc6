"""The one acceptance rule (``discover.rule.Acceptance``), the noise estimate it uses when the user gives none
(``analysis.noise``) and the line the loop writes when its two out-of-sample errors disagree."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hybridhyst.analysis.noise import noise_sd
from hybridhyst.discover.result import disagreement_line
from hybridhyst.discover.rule import Acceptance, Judged
from hybridhyst.discover.validation import Score


def _rule(noise=None):
    return Acceptance(margin=0.02, criterion="bic", n=1000, noise=noise)


def test_an_addition_needs_the_margin_and_the_criterion():
    rule = _rule()
    assert rule.adds(Judged(0.95, 9.0), Judged(1.0, 10.0))
    assert not rule.adds(Judged(0.99, 9.0), Judged(1.0, 10.0))  # 1 % < the 2 % margin
    assert not rule.adds(Judged(0.90, 11.0), Judged(1.0, 10.0))  # the criterion rose


def test_near_the_noise_an_addition_must_remove_more_than_half_a_noise_variance():
    """At 1.05 σ a flexible term that reaches 1.02 σ passes a 2 % margin but removes 0.06 σ² of mean squared
    error: within the noise, refused. Far above the noise the margin decides as before."""
    rule = _rule(noise=1.0)
    assert rule.floor == pytest.approx(0.5)
    assert _rule().adds(Judged(1.02, 9.0), Judged(1.05, 10.0))  # the margin alone takes it
    assert not rule.adds(Judged(1.02, 9.0), Judged(1.05, 10.0))
    assert rule.adds(Judged(2.9, 9.0), Judged(3.0, 10.0))  # 0.59 σ² removed and 3.3 % > margin
    assert not rule.adds(Judged(2.95, 9.0), Judged(3.0, 10.0))  # 1.7 %: the margin refuses
    assert rule.adds(Judged(1.0, 9.0), Judged(1.5, 10.0))  # a real effect near the noise: 1.25 σ² removed


def test_a_refusal_names_each_requirement_the_addition_failed_and_only_those():
    rule = _rule(noise=1.0)
    # a 2.9 % fall passes the margin, but 0.06 σ² removed is within the noise: only that is named
    within = rule.refusal(Judged(1.02, 9.0), Judged(1.05, 10.0))
    assert len(within) == 1 and "noise variance" in within[0] and "margin" not in within[0]
    assert [("margin" in w, "criterion" in w) for w in rule.refusal(Judged(2.95, 11.0), Judged(3.0, 10.0))] == [
        (True, False), (False, False), (False, True)]  # 1.7 %, 0.30 σ², the criterion rose: all three
    assert rule.refusal(Judged(1.0, 9.0), Judged(1.5, 10.0)) == []  # accepted: nothing to name
    # an error that rose fails the margin; it is not "within the noise", with a noise level or without one
    assert [("margin" in w) for w in rule.refusal(Judged(1.1, 9.0), Judged(1.0, 10.0))] == [True]
    assert [("margin" in w) for w in _rule().refusal(Judged(1.1, 11.0), Judged(1.0, 10.0))] == [True, False]
    assert _rule().refusal(Judged(0.99, 9.0), Judged(1.0, 10.0)) == [
        "the judged RMSE did not fall by more than the margin (2%)"]  # no noise level: no noise clause


def test_the_summary_says_why_the_candidate_that_stopped_the_loop_was_refused():
    from hybridhyst.cli.discover import summary_lines

    why = _rule(noise=1.0).refusal(Judged(1.02, 9.0), Judged(1.05, 10.0))
    report = {"steps": [], "removed": [], "before": {}, "after": {},
              "rejected": [{"effect": "lugre", "kind": "effect", "accepted": False, "refused_by": why}]}
    first = summary_lines(report, "N", "run")[0]
    assert first == f"discovery: added nothing; best remaining candidate not accepted: lugre ({why[0]})"


def test_a_simpler_model_within_the_noise_replaces_the_richer_one():
    rule = _rule(noise=1.0)
    assert rule.simpler(Judged(1.2, 9.0), Judged(1.0, 10.0))  # 0.44 σ² more: within the noise
    assert not _rule().simpler(Judged(1.2, 9.0), Judged(1.0, 10.0))  # 20 % more than half the margin
    assert not rule.simpler(Judged(1.3, 9.0), Judged(1.0, 10.0))  # 0.69 σ² more
    assert not rule.simpler(Judged(1.0, 11.0), Judged(1.0, 10.0))  # the criterion must fall


def test_a_pick_within_the_noise_takes_the_fewer_parameters():
    options = [Judged(1.0, 10.0), Judged(1.1, 5.0), Judged(1.5, 1.0)]
    assert _rule().pick(options) == 0  # 10 % apart: validation tells them apart
    assert _rule(noise=1.0).pick(options) == 1  # 0.21 σ² apart: tied, the lower criterion wins; 1.5 is not tied


def test_every_part_of_a_score_must_gain():
    rule = _rule(noise=1.0)
    old = Judged(Score({"records": 2.0, "loco": 2.0}), 10.0)
    assert rule.adds(Judged(Score({"records": 1.5, "loco": 1.5}), 9.0), old)
    assert not rule.adds(Judged(Score({"records": 1.5, "loco": 1.95}), 9.0), old)  # loco: 0.2 σ² only


def test_noise_is_estimated_from_second_differences():
    rng = np.random.default_rng(0)
    t = np.arange(0, 4, 1 / 200)
    y = 2 * np.sin(2 * np.pi * t) + 0.4 * np.sign(np.cos(2 * np.pi * t))  # a sine and friction jumps
    est = noise_sd([y + 0.03 * rng.standard_normal(len(t)), y[::2] + 0.03 * rng.standard_normal(len(t[::2]))])
    assert est == pytest.approx(0.03, rel=0.1)
    e = np.zeros(len(t))  # AR(1) with φ = 0.9: biased low by √(1 − 4φ/3 + φ²/3) = 0.26, as documented
    w = rng.standard_normal(len(t))
    for k in range(1, len(t)):
        e[k] = 0.9 * e[k - 1] + math.sqrt(1 - 0.81) * w[k]
    assert noise_sd([y + 0.03 * e]) < 0.5 * 0.03
    assert noise_sd([np.ones(5)]) is None


def test_the_disagreement_line_names_both_errors_and_their_direction():
    step = {"effect": "lugre", "evidence": {"val_rmse_before": 0.40, "val_rmse_after": 0.35},
            "cross_check": {"kind": "loco", "before": 0.45, "after": 0.52, "disagrees": True}}
    line = disagreement_line(step, "kip")
    assert line.startswith("step lugre:") and "validation records' RMSE fell 12.5 % (0.4 -> 0.35 kip)" in line
    assert "leave-one-condition-out RMSE of the training operating points rose (0.45 -> 0.52 kip)" in line
    short = disagreement_line({**step, "cross_check": {**step["cross_check"], "after": 0.445}}, "kip")
    assert "operating points fell only 1.1 %, less than the margin, (0.45 -> 0.445 kip)" in short
    assert disagreement_line({**step, "cross_check": {**step["cross_check"], "disagrees": False}}) is None
    assert disagreement_line({"effect": "x", "evidence": {}}) is None

    from hybridhyst.cli.discover import summary_lines

    report = {"steps": [{**step, "kind": "effect", "accepted": True}], "removed": [], "rejected": [],
              "before": {"test_rmse": 0.3}, "after": {"test_rmse": 0.4}, "validation": {"kind": "records"}}
    assert any("step lugre:" in s and "rose" in s for s in summary_lines(report, "kip", "/tmp/run"))


def test_a_pick_prefers_a_close_option_the_rule_would_accept():
    """Two finalists within the noise of each other: the simpler one (lower criterion) would be refused as a step,
    the better one accepted; the pick must not stop the loop by choosing the refused one."""
    rule = Acceptance(0.02, "bic", 1000, noise=1.0)
    options = [Judged(1.00, 10.0), Judged(1.001, 5.0)]
    assert rule.pick(options) == 1
    assert rule.pick(options, accepted=lambda i: i == 0) == 0
    assert rule.pick(options, accepted=lambda i: False) == 1  # none would pass: the plain pick


def test_a_step_judges_the_candidates_ranked_below_the_top_only_when_none_of_it_passes():
    """A flexible element ranked first on the training records fails on validation; the effect the data hold,
    ranked fourth, passes: the step takes it. The options below the top are judged only when needed, and where
    none of them passes either the top's pick is the refused step."""
    rule, now = _rule(), Judged(1.0, 10.0)
    top = [Judged(1.10, 5.0), Judged(1.00, 6.0), Judged(1.05, 7.0)]  # none falls by the margin
    below = [Judged(0.99, 8.0), Judged(0.90, 9.0), Judged(0.80, 9.5), Judged(0.85, 11.0)]  # 0.99: 1 %, 11: BIC rose
    options = top + below
    calls = []

    def more():
        calls.append(1)
        return below

    def accepted(i):
        return rule.adds(options[i], now)

    assert rule.choose(top, accepted, more) == (5, True) and calls == [1]  # the lowest error of those passing
    assert rule.choose(top, accepted) == (1, False)  # nothing below: the top's pick, refused
    assert rule.choose(top, lambda i: i < 3 and accepted(i), more) == (1, False)  # none below passes
    passing_top = [Judged(0.9, 5.0)] + top[1:]
    calls.clear()
    assert rule.choose(passing_top, lambda i: rule.adds(passing_top[i], now), more) == (0, True) and calls == []
