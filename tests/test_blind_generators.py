"""Tests of the independent blind-test-bed generators (hybridhyst/testbed/blind/): the package's imports, the
catalogue, and the structure and noise of every case. The known-solution checks of the operators and integrators
the generators use are in tests/test_blind_operators.py and tests/test_blind_integrators.py.
"""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

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
    """Every module of the blind package imports only numpy, scipy and the standard library, and (relative, one
    level) the package's own modules; none names the library."""
    package = Path(blind.__file__).parent
    own = {p.stem for p in package.glob("*.py")} - {"__init__"}
    allowed = {"numpy", "scipy", "math", "dataclasses", "typing"}
    assert own, package
    for path in sorted(package.glob("*.py")):
        src = path.read_text()
        tree = ast.parse(src)
        seen = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    seen.add(a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    assert node.level == 1 and (node.module or "").split(".")[0] in own, (
                        f"relative import (from {'.' * node.level}{node.module or ''}) in blind/{path.name}")
                    continue
                seen.add((node.module or "").split(".")[0])
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                assert node.func.id not in {"__import__", "exec", "eval"}
        assert seen <= allowed, (path.name, seen - allowed)
        assert "hybridhyst" not in src, path.name


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
