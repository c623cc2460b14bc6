"""Tests of the independent blind-test-bed generators (hybridhyst/testbed/blind.py).

Structure and noise of every case, plus known-solution checks of every operator
and integrator the generators use.
"""

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hybridhyst.testbed import blind

TWO_PI = 2.0 * math.pi
EFFECT_WORDS = {
    "play",
    "stribeck",
    "travel_stiffness",
    "travel_friction",
    "drift",
    "asymmetry",
    "relaxation",
    "hysteretic",
    "outside",
}
CASE_FNS = list(blind.CASES)
CASE_IDS = [fn.__name__ for fn in CASE_FNS]


def _cat(case, key="y"):
    return np.concatenate([r[key] for r in case.records])


# =============================================================================
# Module hygiene
# =============================================================================


def test_blind_imports_only_numpy_scipy_stdlib():
    src = Path(blind.__file__).read_text()
    tree = ast.parse(src)
    allowed = {"numpy", "scipy", "math", "dataclasses", "typing"}
    seen = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                seen.add(a.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "relative import in blind.py"
            seen.add((node.module or "").split(".")[0])
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            assert node.func.id not in {"__import__", "exec", "eval"}
    assert seen <= allowed, seen - allowed
    assert "hybridhyst" not in src.replace("hybridhyst/testbed/blind.py", "")


def test_case_catalogue_coverage():
    assert len(CASE_FNS) >= 18
    assert len(set(CASE_IDS)) == len(CASE_IDS)
    counts = {w: 0 for w in EFFECT_WORDS}
    clean, two, cond_cases, clean_sym_damper = 0, 0, 0, False
    for fn in CASE_FNS:
        c = fn(noise=False)
        for e in c.effects:
            counts[e] += 1
        if not c.effects:
            clean += 1
            if c.kind == "damper" and "amplitude" in c.records[0]["conditions"]:
                clean_sym_damper = True
        if len(c.effects) >= 2:
            two += 1
        if "amplitude" not in c.records[0]["conditions"]:
            cond_cases += 1
    need = {
        "play": 2,
        "stribeck": 2,
        "travel_stiffness": 1,
        "travel_friction": 1,
        "drift": 1,
        "asymmetry": 2,
        "relaxation": 2,
        "hysteretic": 2,
        "outside": 2,
    }
    for w, n in need.items():
        assert counts[w] >= n, (w, counts[w])
    assert clean >= 3 and two >= 2 and cond_cases >= 3 and clean_sym_damper


def test_case_lookup():
    c = blind.case("play_friction_damper", noise=False)
    assert c.name == "play_friction_damper"
    with pytest.raises(KeyError):
        blind.case("no_such_case")
    with pytest.raises(ValueError):
        blind.case("play_friction_damper", nominal="drift")


# =============================================================================
# Every case: structure
# =============================================================================


@pytest.mark.parametrize("fn", CASE_FNS, ids=CASE_IDS)
def test_case_structure(fn):
    c = fn()
    assert isinstance(c, blind.BlindCase)
    assert c.name == fn.__name__
    assert isinstance(c.effects, tuple) and set(c.effects) <= EFFECT_WORDS
    assert c.effects == fn.effects
    assert c.kind in ("damper", "oscillator")
    if c.kind == "damper":
        allowed = {"spring", "viscous", "coulomb", "cubic"}
        terms = [s.strip() for s in c.base_law.split("+")]
        assert terms and set(terms) <= allowed, c.base_law
    else:
        assert c.base_law.startswith("oscillator(") and c.base_law.endswith(")")
        terms = {s.strip() for s in c.base_law[len("oscillator(") : -1].split(",")}
        assert {"mass", "viscous", "spring"} <= terms <= {"mass", "viscous", "spring", "cubic", "coulomb"}
    assert set(c.units) == {"x", "y", "t"} and c.units["t"] == "s"
    assert c.noise_sd > 0
    assert len(c.description) > 200
    assert 4 <= len(c.records) <= 9
    names = [r["name"] for r in c.records]
    assert len(set(names)) == len(names)
    cond_names = set(c.records[0]["conditions"])
    assert cond_names in ({"amplitude", "frequency_hz"}, {"pressure_kpa"}, {"current_a"})
    total = 0
    for r in c.records:
        assert set(r) == {"name", "t", "x", "y", "conditions"}
        t, x, y = r["t"], r["x"], r["y"]
        assert t.ndim == x.ndim == y.ndim == 1
        assert len(t) == len(x) == len(y) >= 100
        assert np.all(np.isfinite(t)) and np.all(np.isfinite(x)) and np.all(np.isfinite(y))
        assert np.all(np.diff(t) > 0) and t[0] == 0.0
        assert set(r["conditions"]) == cond_names
        assert all(isinstance(v, float) for v in r["conditions"].values())
        total += len(t)
    assert total <= 20000
    assert c.held_out and set(c.held_out) <= set(names)
    assert 1 <= len(c.validation) <= 2 and set(c.validation) <= set(names)
    assert not set(c.validation) & set(c.held_out)
    assert len(set(names) - set(c.held_out) - set(c.validation)) >= 2
    # at least one held-out record is an extrapolation: the largest amplitude /
    # frequency, or the highest condition level
    key = sorted(cond_names)[0] if cond_names != {"amplitude", "frequency_hz"} else None
    if key is not None:
        levels = [r["conditions"][key] for r in c.records]
        assert len(levels) >= 6
        top = max(levels)
        assert any(r["conditions"][key] == top for r in c.records if r["name"] in c.held_out)
    else:
        amax = max(r["conditions"]["amplitude"] for r in c.records)
        fmax = max(r["conditions"]["frequency_hz"] for r in c.records)
        assert any(
            r["conditions"]["amplitude"] == amax or r["conditions"]["frequency_hz"] == fmax
            for r in c.records
            if r["name"] in c.held_out
        )


@pytest.mark.parametrize("fn", CASE_FNS, ids=CASE_IDS)
def test_case_noise_level_and_determinism(fn):
    c = fn()
    c0 = fn(noise=False)
    again = fn()
    for r, r0, ra in zip(c.records, c0.records, again.records):
        assert r["name"] == r0["name"]
        np.testing.assert_array_equal(r["t"], r0["t"])
        np.testing.assert_array_equal(r["x"], r0["x"])
        np.testing.assert_array_equal(r["y"], ra["y"])
    e = _cat(c) - _cat(c0)
    emp = float(np.sqrt(np.mean(e**2)))
    assert abs(emp / c.noise_sd - 1.0) < 0.15, (emp, c.noise_sd)
    # noise not negligible, not overwhelming
    rms = float(np.sqrt(np.mean(_cat(c0) ** 2)))
    assert 0.01 * rms <= c.noise_sd <= 0.05 * rms, (c.noise_sd, rms)
    # returned arrays are copies, not views of the cache
    c.records[0]["y"][:] = 0.0
    assert np.any(fn().records[0]["y"] != 0.0)


@pytest.mark.parametrize("fn", [f for f in CASE_FNS if f.effects], ids=[f.__name__ for f in CASE_FNS if f.effects])
def test_each_effect_is_well_above_noise(fn):
    c0 = fn(noise=False)
    y0 = _cat(c0)
    yn = _cat(fn(noise=False, nominal=True))
    assert np.sqrt(np.mean((y0 - yn) ** 2)) >= 4.0 * c0.noise_sd
    for eff in c0.effects:
        ye = _cat(fn(noise=False, nominal=eff))
        assert np.sqrt(np.mean((y0 - ye) ** 2)) >= 4.0 * c0.noise_sd, eff
    # nominal variant with noise keeps the same noise realisation
    d1 = _cat(fn(nominal=True)) - yn
    d0 = _cat(fn()) - y0
    np.testing.assert_allclose(d1, d0, atol=1e-9 * (1 + np.abs(y0).max()))


def _derivative(x, t):
    """Fourth-order central differences (uniform grid), second order at the ends."""
    h = t[1] - t[0]
    v = np.gradient(x, h, edge_order=2)
    v[2:-2] = (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * h)
    return v


def _damper_regressors(rec, base_law):
    x, t = rec["x"], rec["t"]
    v = _derivative(x, t)
    v[np.abs(v) < 1e-3 * np.abs(v).max()] = 0.0  # turning points
    cols = []
    for term in [s.strip() for s in base_law.split("+")]:
        cols.append({"spring": x, "viscous": v, "coulomb": np.sign(v), "cubic": x**3}[term])
    return np.column_stack(cols), v


def _base_law_fit_residual(c):
    """Least-squares fit of the declared damper base law to the noise-free data:
    one parameter set for all records (amplitude/frequency cases) or one per
    record (condition cases).  Turning-point samples are excluded."""
    pooled = "amplitude" in c.records[0]["conditions"]
    groups = [c.records] if pooled else [[r] for r in c.records]
    res, thetas = [], []
    for g in groups:
        Xs, ys = [], []
        for r in g:
            X, v = _damper_regressors(r, c.base_law)
            keep = v != 0.0
            Xs.append(X[keep])
            ys.append(r["y"][keep])
        X, y = np.vstack(Xs), np.concatenate(ys)
        th, *_ = np.linalg.lstsq(X, y, rcond=None)
        res.append(y - X @ th)
        thetas.append(th)
    res = np.concatenate(res)
    return float(np.sqrt(np.mean(res**2))), thetas


DAMPER_EFFECT_FNS = [f for f in CASE_FNS if f.effects and f(noise=False).kind == "damper"]


@pytest.mark.parametrize("fn", DAMPER_EFFECT_FNS, ids=[f.__name__ for f in DAMPER_EFFECT_FNS])
def test_damper_effects_not_absorbed_by_base_law(fn):
    c = fn(noise=False)
    rms, _ = _base_law_fit_residual(c)
    assert rms >= 4.0 * c.noise_sd, rms / c.noise_sd


def test_clean_symmetric_damper_is_exactly_the_base_law():
    c = blind.clean_symmetric_damper(noise=False)
    rms, (th,) = _base_law_fit_residual(c)
    assert rms < 0.05 * c.noise_sd
    np.testing.assert_allclose(th, [1.8, 0.9, 1.2], rtol=2e-3)
    # symmetric: F(-x, -v) = -F(x, v) over a whole sine cycle
    r = c.records[3]
    n = len(r["t"]) - 1
    half = n // 6  # 3 cycles -> half a cycle
    np.testing.assert_allclose(r["y"][1:half], -r["y"][half + 1 : 2 * half], atol=1e-9)


def test_clean_pressure_damper_parameters_follow_the_stated_laws():
    c = blind.clean_pressure_cubic_damper(noise=False)
    rms, thetas = _base_law_fit_residual(c)
    assert rms < 0.05 * c.noise_sd
    for r, th in zip(c.records, thetas):
        p = r["conditions"]["pressure_kpa"]
        np.testing.assert_allclose(th, [20 + 0.08 * p, 0.6 * math.exp(p / 250.0), 0.03 + 5e-5 * p], rtol=2e-3)


def test_damper_sines_start_from_rest_at_minus_amplitude():
    for fn in CASE_FNS:
        c = fn(noise=False)
        if c.kind != "damper" or "amplitude" not in c.records[0]["conditions"]:
            continue
        for r in c.records:
            if r["name"].startswith("RND"):
                assert abs(r["x"][0]) < 1e-12
                continue
            A = r["conditions"]["amplitude"]
            # starts at its minimum -A (so from rest for these smooth inputs)
            assert r["x"][0] == pytest.approx(-A, rel=1e-12)
            assert np.max(np.abs(r["x"])) <= A * (1 + 1e-12)


def test_oscillators_start_at_rest():
    for fn in CASE_FNS:
        c = fn(noise=False)
        if c.kind != "oscillator":
            continue
        for r in c.records:
            assert r["y"][0] == 0.0 and r["x"][0] == 0.0


# =============================================================================
# Play operator
# =============================================================================


def test_play_dead_band_on_ramp():
    r = 0.5
    h = 1e-3
    up = np.arange(0, 5000 + 1) * h  # 0 -> 5
    down = 5.0 - np.arange(1, 5000 + 1) * h  # -> 0
    up2 = np.arange(1, 5000 + 1) * h  # -> 5
    x = np.concatenate([up, down, up2])
    z = blind.play_operator(x, r, z0=0.0)
    # first rise: z stays 0 until x = r, then follows x - r
    np.testing.assert_allclose(z[:5001], np.maximum(up - r, 0.0), atol=1e-12)
    # down: z holds 4.5 until x = 5 - 2r, then follows x + r
    np.testing.assert_allclose(z[5001:10001], np.minimum(down + r, 5.0 - r), atol=1e-12)
    # the input travel during which the output is frozen after the reversal = 2r
    frozen = np.abs(np.diff(z[5000:10001])) == 0.0
    width = np.sum(frozen) * h
    assert width == pytest.approx(2 * r, abs=1.01 * h)
    np.testing.assert_allclose(z[10001:], np.maximum(up2 - r, 0.0 + r), atol=1e-12)
    # band invariant
    assert np.all(np.abs(x - z) <= r + 1e-12)


def test_play_zero_width_identity_rate_independence_and_refinement():
    t = np.linspace(0, 3, 3001)
    x = np.sin(TWO_PI * t) + 0.3 * np.sin(TWO_PI * 3.7 * t)
    np.testing.assert_array_equal(blind.play_operator(x, 0.0), x)
    z = blind.play_operator(x, 0.2)
    # rate independence: holding the input (repeated samples) changes nothing
    np.testing.assert_array_equal(blind.play_operator(np.repeat(x, 3), 0.2)[::3], z)
    # Lipschitz: |dz| <= |dx|
    assert np.all(np.abs(np.diff(z)) <= np.abs(np.diff(x)) + 1e-12)
    # refinement invariance for a piecewise linear input (turning points on grid)
    knots = np.array([0.0, 1.0, -0.5, 0.8, 0.1, 0.4])
    coarse = np.concatenate([np.linspace(a, b, 11)[:-1] for a, b in zip(knots[:-1], knots[1:])] + [knots[-1:]])
    fine = np.interp(np.linspace(0, len(coarse) - 1, 7 * (len(coarse) - 1) + 1), np.arange(len(coarse)), coarse)
    np.testing.assert_allclose(blind.play_operator(fine, 0.15)[::7], blind.play_operator(coarse, 0.15), atol=1e-14)


def test_play_velocity_on_sine():
    A, f, r = 4.0, 1.0, 0.6
    t, x, v = blind.sine_input(A, f, 2, 2000)
    z = blind.play_operator(x, r, z0=x[0] + r)
    vz = blind.play_velocity(x, z, v, r)
    # after the reversal at x = +A (t = 0.5 s) the element is disengaged until
    # x has come down by 2r: A cos(w t') = A - 2r
    i_rev = 1000
    frozen = vz[i_rev + 1 : 1500] == 0.0
    t_release = math.acos((A - 2 * r) / A) / TWO_PI  # time after the reversal
    n_frozen = np.sum(frozen)
    assert n_frozen * (t[1] - t[0]) == pytest.approx(t_release, abs=2 * (t[1] - t[0]))
    # engaged portions move with the input
    eng = vz != 0
    np.testing.assert_allclose(vz[eng], v[eng])
    inner = eng & np.roll(eng, 1) & np.roll(eng, -1)
    inner[[0, -1]] = False
    np.testing.assert_allclose(np.gradient(z, t)[inner], v[inner], rtol=0, atol=1e-3 * A * TWO_PI)
    # the element does not move while disengaged
    assert np.ptp(z[i_rev : i_rev + n_frozen + 1]) == 0.0


# =============================================================================
# Travel, Dahl, Maxwell
# =============================================================================


def test_cumulative_travel_of_sine():
    for A, cyc in [(1.0, 3), (2.5, 4)]:
        t, x, v = blind.sine_input(A, 0.7, cyc, 200)
        s = blind.cumulative_travel(x)
        assert s[-1] == pytest.approx(4 * A * cyc, rel=1e-12)
        assert s[100] == pytest.approx(2 * A, rel=1e-12)  # half a cycle
        assert np.all(np.diff(s) >= 0)


def test_dahl_matches_analytic_on_monotone_ramp():
    Fc, sig = 60.0, 120.0
    x = np.linspace(-3.0, 2.0, 501)
    F = blind.dahl_operator(x, Fc, sig, F0=-Fc)
    expected = Fc + (-Fc - Fc) * np.exp(-sig * (x - x[0]) / Fc)
    np.testing.assert_allclose(F, expected, atol=1e-10)
    # going down from the top: F -> -Fc
    xd = np.linspace(2.0, -3.0, 501)
    Fd = blind.dahl_operator(xd, Fc, sig, F0=F[-1])
    np.testing.assert_allclose(Fd, -Fc + (F[-1] + Fc) * np.exp(-sig * (2.0 - xd) / Fc), atol=1e-10)


def test_dahl_is_exact_under_refinement_and_bounded():
    knots = np.array([-4.0, 4.0, 1.0, 2.0, -0.3, 0.2, -4.0])
    coarse = np.concatenate([np.linspace(a, b, 9)[:-1] for a, b in zip(knots[:-1], knots[1:])] + [knots[-1:]])
    m = 13
    fine = np.interp(np.linspace(0, len(coarse) - 1, m * (len(coarse) - 1) + 1), np.arange(len(coarse)), coarse)
    Fc_ = blind.dahl_operator(coarse, 60.0, 120.0, F0=-60.0)
    Ff = blind.dahl_operator(fine, 60.0, 120.0, F0=-60.0)
    np.testing.assert_allclose(Ff[::m], Fc_, atol=1e-10)
    assert np.all(np.abs(Ff) <= 60.0 + 1e-12)


def test_maxwell_ramp_hold_matches_exponential():
    km, cm = 40.0, 3.0
    tau = cm / km
    h = 1e-4
    x0, tr = 2.0, 0.05
    n_r = int(round(tr / h))
    t = np.arange(0, 20000 + 1) * h
    x = np.where(t < tr, x0 * t / tr, x0)
    x[n_r] = x0
    F = blind.maxwell_force(x, h, km, tau)
    vr = x0 / tr
    Fr = cm * vr * (1.0 - np.exp(-t / tau))
    Fh = cm * vr * (1.0 - math.exp(-tr / tau)) * np.exp(-(t - tr) / tau)
    expected = np.where(t <= tr + 1e-12, Fr, Fh)
    np.testing.assert_allclose(F, expected, atol=1e-9 * cm * vr)
    # a fast ramp approaches the step response km x0 exp(-t/tau)
    tr2 = 1e-4
    x2 = np.where(t < tr2, x0 * t / tr2, x0)
    F2 = blind.maxwell_force(x2, h, km, tau)
    late = t > 0.01
    np.testing.assert_allclose(F2[late], km * x0 * np.exp(-t[late] / tau), rtol=2e-3)


# =============================================================================
# Linear systems: exact first-order hold
# =============================================================================


def _oscillator_sine_from_rest(t, m, c, k, F0, w):
    """Closed-form response of m x'' + c x' + k x = F0 sin(w t), x(0)=x'(0)=0."""
    wn = math.sqrt(k / m)
    z = c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - z * z)
    M = np.array([[k - m * w * w, -c * w], [c * w, k - m * w * w]])
    a, b = np.linalg.solve(M, [F0, 0.0])
    C1 = -b
    C2 = (-a * w + z * wn * C1) / wd
    return a * np.sin(w * t) + b * np.cos(w * t) + np.exp(-z * wn * t) * (C1 * np.cos(wd * t) + C2 * np.sin(wd * t))


