"""Known-solution checks of the blind generators' elementary operators (hybridhyst/testbed/blind/operators.py,
inputs.py, noise.py): the play operator, cumulative travel, Dahl, Maxwell, the input signals, the noise models and
the smoothed signs (split from tests/test_blind_generators.py).
"""

import math

import numpy as np
import pytest

from hybridhyst.testbed import blind

TWO_PI = 2.0 * math.pi


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
