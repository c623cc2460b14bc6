"""The independent discovery test bed (hybridhyst/testbed): generators against known solutions, the case
list, the scoring, one small case end to end, and (slow) the whole bed against its pass criteria."""

from __future__ import annotations

import ast
import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from hybridhyst.testbed import generators as g

GENERATORS = Path(g.__file__)


# -- (a) the generators share no code with the library ------------------------------------------------------


def test_generators_import_nothing_from_hybridhyst():
    tree = ast.parse(GENERATORS.read_text())
    modules = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"relative import (from {'.' * node.level}{node.module or ''}) in generators.py"
            modules.append(node.module or "")
    roots = {m.split(".")[0] for m in modules}
    assert "hybridhyst" not in roots
    assert roots <= {"__future__", "math", "collections", "dataclasses", "typing", "numpy", "scipy"}, roots


# -- (b) generators against known solutions --------------------------------------------------------------------


class Ramp:
    """x = v0 t (a constant-velocity signal with the Sines interface)."""

    def __init__(self, v0):
        self.v0 = v0

    def x(self, t):
        return self.v0 * np.asarray(t, float)

    def v(self, t):
        return np.full_like(np.asarray(t, float), self.v0)

    def a(self, t):
        return np.zeros_like(np.asarray(t, float))


def test_play_on_a_ramp_has_a_dead_band_of_width_2r():
    r = 0.1
    up = np.linspace(0.0, 1.0, 10001)
    x = np.r_[up, up[::-1][1:]]  # 0 → 1 → 0
    y = g.play(x, r)
    yu = y[:10001]
    assert np.all(yu[up <= r] == 0.0)  # centred on x(0): still until the gap closes
    np.testing.assert_allclose(yu[up >= r], up[up >= r] - r, atol=1e-12)
    down = x[10001:]
    yd = y[10001:]
    held = np.abs(yd - (1.0 - r)) < 1e-12
    travel = 1.0 - down[held].min()
    assert travel == pytest.approx(2 * r, abs=2e-4)  # dead band of width 2r after the reversal
    np.testing.assert_allclose(yd[down <= 1 - 2 * r], down[down <= 1 - 2 * r] + r, atol=1e-12)


def test_play_on_a_sine_and_its_rate():
    r, A = 0.2, 1.0
    t = g.fine_grid(np.linspace(0, 2, 401), 20)
    sig = g.sine(A, 1.0)
    x, v = sig.x(t), sig.v(t)
    y = g.play(x, r)
    assert np.max(np.abs(x - y)) <= r + 1e-12
    assert y.max() == pytest.approx(A - r, abs=1e-6) and y.min() == pytest.approx(-A + r, abs=1e-6)
    # after the first maximum, y holds at A − r until x has come down by 2r
    k = np.argmax(x[t < 0.5])
    after = slice(k, k + np.argmax(x[k:] <= A - 2 * r - 1e-3) + 1)
    assert np.ptp(y[after][:-2]) < 1e-9
    dy = g.play_rate(x, v, y, r)
    from scipy.integrate import cumulative_trapezoid

    np.testing.assert_allclose(cumulative_trapezoid(dy, t, initial=0.0), y - y[0], atol=5e-3)  # ẏ integrates to y
    assert np.all(dy[after][1:-2] == 0.0)


def test_dahl_exact_virgin_curve_and_steady_sliding():
    sigma0, Fc = 8.0, 0.6
    x = np.linspace(0, 1.0, 11)  # coarse on purpose: the step is exact
    F = sigma0 * g.dahl_exact(x, sigma0, Fc)
    np.testing.assert_allclose(F, Fc * (1 - np.exp(-sigma0 * x / Fc)), rtol=1e-12, atol=1e-15)
    back = np.r_[x, x[::-1][1:] - 1.0, np.linspace(-1.0, -3.0, 50)]
    assert sigma0 * g.dahl_exact(back, sigma0, Fc)[-1] == pytest.approx(-Fc, rel=1e-9)


