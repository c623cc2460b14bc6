"""Known-solution and convergence checks of the blind generators' integrators
(hybridhyst/testbed/blind/operators.py's exact first-order hold, integrators.py): linear systems against closed
forms, the nonlinear ODE integrations against closed forms and tighter solutions (split from
tests/test_blind_generators.py).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hybridhyst.testbed import blind

TWO_PI = 2.0 * math.pi


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