def test_foh_linear_oscillator_matches_closed_form():
    p = blind._LIN_OSC
    A, B, C = blind.linear_oscillator_matrices(p["m"], p["c"], p["k"])
    for F0, f in [(5.0, 1.5), (8.0, 3.0), (10.0, 6.0)]:
        t = np.arange(5 * 1600 + 1) / (f * 1600)
        u = F0 * np.sin(TWO_PI * f * t)
        x = blind.lti_foh_response(A, B, C, t[1] - t[0], u)
        ex = _oscillator_sine_from_rest(t, p["m"], p["c"], p["k"], F0, TWO_PI * f)
        assert np.max(np.abs(x - ex)) < 1e-5 * np.max(np.abs(ex))


def test_clean_linear_oscillator_case_matches_closed_form():
    c = blind.clean_linear_oscillator(noise=False)
    p = blind._LIN_OSC
    for r in c.records:
        if r["name"].startswith("MS"):
            continue
        F0, f = r["conditions"]["amplitude"], r["conditions"]["frequency_hz"]
        ex = 1000.0 * _oscillator_sine_from_rest(r["t"], p["m"], p["c"], p["k"], F0, TWO_PI * f)
        assert np.max(np.abs(r["y"] - ex)) < 0.01 * c.noise_sd


def test_foh_is_exact_for_piecewise_linear_input():
    # 3-state standard linear solid oscillator against a tight solve_ivp on the
    # same piecewise-linear input
    A, B, C = blind.sls_oscillator_matrices(4.0, 5.0, 2000.0, 1500.0, 0.04)
    h = 0.004
    t = np.arange(0, 401) * h
    rng = np.random.default_rng(5)
    u = np.concatenate([[0.0], rng.normal(0, 20.0, 400)])
    x = blind.lti_foh_response(A, B, C, h, u)

    def rhs(tt, s):
        return A @ s + B * np.interp(tt, t, u)

    ref = solve_ivp(rhs, (0, t[-1]), np.zeros(3), method="DOP853", t_eval=t, rtol=1e-12, atol=1e-15, max_step=h / 4)
    assert np.max(np.abs(x - ref.y[0])) < 1e-8 * np.max(np.abs(ref.y[0]))
    with pytest.raises(ValueError):
        blind.lti_foh_response(A, B, C, h, u + 1.0)


