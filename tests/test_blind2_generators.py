"""Tests of the blind2 data generators (hybridhyst.testbed.blind2): structure, determinism, noise, effect visibility
and known-solution checks of every numerical operator and integrator they use."""

from __future__ import annotations

import ast
import dataclasses
import math
import pathlib
import sys
from functools import cache

import numpy as np
import pytest

from hybridhyst.testbed import blind2
from hybridhyst.testbed.blind2 import core, ops

PKG_DIR = pathlib.Path(blind2.__file__).parent
EFFECT_WORDS = (
    "play",
    "stribeck",
    "travel_stiffness",
    "travel_friction",
    "drift",
    "asymmetry",
    "relaxation",
    "hysteretic",
    "outside",
)
FIELDS = [
    "name",
    "effects",
    "description",
    "base_law",
    "kind",
    "units",
    "mass_kg",
    "noise_sd",
    "records",
    "held_out",
    "validation",
    "noise_model",
]


@cache
def built(name: str, noise: bool = True, nominal=False):
    return blind2.case(name, noise=noise, nominal=nominal)


def stacked_y(c) -> np.ndarray:
    return np.concatenate([r["y"] for r in c.records])


# ----------------------------------------------------------------------------------------------------------------------
# Package hygiene and catalogue
# ----------------------------------------------------------------------------------------------------------------------


def test_imports_only_numpy_scipy_stdlib():
    allowed = set(sys.stdlib_module_names) | {"numpy", "scipy", "__future__"}
    files = sorted(PKG_DIR.glob("*.py"))
    assert files
    for path in files:
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level > 0:  # relative import inside the package
                    continue
                roots = [node.module.split(".")[0]]
            else:
                continue
            for root in roots:
                assert root in allowed, f"{path.name} imports {root}"


def test_catalogue_and_required_mix():
    assert len(blind2.CASES) >= 17
    assert blind2.CASE_NAMES == [f.__name__ for f in blind2.CASES]
    assert len(set(blind2.CASE_NAMES)) == len(blind2.CASE_NAMES)
    cases = [built(n) for n in blind2.CASE_NAMES]
    assert [c.name for c in cases] == blind2.CASE_NAMES
    clean = [c for c in cases if not c.effects]
    single = [c for c in cases if len(c.effects) == 1]
    assert len(clean) >= 4
    assert {c.kind for c in clean} == {"damper", "oscillator"}
    operating = {"amplitude", "frequency_hz", "rms"}
    assert any(set(r["conditions"]) - operating for c in clean for r in c.records)
    assert len(single) >= 10
    assert set(EFFECT_WORDS[:-1]) <= {c.effects[0] for c in single}
    assert any(c.kind == "oscillator" for c in single)
    assert any(len(c.effects) == 2 for c in cases)
    assert sum("outside" in c.effects for c in cases) >= 2
    with pytest.raises(KeyError):
        blind2.case("no_such_case")