def test_clearance_dahl_plateau_and_levels():
    """Hand-checked shape on 0 → A → −A: no force until x = r, then Dahl's virgin curve shifted by r up to
    Fc_pos; after the reversal Dahl's unloading towards −Fc_neg until the force is 0 (a travel
    d₀ = ℓ₋ ln(1 + Fc_pos / Fc_neg), ℓ₋ = Fc_neg / σ0), exactly 0 over a travel of 2r (the gap), then the
    virgin curve down to −Fc_neg. Exact per step: a coarse path gives the fine path's values."""
    r, sigma0, Fc_pos, Fc_neg, A = 0.06, 15.0, 0.5, 0.7, 1.0
    lp, ln_ = Fc_pos / sigma0, Fc_neg / sigma0
    up = np.linspace(0.0, A, 20001)
    down = np.linspace(A, -A, 40001)[1:]
    x = np.r_[up, down]
    F = g.clearance_dahl(x, r, sigma0, Fc_pos, Fc_neg)
    Fu, Fd = F[: len(up)], F[len(up):]
    assert np.all(Fu[up <= r] == 0.0)  # the gap starts centred
    np.testing.assert_allclose(Fu[up > r], Fc_pos * (1 - np.exp(-(up[up > r] - r) / lp)), rtol=1e-12, atol=1e-14)
    assert Fu[-1] == pytest.approx(Fc_pos, rel=1e-9)  # saturated before the reversal
    d = A - down  # travel since the reversal
    d0 = ln_ * math.log(1 + Fc_pos / Fc_neg)
    assert d0 == pytest.approx(0.02515, abs=1e-5)  # by hand: (0.7/15) ln(12/7) = 0.04667 × 0.5390
    unload = d < d0
    np.testing.assert_allclose(Fd[unload], sigma0 * (-ln_ + (Fu[-1] / sigma0 + ln_) * np.exp(-d[unload] / ln_)),
                               rtol=1e-10, atol=1e-13)
    assert np.all(Fd[unload] > 0)
    gap = (d >= d0 + 1e-9) & (d <= d0 + 2 * r - 1e-9)
    assert np.all(Fd[gap] == 0.0)  # exactly no force while the input crosses the gap
    assert np.count_nonzero(Fd == 0.0) == pytest.approx(2 * r / (2 * A / 40000), abs=2)  # plateau width 2r
    after = d > d0 + 2 * r
    np.testing.assert_allclose(Fd[after], -Fc_neg * (1 - np.exp(-(d[after] - d0 - 2 * r) / ln_)), rtol=1e-9,
                               atol=1e-12)
    assert Fd[-1] == pytest.approx(-Fc_neg, rel=1e-9)
    coarse = np.r_[np.linspace(0, A, 21), np.linspace(A, -A, 41)[1:]]  # every 1000th / 1000th point of x
    np.testing.assert_allclose(g.clearance_dahl(coarse, r, sigma0, Fc_pos, Fc_neg), F[::1000], rtol=1e-9,
                               atol=1e-12)
    # r = 0 and equal levels is Dahl
    y = g.sine(0.8, 1.0).x(np.linspace(0, 2, 2001))
    np.testing.assert_allclose(g.clearance_dahl(y, 0.0, 8.0, 0.6, 0.6), 8.0 * g.dahl_exact(y, 8.0, 0.6), rtol=1e-10,
                               atol=1e-13)

def test_dahl_exact_matches_an_ode_solver():
    sigma0, Fc = 10.0, 0.5
    t = np.linspace(0, 2, 2001)
    sig = g.sine(0.8, 1.0)

    def rhs(tt, z):
        v = float(sig.v(np.array([tt]))[0])
        return np.array([v - sigma0 * abs(v) * z[0] / Fc])

    z_ode = g.integrate(rhs, t, [0.0], method="LSODA", refine=2)[:, 0]
    z_exact = g.dahl_exact(sig.x(t), sigma0, Fc)
    assert np.max(np.abs(z_ode - z_exact)) * sigma0 < 2e-3 * Fc