# =============================================================================
# Nonlinear integrators: convergence and closed forms
# =============================================================================


def test_stribeck_oscillator_converged():
    p = blind._STRIB_OSC
    F0, f = 7.0, 1.5
    t = np.arange(4 * 100 + 1) / (f * 100)
    x1 = blind.simulate_stribeck_oscillator(t, F0, f, p)
    x2 = blind.simulate_stribeck_oscillator(t, F0, f, p, rtol=1e-11, atol=1e-14, max_step=(t[1] - t[0]) / 30)
    noise_m = blind.stribeck_oscillator().noise_sd / 1000.0
    assert np.max(np.abs(x1 - x2)) < 1e-3 * noise_m
    # with no friction it is the linear oscillator
    q = dict(p, Fc=0.0, Fs=0.0)
    x0 = blind.simulate_stribeck_oscillator(t, F0, f, q)
    ex = _oscillator_sine_from_rest(t, q["m"], q["c"], q["k"], F0, TWO_PI * f)
    assert np.max(np.abs(x0 - ex)) < 1e-6 * np.max(np.abs(ex))


def test_endstop_oscillator_converged_and_linear_inside_gap():
    p = blind._ENDSTOP
    F0, f = 6.0, 2.5
    t = np.arange(5 * 60 + 1) / (f * 60)
    x1 = blind.simulate_endstop_oscillator(t, F0, f, p)
    x2 = blind.simulate_endstop_oscillator(t, F0, f, p, rtol=1e-12, atol=1e-15, max_step=(t[1] - t[0]) / 30)
    assert np.max(np.abs(x1)) > p["g"]  # the stops are hit
    assert np.max(np.abs(x1 - x2)) < 1e-3 * blind.endstop_contact_oscillator().noise_sd / 1000.0
    q = dict(p, g=10.0)  # stops never reached
    xl = blind.simulate_endstop_oscillator(t, F0, f, q)
    ex = _oscillator_sine_from_rest(t, q["m"], q["c"], q["k"], F0, TWO_PI * f)
    assert np.max(np.abs(xl - ex)) < 1e-7 * np.max(np.abs(ex))