# ----------------------------------------------------------------------------------------------------------------------
# Per-case checks
# ----------------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", blind2.CASE_NAMES)
def test_fields_and_records(name):
    c = built(name)
    assert isinstance(c, blind2.BlindCase)
    assert [f.name for f in dataclasses.fields(c)] == FIELDS
    assert c.name == name
    assert isinstance(c.effects, tuple) and len(set(c.effects)) == len(c.effects)
    assert all(w in EFFECT_WORDS for w in c.effects)
    assert isinstance(c.description, str) and len(c.description) > 200
    assert c.kind in ("damper", "oscillator")
    law = c.base_law
    if c.kind == "damper":
        assert law == "F = k x + c v" or "coulomb" in law or "cubic" in law
        assert c.mass_kg is None
        assert set(c.units) == {"x", "y"}
    else:
        assert "m x'' + c x' + k x" in law and law.endswith("= u")
        assert c.units["x"] == "N" and c.units["y"] in ("mm", "m") and set(c.units) == {"x", "y"}
        assert isinstance(c.mass_kg, float) and c.mass_kg > 0
        assert core.round_sig1(c.mass_kg) == c.mass_kg
    assert c.noise_sd > 0
    assert isinstance(c.noise_model, tuple) and c.noise_model[0] in ("white", "ar1", "lowpass")
    assert 1 <= len(c.records) <= 12
    assert sum(r["t"].size for r in c.records) <= 25_000
    names = [r["name"] for r in c.records]
    assert len(set(names)) == len(names)
    for r in c.records:
        assert set(r) == {"name", "t", "x", "y", "conditions"}
        t, x, y = r["t"], r["x"], r["y"]
        assert t.ndim == x.ndim == y.ndim == 1 and t.size == x.size == y.size >= 100
        assert np.all(np.isfinite(t)) and np.all(np.isfinite(x)) and np.all(np.isfinite(y))
        dt = np.diff(t)
        assert dt.min() > 0 and np.allclose(dt, dt[0], rtol=1e-9, atol=0)
        assert all(isinstance(k, str) and isinstance(v, float) for k, v in r["conditions"].items())
        if r["name"].startswith("sine") or "_sine_" in r["name"]:
            assert {"amplitude", "frequency_hz"} <= set(r["conditions"])
            assert r["conditions"]["amplitude"] == pytest.approx(np.max(np.abs(x)), rel=0.02)
    assert c.held_out and set(c.held_out) <= set(names)
    assert set(c.validation) <= set(names)
    assert not set(c.held_out) & set(c.validation)
    for n in c.held_out:
        assert n in c.description


@pytest.mark.parametrize("name", blind2.CASE_NAMES)
def test_deterministic(name):
    a = blind2.case(name)
    b = built(name)
    for ra, rb in zip(a.records, b.records):
        for key in ("t", "x", "y"):
            assert np.array_equal(ra[key], rb[key])
        assert ra["conditions"] == rb["conditions"]
    assert a.description == b.description


@pytest.mark.parametrize("name", blind2.CASE_NAMES)
def test_noise_level(name):
    noisy, clean = built(name), built(name, noise=False)
    for rn, rc in zip(noisy.records, clean.records):
        assert np.array_equal(rn["x"], rc["x"]) and np.array_equal(rn["t"], rc["t"])
    d = stacked_y(noisy) - stacked_y(clean)
    assert abs(d.mean()) < 0.2 * clean.noise_sd
    assert 0.85 * clean.noise_sd < d.std() < 1.15 * clean.noise_sd


@pytest.mark.parametrize("name", blind2.CASE_NAMES)
def test_effects_visible(name):
    truth = built(name, noise=False)
    y = stacked_y(truth)
    if not truth.effects:
        nom = built(name, noise=False, nominal=True)
        assert np.array_equal(stacked_y(nom), y)
        return
    switches = list(truth.effects) + ([True] if len(truth.effects) > 1 else [])
    for word in switches:
        nom = built(name, noise=False, nominal=word)
        for rn, rt in zip(nom.records, truth.records):
            assert np.array_equal(rn["x"], rt["x"])
        rms = float(np.sqrt(np.mean((stacked_y(nom) - y) ** 2)))
        assert rms >= 3.0 * truth.noise_sd, (word, rms, truth.noise_sd)
    with pytest.raises(ValueError):
        blind2.case(name, nominal="not_an_effect")


# ----------------------------------------------------------------------------------------------------------------------
# Known-solution checks of the operators and integrators
# ----------------------------------------------------------------------------------------------------------------------


def test_play_operator_hand_case():
    x = [0.0, 1.0, 2.0, 1.5, 0.5, -1.0, 0.0]
    assert np.allclose(ops.play_operator(x, 0.5), [0.0, 0.5, 1.5, 1.5, 1.0, -0.5, -0.5])