def test_lugre_steady_sliding_level():
    p = dict(sigma0=30.0, sigma1=0.2, sigma2=0.05, Fc=0.4, Fs=0.8, vs=1.0)
    for v0 in (0.3, 1.0, 3.0):
        t = np.linspace(0, 2.0 / v0, 201)
        F = g.lugre(t, Ramp(v0), **p)
        level = g.stribeck_curve(v0, p["Fc"], p["Fs"], p["vs"]) + p["sigma2"] * v0
        assert F[-1] == pytest.approx(level, rel=1e-6)
    assert float(g.stribeck_curve(0.0, 0.4, 0.8, 1.0)) == pytest.approx(0.8)


@pytest.mark.parametrize("n, envelope", [(1.0, lambda s: 1 - np.exp(-s)), (2.0, np.tanh)])
def test_bouc_wen_envelope(n, envelope):
    Fy, xy = 0.8, 0.25
    t = np.linspace(0, 1.0, 101)
    F = g.bouc_wen_yield(t, Ramp(1.0), Fy, xy, n, b=0.5)
    np.testing.assert_allclose(F, Fy * envelope(t / xy), atol=1e-6)


def test_integrators_converge_on_a_damped_oscillator():
    wn, zeta = 2 * np.pi, 0.1
    wd = wn * np.sqrt(1 - zeta**2)
    t = np.linspace(0, 3, 61)
    exact = np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))

    def rhs(tt, s):
        return np.array([s[1], -2 * zeta * wn * s[1] - wn**2 * s[0]])

    errors = [np.max(np.abs(g.heun(rhs, t, [1.0, 0.0], refine=m)[:, 0] - exact)) for m in (2, 4, 8, 16)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 3.5) and np.all(ratios < 4.5), ratios  # second order as the grid refines
    for method in ("DOP853", "LSODA", "Radau"):
        y = g.integrate(rhs, t, [1.0, 0.0], method=method, rtol=1e-10, atol=1e-12)[:, 0]
        assert np.max(np.abs(y - exact)) < 1e-7, method


def test_oscillator_steady_state_amplitude():
    m, c, k, f = 0.005, 0.2, 2.0, 2.0  # heavily damped: the transient is gone after a few cycles
    w = 2 * np.pi * f
    t = np.linspace(0, 3, 601)
    x = g.oscillator(t, g.sine(1.0, f), m, c, k)
    amplitude = 1.0 / np.hypot(k - m * w**2, c * w)
    assert np.max(np.abs(x[t > 2])) == pytest.approx(amplitude, rel=1e-4)


def test_linear_lag_and_maxwell_exact():
    t = np.linspace(0, 1, 11)  # coarse: the exponential integrator is exact for piecewise-linear input
    lam = 5.0
    np.testing.assert_allclose(g.linear_lag(t, np.ones_like(t), lam), (1 - np.exp(-lam * t)) / lam, rtol=1e-12)
    u = 2 * t
    exact = 2 * (t / lam - (1 - np.exp(-lam * t)) / lam**2)
    np.testing.assert_allclose(g.linear_lag(t, u, lam), exact, rtol=1e-10, atol=1e-14)
    km, cm, v0 = 2.0, 0.2, 0.5
    F = g.maxwell_force(t, np.full_like(t, v0), km, cm)
    np.testing.assert_allclose(F, cm * v0 * (1 - np.exp(-km * t / cm)), rtol=1e-12)