def test_bouc_wen_closed_form_on_monotone_half_cycle():
    # n = 1, z0 = 0, x' > 0 and z >= 0: dz/dx = (1 - z)/xy -> z = 1 - exp(-(x + A)/xy)
    p = dict(blind._BW, n=1.0)
    A = 3.0
    t = np.linspace(0, 0.5, 501)  # x = -A cos(2 pi t): -A -> A
    z = blind.simulate_bouc_wen(t, [A], [1.0], p, z0=0.0)
    x = -A * np.cos(TWO_PI * t)
    np.testing.assert_allclose(z, 1.0 - np.exp(-(x + A) / p["xy"]), atol=1e-8)


def test_bouc_wen_bounded_and_converged():
    t = np.arange(601) / 400.0
    z1 = blind.simulate_bouc_wen(t, [8.0, 2.0], [1.0, 4.2], blind._BW, z0=-1.0)
    z2 = blind.simulate_bouc_wen(
        t, [8.0, 2.0], [1.0, 4.2], blind._BW, z0=-1.0, rtol=1e-12, atol=1e-14, max_step=(t[1] - t[0]) / 15
    )
    assert np.all(np.abs(z1) <= 1.0 + 1e-9)
    # force scale alpha <= 320 N; integration error far below the noise
    assert 320.0 * np.max(np.abs(z1 - z2)) < 1e-3 * blind.mr_bouc_wen_damper().noise_sd


