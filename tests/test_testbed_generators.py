"""The independent test bed's generators (hybridhyst/testbed/generators/): they share no code with the library,
and they agree with known solutions (split from tests/test_testbed.py)."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from hybridhyst.testbed import generators as g

GENERATORS = Path(g.__file__).parent
MODULES = sorted(p.stem for p in GENERATORS.glob("*.py") if p.stem != "__init__")


# -- (a) the generators share no code with the library ------------------------------------------------------


def test_generators_import_nothing_from_hybridhyst():
    """No module of the package imports the library: only the standard library, numpy, scipy and (relative, one
    level) the package's own modules."""
    assert MODULES, GENERATORS
    for path in sorted(GENERATORS.glob("*.py")):
        tree = ast.parse(path.read_text())
        modules = []
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules += [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    assert node.level == 1 and (node.module or "").split(".")[0] in MODULES, (
                        f"relative import (from {'.' * node.level}{node.module or ''}) in generators/{path.name}")
                    continue
                modules.append(node.module or "")
        roots = {m.split(".")[0] for m in modules}
        assert "hybridhyst" not in roots, path.name
        assert roots <= {"__future__", "math", "collections", "dataclasses", "typing", "numpy", "scipy"}, (path.name,
                                                                                                            roots)


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