def test_signals_and_signs():
    t = np.linspace(-0.5, 3, 3501)
    sig = g.multisine(0.5, [0.5, 1.0, 1.5], seed=3, fade=0.4)
    x, v, a = sig.x(t), sig.v(t), sig.a(t)
    np.testing.assert_allclose(v[1:-1], np.gradient(x, t)[1:-1], atol=2e-3)
    np.testing.assert_allclose(a[1:-1], np.gradient(v, t)[1:-1], atol=0.1)
    before = t <= 0
    assert np.all(x[before] == 0) and np.all(v[before] == 0) and np.all(a[before] == 0)  # at rest before 0
    rest = g.sine(1.0, 1.0, phase=-np.pi / 2)
    assert rest.x(np.array([-1.0, 0.0]))[0] == -1.0 and rest.v(np.array([0.0]))[0] == pytest.approx(0, abs=1e-12)
    assert g.cumulative_travel(g.sine(0.7, 1.0).x(np.linspace(0, 1, 4001)))[-1] == pytest.approx(4 * 0.7, rel=1e-6)
    tf = g.fine_grid(np.array([0.0, 0.1, 0.3]), 4)
    np.testing.assert_allclose(tf[::4], [0.0, 0.1, 0.3])
    vv = np.array([-1.0, -1e-3, 0.0, 1e-3, 1.0])
    assert list(g.sgn(vv)) == [-1, -1, 0, 1, 1]
    for kind in ("arctan", "erf", "algebraic"):
        s = g.sgn(vv, kind, 1e-4)
        np.testing.assert_allclose(s, -s[::-1])
        assert s[2] == 0 and abs(s[-1] - 1) < 1e-3
    with pytest.raises(ValueError):
        g.sgn(vv, "tanh", 0.1)


def test_noise_sd_and_lag1_correlation():
    rng = np.random.default_rng(0)
    w = g.white_noise(200_000, 0.03, rng)
    assert w.std() == pytest.approx(0.03, rel=0.01)
    for phi in (0.5, 0.9):
        e = g.ar1_noise(200_000, 0.03, phi, rng)
        assert e.std() == pytest.approx(0.03, rel=0.03)
        assert np.corrcoef(e[:-1], e[1:])[0, 1] == pytest.approx(phi, abs=0.01)
    with pytest.raises(ValueError):
        g.ar1_noise(10, 0.1, 1.0, rng)


# -- (c) the case list ---------------------------------------------------------------------------------------------


FAMILIES = {"viscous", "coulomb", "asymmetric_coulomb", "stribeck", "linear_stiffness", "cubic_stiffness", "bouc_wen",
            "dahl", "lugre", "backlash", "inertia", "attenuation", "time_delay", "travel_drift", "maxwell", "clearance"}


def test_case_list_sanity():
    from hybridhyst.physics.effects import EFFECTS
    from hybridhyst.testbed.cases import CASES, CATEGORIES

    assert len(CASES) >= 24
    assert len({c.name for c in CASES}) == len(CASES)
    counts = Counter(c.category for c in CASES)
    assert set(counts) <= set(CATEGORIES)
    assert counts["single"] >= 16 and counts["pair"] >= 4 and counts["condition"] >= 3 and counts["clean"] >= 3
    assert counts["out_of_library"] >= 2
    singles = [c for c in CASES if c.category == "single"]
    assert FAMILIES <= {n for c in singles for fam in c.expected for n in fam}
    for c in CASES:
        assert all(name in EFFECTS for fam in c.expected for name in fam), c.name
        if c.category in ("single", "pair", "condition"):
            assert len(c.expected) == (2 if c.category == "pair" else 1), c.name
            assert c.keys, c.name
            for coord, truth, tol in c.keys:
                effect = coord.split(".")[0]
                if effect.startswith("lag_"):  # discover's key of a control's lag: lag_<control>
                    effect = "control_lag"
                assert any(effect in fam for fam in c.expected), (c.name, coord)
                assert math.isfinite(truth) and truth != 0 and 0 < tol < 1
        else:
            assert not c.expected and not c.keys, c.name
        assert c.noise > 0
        assert set(c.split) <= {"held_out", "val"} and c.split.get("held_out") and c.split.get("val")