def test_thermal_viscous_closed_form_when_linear():
    p = dict(blind._THERM, b=0.0)
    A, f = 20.0, 1.0
    t, x, v = blind.sine_input(A, f, 5, 40)
    th = blind.simulate_thermal_viscous(t, A, f, p)
    w = TWO_PI * f
    a = p["c0"] * A * A * w * w / (2 * p["C"])
    tau = p["tau"]
    Om = 2 * w
    P = -a * tau / (1 + (Om * tau) ** 2)
    Q = P * Om * tau
    ex = a * tau + P * np.cos(Om * t) + Q * np.sin(Om * t) + (-a * tau - P) * np.exp(-t / tau)
    np.testing.assert_allclose(th, ex, atol=1e-8 * np.max(ex))
    # nonlinear (b > 0) version converged
    th1 = blind.simulate_thermal_viscous(t, A, f, blind._THERM)
    th2 = blind.simulate_thermal_viscous(t, A, f, blind._THERM, rtol=1e-12, atol=1e-14, max_step=(t[1] - t[0]) / 40)
    assert np.max(np.abs(th1 - th2)) < 1e-8
    assert th1[-1] < th[-1]  # less heating when damping fades


def test_crank_nicolson_thermal_friction_against_solve_ivp():
    p = blind._ASYMDRIFT
    A, f = 2.0, 1.0
    tf, xf, vf = blind.sine_input(A, f, 4, 120, 20)
    th = blind.thermal_friction_cn(tf, vf, p)
    w = TWO_PI * f

    def rhs(tt, y):
        v = A * w * math.sin(w * tt)
        s = v / math.sqrt(v * v + p["delta"] ** 2)
        return [
            ((p["Fbar"] + p["dF"] * s) * math.exp(-p["b"] * y[0]) * s * v + p["c"] * v * v) / p["C"] - y[0] / p["tau"]
        ]

    t = tf[::20]
    ref = solve_ivp(
        rhs, (0, t[-1]), [0.0], method="DOP853", t_eval=t, rtol=1e-11, atol=1e-12, max_step=(t[1] - t[0]) / 10
    ).y[0]
    # the force sensitivity to th is about Fdir * b ~ 0.03 kip/K; error << noise
    assert np.max(np.abs(th[::20] - ref)) < 1e-3
    assert 0.03 * np.max(np.abs(th[::20] - ref)) < 1e-3 * blind.asymmetric_friction_drift_damper().noise_sd
    # second-order convergence
    e = []
    for ref_n in (5, 10):
        tfn, _, vfn = blind.sine_input(A, f, 4, 120, ref_n)
        e.append(np.max(np.abs(blind.thermal_friction_cn(tfn, vfn, p)[::ref_n] - ref)))
    assert e[1] < e[0] / 3.0


