"""Seed 002's loop metrics on loops whose values are known by hand, and the exponential trend fits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hybridhyst.analysis import (
    dissipated_energy,
    equivalent_stiffness,
    fit_trend,
    loop_metrics,
    peak_response,
)


def _theta(n=4000):
    return 2 * math.pi * np.arange(n) / n  # one period, n divisible by 4: a sample sits on each turning point


@pytest.mark.parametrize("phase", [0.3, 1.0, math.pi / 2])
def test_energy_of_an_ellipse_is_pi_f_x_sin_phase(phase):
    th = _theta()
    X, F = 5.0, 12.0
    x, y = X * np.sin(th), F * np.sin(th + phase)
    assert dissipated_energy(x, y) == pytest.approx(math.pi * F * X * math.sin(phase), rel=1e-5)
    # traversed the other way round (response lagging) the loop would give energy back: negative area
    assert dissipated_energy(x, F * np.sin(th - phase)) == pytest.approx(-math.pi * F * X * math.sin(phase), rel=1e-5)


def test_spring_dashpot_peak_and_energy():
    """y = k x + c ẋ: the peak is X·sqrt(k² + (cω)²) (before the amplitude), E_d = π c ω X² (viscous ellipse)."""
    th, X, k, c, w = _theta(), 5.0, 3.0, 0.7, 2.0
    x, y = X * np.sin(th), k * X * np.sin(th) + c * w * X * np.cos(th)
    assert peak_response(x, y) == pytest.approx((X, X * math.hypot(k, c * w)), rel=1e-6)
    assert dissipated_energy(x, y) == pytest.approx(math.pi * c * w * X**2, rel=1e-5)


def test_peak_of_a_friction_loop_is_the_top_of_the_jump_not_the_turning_point_sample():
    """y = k x + F_c tanh(ẋ / v_s): at x_max, ẋ = 0 and y = k X; the maximum torque is k X + F_c (nearly)."""
    th, X, k, Fc = _theta(), 5.0, 1.0, 4.0
    x = X * np.sin(th)
    y = k * x + Fc * np.tanh(X * np.cos(th) / 1e-3)
    assert y[np.argmax(x)] == pytest.approx(k * X)
    assert peak_response(x, y)[1] == pytest.approx(k * X + Fc, rel=1e-3)


def _bilinear_loop(k_load, k_unload, X=5.0):
    """Loading (|x| growing) y = k_l x; unloading y = k_u (x − X sgn x) + k_l X sgn x (meets loading at ±X)."""
    x = X * np.sin(_theta())
    s = np.sign(x)
    loading = x * np.gradient(x) > 0
    return x, np.where(loading, k_load * x, k_unload * (x - X * s) + k_load * X * s)


def test_equivalent_stiffness_reads_the_slope_of_each_branch_on_both_sides():
    x, y = _bilinear_loop(2.0, 7.0)
    assert equivalent_stiffness(x, y, (1, 3), "loading") == pytest.approx(2.0, rel=1e-12)
    assert equivalent_stiffness(x, y, (3.5, 5), "unloading") == pytest.approx(7.0, rel=1e-12)
    assert equivalent_stiffness(x, y, (-3, -1), "loading") == pytest.approx(2.0, rel=1e-12)
    assert equivalent_stiffness(x, y, (-5, -3.5), "unloading") == pytest.approx(7.0, rel=1e-12)


def test_loop_metrics_of_a_bilinear_loop():
    """Seed 002's windows on a ±5 loop: k_a is the mean of the branch slopes; the area between the two
    branches is the parallelogram X·(k_u − k_l)·X per half, 2·X²·(k_u − k_l) in all."""
    k_l, k_u, X = 2.0, 7.0, 5.0
    m = loop_metrics(*_bilinear_loop(k_l, k_u, X))
    assert (m.loading_stiffness, m.unloading_stiffness) == pytest.approx((k_l, k_u), rel=1e-12)
    assert m.average_stiffness == pytest.approx(4.5, rel=1e-12)
    assert m.amplitude == pytest.approx(X, rel=1e-12)
    # each half: triangle between the lines y = k_l x and y = k_u(x − X) + k_l X over x ∈ [0, X]
    assert m.dissipated_energy == pytest.approx(2 * 0.5 * X * X * (k_u - k_l), rel=1e-3)


def test_loop_metrics_refuse_windows_outside_the_loop_and_non_finite_data():
    x, y = _bilinear_loop(2.0, 7.0, X=2.0)
    with pytest.raises(ValueError, match="fewer than two distinct samples in x ∈ \\[3.5, 5\\]"):
        loop_metrics(x, y)
    with pytest.raises(ValueError, match="branch must be"):
        equivalent_stiffness(x, y, (0.5, 1.5), "up")
    y[10] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        dissipated_energy(x, y)


@pytest.mark.parametrize("kind, coef", [("exp_rise", (4.0, 15.0, 60.0)), ("exp_decay", (0.01, 0.5, 300.0)),
                                        ("exp_growth", (2.0, 0.5, 40.0))])
def test_fit_trend_recovers_seed002_exponentials(kind, coef):
    p = np.linspace(0.0, 0.05, 11)
    y = {"exp_rise": lambda c: coef[0] + coef[1] * (1 - np.exp(-coef[2] * c)),
         "exp_decay": lambda c: coef[0] + coef[1] * np.exp(-coef[2] * c),
         "exp_growth": lambda c: coef[0] + coef[1] * np.exp(coef[2] * c)}[kind](p)
    fit = fit_trend(p, y, kind)
    assert (fit.y0, fit.a, fit.b) == pytest.approx(coef, rel=1e-5)
    assert fit.r2 == pytest.approx(1.0, abs=1e-10)
    assert fit(p) == pytest.approx(y, rel=1e-6)
    with pytest.raises(ValueError, match="unknown trend kind"):
        fit_trend(p, y, "linear")


def test_r2_is_undefined_for_a_constant_target_without_a_warning():
    import warnings

    from hybridhyst.analysis.metrics import r2

    assert r2([1.0, 2.0, 3.0], [1.0, 2.0, 4.0]) == pytest.approx(1 - 1 / (14 / 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # per-level estimates that all sit at one value (a box edge)
        assert math.isnan(r2([1.0, 1.0], [2.0, 2.0]))