def test_case_data_nominal_and_split():
    import torch

    from hybridhyst.testbed.cases import CASES

    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    try:
        for c in CASES:
            records = c.records()
            train, val, test = records.split(held_out=c.split["held_out"], val=c.split["val"])
            assert len(train) >= 2 and len(val) >= 1 and len(test) >= 1, c.name
            assert 4 <= len(records) <= 9, c.name
            for r in records:
                assert np.all(np.isfinite(r.y)) and len(r) >= 60, (c.name, r.name)
            nominal = c.nominal()
            present = {e.name for e in nominal.effects.values()}
            assert not present & {n for fam in c.expected for n in fam}, c.name  # the extra effect is missing
            if c.category == "condition" and records.records[0].controls:  # the condition varies in every record
                for r in records:
                    assert r.controls and all(np.ptp(v) > 0 for v in r.controls.values()), (c.name, r.name)
            elif c.category == "condition":  # every record at a level of the condition the split holds out
                (condition,) = c.split["held_out"]
                assert len({r.conditions[condition] for r in records}) >= 6, c.name
    finally:
        torch.set_default_dtype(old)


# -- scoring --------------------------------------------------------------------------------------------------------


def _report(named, params=None, trends=(), flagged=None, after=0.031):
    ev = {"val_rmse_before": 0.1, "val_rmse_after": 0.05}
    steps = [{"effect": n, "kind": "effect", "new_coordinates": {}, "evidence": ev} for n in named]
    steps += [{"effect": n, "kind": "condition", "new_coordinates": {}, "evidence": ev} for n in trends]
    unexplained = {} if flagged is None else {"structure_flagged": flagged}
    return {"before": {"test_rmse": 1.0}, "after": {"test_rmse": after, "parameters": params or {}},
            "steps": steps, "effects": {"added": list(named), "dropped": []}, "unexplained": unexplained}


def test_score_rules():
    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import markdown, score, summary

    pair = CASE_BY_NAME["backlash+coulomb"]
    row = score(pair, _report(["backlash", "asymmetric_coulomb"],
                              {"backlash.r": {"value": 0.081}, "asymmetric_coulomb.Fc": {"value": 0.41}}), 1.0)
    assert row["found"] and not row["wrong"] and row["ok_effect"] and row["ok_param"] and row["ok_rmse"] and row["ok"]
    assert row["keys"][1]["found_as"] == "asymmetric_coulomb.Fc"  # the alias carries the key parameter
    row = score(pair, _report(["backlash", "dahl"], {"backlash.r": {"value": 0.08}}), 1.0)
    assert not row["found"] and row["wrong"] == ["dahl"] and not row["ok_effect"]
    clean = CASE_BY_NAME["clean_friction"]
    assert score(clean, _report([]), 1.0)["ok"]
    assert not score(clean, _report([], trends=["viscous.c~frequency_hz"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], after=0.05), 1.0)["ok_rmse"]
    ool = CASE_BY_NAME["cogging"]
    assert not score(ool, _report([]), 1.0)["ok"]  # not flagged (a missing key counts as False)
    assert score(ool, _report([], flagged=True), 1.0)["ok"]
    rows = [score(pair, _report(["backlash", "coulomb"]), 2.0), score(clean, _report([]), 3.0)]
    s = summary(rows)
    assert s["effect_share"] == 1.0 and s["clean_ok"] == 1 and s["wall_s"] == 5.0
    text = markdown(rows)
    assert "| backlash+coulomb | pair |" in text and "Pass criteria" in text
    # two members of one family for one effect: the second is an effect the data lack
    row = score(pair, _report(["backlash", "coulomb", "asymmetric_coulomb"]), 1.0)
    assert row["found"] and row["wrong"] == ["asymmetric_coulomb"] and not row["ok_effect"]