def test_duffing_midpoint_linear_limit_and_convergence():
    p = blind._DUFF
    F0, f = 4.0, 2.5
    for k3 in (0.0, p["k3"]):
        q = dict(p, k3=k3)
        xs = []
        for ref in (20, 40, 80):
            tf = np.arange(4 * 80 * ref + 1) / (f * 80 * ref)
            um = F0 * np.sin(TWO_PI * f * (tf[:-1] + 0.5 * (tf[1] - tf[0])))
            xs.append(blind.duffing_midpoint(tf, um, q)[::ref])
        if k3 == 0.0:
            t = np.arange(4 * 80 + 1) / (f * 80)
            ex = _oscillator_sine_from_rest(t, q["m"], q["c"], q["k"], F0, TWO_PI * f)
            assert np.max(np.abs(xs[0] - ex)) < 1e-3 * np.max(np.abs(ex))
            assert np.max(np.abs(xs[2] - ex)) < np.max(np.abs(xs[0] - ex)) / 10  # 2nd order
        else:
            # the production grid (20x) is within 2 % of the noise sd of the converged answer
            assert 1000.0 * np.max(np.abs(xs[0] - xs[2])) < 0.02 * blind.clean_duffing_oscillator().noise_sd


# =============================================================================
# Signals and noise
# =============================================================================