def test_stop_operator_hand_case():
    x = [0.0, 0.25, 1.0, 0.5, -0.5, -0.25]
    assert np.allclose(ops.stop_operator(x, 2.0, 1.0), [0.0, 0.5, 1.0, 0.0, -1.0, -0.5])


def test_dead_zone_and_smooth_sign():
    assert np.allclose(ops.dead_zone([-2.0, -0.5, 0.0, 0.5, 2.0], 1.0), [-1.0, 0.0, 0.0, 0.0, 1.0])
    v = np.array([-1.0, -1e-3, 0.0, 1e-3, 1.0])
    s = ops.smooth_sign(v, 1e-3)
    assert s[2] == 0.0 and np.allclose(s, -s[::-1])
    assert s[4] == pytest.approx(1.0) and s[3] == pytest.approx(math.tanh(1.0))


def _sine_total_variation(amp, omega, t):
    # total variation of A sin(w t) on [0, t]: 2 A per half period plus the part of the current one
    theta = omega * t + 0.5 * math.pi
    m = np.floor(theta / math.pi)
    rest = theta - m * math.pi
    return amp * (2.0 * m + 1.0 - np.cos(rest) - 1.0)


def test_cumulative_travel_against_exact_sine():
    amp, f = 3.0, 1.3
    t = np.linspace(0.0, 4.1, 50_001)
    s = ops.cumulative_travel(amp * np.sin(2 * math.pi * f * t), s0=7.0)
    exact = 7.0 + _sine_total_variation(amp, 2 * math.pi * f, t)
    assert np.max(np.abs(s - exact)) < 1e-5


def test_backlash_linkage_known_solutions():
    k, c, h = 20.0, 1.5, 1e-4
    t = np.arange(2000) * h
    sig = core.Sine(2.0, 3.0)
    # no clearance: always in contact, F = k x + c v
    z, f = ops.backlash_linkage(sig.x(t), sig.v(t), 0.0, k, c, h)
    assert np.allclose(z, sig.x(t)) and np.allclose(f, k * sig.x(t) + c * sig.v(t))
    # pin held at 0 inside the clearance: the piston relaxes exactly, no force
    z, f = ops.backlash_linkage(np.zeros(t.size), np.zeros(t.size), 2.0, k, c, h, z0=1.0)
    assert np.allclose(z, np.exp(-k * t / c), rtol=1e-12, atol=1e-14) and np.all(f == 0.0)
    # pin moving at constant speed from the centre: free until the clearance is taken up, then pushes
    vel, r = 5.0, 0.5
    z, f = ops.backlash_linkage(vel * t, np.full(t.size, vel), r, k, c, h)
    contact = vel * t >= r
    assert np.all(f[~contact] == 0.0)
    assert np.allclose(z[contact], vel * t[contact] - r)
    assert np.allclose(f[contact], k * (vel * t[contact] - r) + c * vel)


def _ramp_response(m, c, k, rate, t):
    """Closed-form x(t) of m x'' + c x' + k x = rate t from rest."""
    w = math.sqrt(k / m)
    zeta = c / (2.0 * math.sqrt(k * m))
    wd = w * math.sqrt(1.0 - zeta**2)
    a = rate * c / k**2
    b = (zeta * w * a - rate / k) / wd
    return rate / k * (t - c / k) + np.exp(-zeta * w * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))


def test_rk4_against_closed_form_oscillator():
    m, c, k, rate = 2.3, 12.0, 8000.0, 30.0
    t = np.arange(1500) / 500.0
    sol = ops.rk4(lambda s, u: [s[1], (u[0] - c * s[1] - k * s[0]) / m], [0.0, 0.0], t, 4, lambda tt: rate * tt)
    exact = _ramp_response(m, c, k, rate, t)
    assert np.max(np.abs(sol[:, 0] - exact)) < 1e-7 * np.max(np.abs(exact)) + 1e-12