def test_blind_bed_cases_are_scored_by_the_library_families_of_their_effect_words():
    """The blind bed (``testbed/blind.py``, written without the library): every case builds records, a nominal of
    its declared base law that simulates, and a split; an effect the library has a family for is scored as an
    effect case, one it lacks as out of library, no effect as a clean control."""
    import torch

    from hybridhyst.simulate import simulate
    from hybridhyst.testbed import blind
    from hybridhyst.testbed.blind_cases import BLIND_CASES, family

    assert len(BLIND_CASES) >= 16
    by = {c.name: c for c in BLIND_CASES}
    assert by["clean_symmetric_damper"].category == "clean"
    assert by["play_friction_damper"].expected == (frozenset({"backlash", "clearance"}),)
    assert by["asymmetric_friction_drift_damper"].category == "pair"
    assert by["asymmetric_viscous_damper"].category == "out_of_library"  # no direction-dependent damping
    assert by["cogging_rotary_damper"].category == "out_of_library"
    assert by["clean_pressure_cubic_damper"].trends_ok == ("pressure_kpa",)
    assert not by["clean_symmetric_damper"].trends_ok
    from hybridhyst.testbed.run import score

    clean = by["clean_pressure_cubic_damper"]
    assert score(clean, _report([], trends=["trends~pressure_kpa"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], trends=["spring.k~amplitude"]), 1.0)["ok_effect"]
    assert family("asymmetry", blind.case("asymmetric_viscous_damper")) is None
    for case in BLIND_CASES:
        records = case.records()
        train, val, test = records.split(**case.split)
        assert len(train.records) >= 3 and len(test.records) >= 1, case.name
        out = simulate(case.nominal(), [train.records[0]], backend="reference")
        assert bool(torch.isfinite(out[0]).all()), case.name


# -- (e) one small case end to end -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["clean_friction", "linear_stiffness"])
def test_fast_cases_end_to_end_pass(name):
    """The fast subset of the bed in the default run: a clean control (nothing added) and a single effect at
    20 samples per cycle (named, key parameter within tolerance, held-out error at the noise)."""
    import torch

    from hybridhyst.testbed.cases import CASE_BY_NAME, FAST_CASES
    from hybridhyst.testbed.run import markdown, run_case

    assert name in FAST_CASES
    old = torch.get_default_dtype()
    try:
        row = run_case(CASE_BY_NAME[name])
    finally:
        torch.set_default_dtype(old)
    assert row["error"] is None, row["error"]
    assert isinstance(row["named"], list) and all(isinstance(n, str) for n in row["named"])
    assert isinstance(row["trends"], list)
    for key in ("test_rmse_before", "test_rmse_after", "after_over_noise"):
        assert isinstance(row[key], float) and math.isfinite(row[key]) and row[key] > 0, key
    assert row["wall_s"] > 0
    assert isinstance(row["ok"], bool) and isinstance(row["ok_rmse"], bool) and isinstance(row["flagged"], bool)
    assert row["name"] in markdown([row])
    assert row["ok"] and row["ok_rmse"] and row["ok_effect"], row


def test_the_bed_gives_every_case_the_same_discover_options():
    """``run_case(case, options)`` passes the options to discover (here one it refuses: the row says so)."""
    import torch

    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import run_case

    old = torch.get_default_dtype()
    try:
        row = run_case(CASE_BY_NAME["clean_friction"], {"validation": "lofo"})
    finally:
        torch.set_default_dtype(old)
    assert "unknown validation 'lofo'" in row["error"] and not row["ok"]


# -- (d) the whole bed against its targets ----------------------------------------------------------------------------


@pytest.mark.slow
def test_whole_bed_meets_the_pass_criteria():
    from hybridhyst.testbed.cases import CASES
    from hybridhyst.testbed.run import TARGETS, markdown, run_bed, summary

    rows = run_bed(CASES, jobs=2, progress=False)
    s = summary(rows)
    table = markdown(rows)
    assert not s["errors"], table
    assert s["effect_share"] >= TARGETS["effect_share"], table
    assert s["rmse_share"] >= TARGETS["rmse_share"], table
    assert s["clean_ok"] == s["clean_cases"], table
    assert s["ool_ok"] == s["ool_cases"], table