def test_sine_and_cos_sum_inputs():
    t, x, v = blind.sine_input(2.0, 0.5, 3, 100)
    assert len(t) == 301 and t[-1] == pytest.approx(6.0)
    assert x[0] == -2.0 and x[-1] == pytest.approx(-2.0) and v[0] == 0.0 and v[50] == 0.0
    np.testing.assert_allclose(np.gradient(x, t)[1:-1], v[1:-1], atol=2e-3 * np.abs(v).max())
    t = np.linspace(0, 2, 2001)
    xs, vs = blind.cos_sum(t, [1.0, 0.5], [1.0, 3.0])
    assert xs[0] == -1.5 and vs[0] == 0.0
    np.testing.assert_allclose(np.gradient(xs, t)[1:-1], vs[1:-1], atol=1e-3 * np.abs(vs).max())
    xm, vm = blind.tapered_multisine(t, [1.0, 0.4], [1.3, 2.9], [0.3, 1.1], 2.0, 0.4)
    assert xm[0] == 0.0 and xm[-1] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(np.gradient(xm, t)[1:-1], vm[1:-1], atol=1e-3 * np.abs(vm).max())


def test_ar1_noise_statistics():
    rng = np.random.default_rng(1)
    e = blind.ar1_noise(rng, 200000, 2.0, 0.8)
    assert np.std(e) == pytest.approx(2.0, rel=0.03)
    rho = np.corrcoef(e[:-1], e[1:])[0, 1]
    assert rho == pytest.approx(0.8, abs=0.01)
    # stationary from the first sample: many short sequences
    first = np.array([blind.ar1_noise(np.random.default_rng(i), 2, 2.0, 0.8)[0] for i in range(2000)])
    assert np.std(first) == pytest.approx(2.0, rel=0.05)


def test_lowpass_noise_statistics():
    rng = np.random.default_rng(2)
    e = blind.lowpass_noise(rng, 200000, 0.5, 2, 0.2)
    assert np.std(e) == pytest.approx(0.5, rel=0.03)
    assert np.corrcoef(e[:-1], e[1:])[0, 1] > 0.5  # coloured
    w = blind.make_noise(np.random.default_rng(3), 100000, 1.5, ("white",))
    assert np.std(w) == pytest.approx(1.5, rel=0.02)
    assert abs(np.corrcoef(w[:-1], w[1:])[0, 1]) < 0.02


def test_smooth_signs():
    v = np.linspace(-5, 5, 1001)
    for fn in (blind.sign_arctan, blind.sign_erf, blind.sign_algebraic):
        s = fn(v, 0.1)
        assert np.all(np.diff(s) >= 0) and np.all(np.abs(s) <= 1)
        np.testing.assert_allclose(s, -s[::-1], atol=1e-15)
        assert abs(s[-1]) > 0.98
    assert blind.sign_exact(0.0) == 0.0