def test_rk4_against_closed_form_maxwell():
    k1, tau, vel = 15.0, 0.05, 4.0
    t = np.arange(500) / 250.0
    sol = ops.rk4(lambda s, u: [k1 * u[0] - s[0] / tau], [0.0], t, 2, lambda tt: np.full(tt.size, vel))
    exact = k1 * vel * tau * (1.0 - np.exp(-t / tau))
    assert np.max(np.abs(sol[:, 0] - exact)) < 1e-5 * np.max(exact)


def test_rk4_kink_refinement_against_finer_grid():
    m, c, k, g = 1.4, 25.0, 3.0e4, 0.3e-3

    def rhs(s, u):
        x = s[0]
        spring = x - g if x > g else (x + g if x < -g else 0.0)
        return [s[1], (u[0] - c * s[1] - k * spring) / m]

    def region(s):
        return int(s[0] > g) - int(s[0] < -g)

    sig = core.Sine(40.0, 25.0)
    t = np.arange(300) / 1000.0
    coarse = ops.rk4(rhs, [0.0, 0.0], t, 4, sig.x, region=region)[:, 0]
    reference = ops.rk4(rhs, [0.0, 0.0], t, 32, sig.x, region=region)[:, 0]
    assert np.max(np.abs(coarse - reference)) < 1e-3 * np.max(np.abs(reference))


def test_foh_oscillator_against_closed_form():
    m, c, k, rate = 2.3, 12.0, 8000.0, 30.0
    t = np.arange(3000) / 2000.0
    x = ops.linear_oscillator_foh(m, c, k, rate * t, t[1] - t[0])
    exact = _ramp_response(m, c, k, rate, t)
    assert np.max(np.abs(x - exact)) < 1e-9 * np.max(np.abs(exact)) + 1e-12


def test_cooling_is_exact_exponential():
    assert ops.cool(50.0, 20.0, 24.0, 24.0) == pytest.approx(20.0 + 30.0 / math.e)


def test_signal_derivatives():
    t = np.linspace(0.0, 6.0, 60_001)
    dt = t[1] - t[0]
    signals = [
        core.Sine(2.0, 1.5, 0.3),
        core.Decaying(8.0, 1.0, 4.0),
        core.Multisine(0.2, 3.0, 8, 4.0, seed=1, fade=1.0),
        core.Chirp(10.0, 0.2, 3.0, 6.0),
        core.RampHold(5.0, 0.1),
    ]
    for sig in signals:
        x, v = sig.x(t), sig.v(t)
        num = (x[2:] - x[:-2]) / (2 * dt)
        assert np.max(np.abs(num - v[1:-1])) < 1e-3 * np.max(np.abs(v)), type(sig).__name__
    ms = core.Multisine(0.2, 3.0, 8, 4.0, seed=1)
    tt = np.arange(200_000) * 0.01
    assert np.std(ms.x(tt)) == pytest.approx(4.0, rel=0.01)


@pytest.mark.parametrize("model", [("white",), ("ar1", 0.8), ("lowpass", 4, 0.2), ("lowpass", 2, 0.3)])
def test_unit_noise_marginal_variance(model):
    e = core.unit_noise(np.random.default_rng(5), 200_000, model)
    assert e.std() == pytest.approx(1.0, rel=0.03)
    if model[0] == "ar1":
        assert np.corrcoef(e[1:], e[:-1])[0, 1] == pytest.approx(model[1], abs=0.01)


def test_round_sig1_and_switches():
    assert [core.round_sig1(v) for v in (2.3, 0.82, 1.4, 4.6, 0.62)] == [2.0, 0.8, 1.0, 5.0, 0.6]
    assert core.switched_off(False, ("play",)) == frozenset()
    assert core.switched_off(True, ("play", "drift")) == {"play", "drift"}
    assert core.switched_off("drift", ("play", "drift")) == {"drift"}
    assert core.switched_off(["play"], ("play", "drift")) == {"play"}
    with pytest.raises(ValueError):
        core.switched_off("stribeck", ("play",))
