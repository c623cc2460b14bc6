"""The test bed's control-channel cases (issue 39): their generators (a random voltage staircase, a pressure ramp,
band-limited random motion, Bouc–Wen with n = 2 exact in displacement, a lagged MR damper) against known
solutions and scipy, and the two cases' records and nominals; no discovery is run (fast)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hybridhyst.testbed import generators as g
from hybridhyst.testbed.laws import control_friction_law, mr_lag_law, on_fine

MR = "mr_damper~voltage+lag"
RAMP = "friction~pressure_ramp+viscous"
MR_TRUTH = dict(c_a=1.0, c_b=1.5, alpha_a=20.0, alpha_b=60.0, k=2.0, beta=0.4, gamma=0.3)


# -- generators --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("beta, gamma", [(0.4, 0.3), (0.2, 0.5), (0.4, 0.4)])
def test_bouc_wen_n2_matches_an_ode_solver(beta, gamma):
    """Exact per step in displacement (tanh / tan / linear branches, split where z crosses 0) = LSODA on the ODE
    ż = ẋ − β|ẋ| z|z| − γ ẋ z² in time; the state saturates at 1/√(β + γ)."""
    sig = g.random_motion(8.0, 0.5, 3.0, 8, seed=5, duration=2.0)
    t = np.arange(501) / 250.0
    z = g.bouc_wen_n2(sig.x(g.fine_grid(t, 20)), beta, gamma)[::20]

    def rhs(tt, s):
        v = float(sig.v(np.array([tt]))[0])
        return np.array([v - beta * abs(v) * abs(s[0]) * s[0] - gamma * v * s[0] ** 2])

    z_ode = g.integrate(rhs, t, [0.0], method="LSODA", refine=10)[:, 0]
    assert np.max(np.abs(z - z_ode)) < 1e-4
    assert np.max(np.abs(z)) == pytest.approx(1 / math.sqrt(beta + gamma), rel=1e-4)  # 8 mm drives it to saturation


def test_bouc_wen_n2_virgin_curve_is_tanh_and_coarse_steps_are_exact():
    beta, gamma = 0.4, 0.3
    a = beta + gamma
    x = np.linspace(0.0, 3.0, 7)  # coarse on purpose: monotone steps are exact
    np.testing.assert_allclose(g.bouc_wen_n2(x, beta, gamma), np.tanh(math.sqrt(a) * x) / math.sqrt(a), rtol=1e-12)
    path = np.r_[np.linspace(0, 3, 3001), np.linspace(3, -2, 5001)[1:], np.linspace(-2, 1, 3001)[1:]]
    fine = g.bouc_wen_n2(path, beta, gamma)
    corners = np.r_[np.linspace(0, 3, 4), np.linspace(3, -2, 6)[1:], np.linspace(-2, 1, 4)[1:]]  # every 1000th
    np.testing.assert_allclose(g.bouc_wen_n2(corners, beta, gamma), fine[::1000], rtol=1e-9, atol=1e-12)


def test_staircase_ramp_and_random_motion():
    v = g.staircase(4.0, 0.0, 2.0, seed=3)
    times, values = np.array(v.times), np.array(v.values)
    assert times[0] == 0.0 and times[-1] == 4.0 and np.all(np.diff(times) > 0)
    assert values.min() >= 0.0 and values.max() <= 2.0
    ramps = np.diff(times)[1:-1:2]  # level, (slew, hold)* ...: the ramps are every other interval after the first
    np.testing.assert_allclose(ramps, 0.005, atol=1e-12)
    holds = np.r_[times[1], np.diff(times)[2:-1:2]]
    assert np.all((holds >= 0.3 - 1e-12) & (holds <= 0.8 + 1e-12)), holds
    steps = np.abs(np.diff(values[::2]))
    assert np.all(steps[:-1] >= 0.3)  # each new level at least min_step from the one before
    assert len(steps) >= 4  # 4 s of 0.3–0.8 s levels
    t = np.arange(1001) / 250.0
    np.testing.assert_allclose(v(t[:3]), values[0])  # a staircase of levels, sampled
    p = g.ramp(4.0, 0.02, 0.09, lead=0.5)
    np.testing.assert_allclose(p(np.array([0.0, 0.5, 2.0, 3.5, 4.0])), [0.02, 0.02, 0.055, 0.09, 0.09])
    sig = g.random_motion(8.0, 0.5, 3.0, 8, seed=1, duration=4.0)
    assert np.max(np.abs(sig.x(t))) == pytest.approx(8.0, rel=1e-3)
    assert all(0.5 <= f <= 3.0 for f in sig.frequencies)
    assert sig.x(np.array([0.0]))[0] == 0.0 and sig.v(np.array([0.0]))[0] == 0.0  # from rest
    tf = np.linspace(0, 4, 40001)
    np.testing.assert_allclose(sig.v(tf)[1:-1], np.gradient(sig.x(tf), tf)[1:-1], atol=1e-3)


def test_mr_lag_law_response_follows_the_lagged_voltage():
    """Under a voltage step (a ramp of one fine step, h) the coil state is the first-order solution,
    u = 1.5 − e^(−η (t − t₁)) (e^(ηh) − 1) / (ηh) after it (the exact integrator), so the force moves to the new
    level with the time constant 1/η: F is linear in u, and its distance from the instantaneous response is that
    share of the jump; before the step it is the low voltage's response, five time constants later the high
    one's; and the voltage changes the force (damping and hysteretic force alike)."""
    eta, t1 = 50.0, 1.0
    t = np.arange(751) / 250.0
    h = 0.004 / 20  # one step of the 20x finer grid the law is computed on
    volts = g.Schedule((0.0, t1, t1 + h, 3.0), (0.5, 0.5, 1.5, 1.5))
    sig = g.random_motion(8.0, 0.5, 3.0, 8, seed=2, duration=3.0)
    tf = g.fine_grid(t, 20)
    u = g.linear_lag(tf, eta * volts(tf), eta, y0=0.5)
    share = lambda tt: np.exp(-eta * (tt - t1)) * np.expm1(eta * h) / (eta * h)  # noqa: E731
    after = tf >= t1 + h - 1e-12
    np.testing.assert_allclose(u[after], 1.5 - share(tf[after]), rtol=1e-9)
    lagged = on_fine(mr_lag_law(volts, eta=eta, **MR_TRUTH), 20)(t, sig)
    instant = on_fine(mr_lag_law(volts, eta=1e6, **MR_TRUTH), 20)(t, sig)
    low = on_fine(mr_lag_law(g.Schedule((0.0, 3.0), (0.5, 0.5)), eta=eta, **MR_TRUTH), 20)(t, sig)
    high = on_fine(mr_lag_law(g.Schedule((0.0, 3.0), (1.5, 1.5)), eta=eta, **MR_TRUTH), 20)(t, sig)
    assert np.sqrt(np.mean((high - low) ** 2)) > 0.3 * np.std(low)  # the voltage changes the response
    np.testing.assert_allclose(lagged[t <= t1], low[t <= t1], atol=1e-9)
    np.testing.assert_allclose(instant[t > t1 + 0.01], high[t > t1 + 0.01], atol=1e-6)
    moving = (t > t1) & (np.abs(high - low) > 1.0)
    np.testing.assert_allclose((lagged - instant)[moving] / (low - high)[moving], share(t[moving]), rtol=1e-6,
                               atol=1e-9)
    assert np.max(np.abs(lagged - high)[t >= t1 + 5 / eta]) < 0.01 * np.max(np.abs(high - low))


def test_control_friction_law_level_follows_the_ramp():
    """At each upward zero crossing of x = −A cos 2πft the force is c A ω + level(p(t)) (x = 0, sgn ẋ = 1): the
    crossings' forces rise along an increasing ramp by the level's rise."""
    a, f, c = 5.0, 1.0, 0.6
    p = g.ramp(4.0, 0.02, 0.09, lead=0.5)
    law = control_friction_law(p, k=4.0, c=c, level=lambda q: 10.0 + 400.0 * q)
    crossings = (np.arange(4) + 0.25) / f  # x = 0, ẋ = A ω
    F = law(crossings, g.sine(a, f, phase=-math.pi / 2))
    np.testing.assert_allclose(F, c * a * 2 * math.pi * f + 10.0 + 400.0 * p(crossings), rtol=1e-12)
    assert F[-1] - F[0] == pytest.approx(400.0 * (p(crossings[-1:])[0] - p(crossings[:1])[0]))


# -- the two cases -----------------------------------------------------------------------------------------------


def test_control_cases_records_split_and_nominals():
    """Both cases: every record carries its control channel, which varies within it; the only condition is the
    categorical ``set`` (4 fit, 1 val, 1 held out), so discovery offers no numeric condition as a trend; the
    nominal's parameters are constants and it lacks the expected effect."""
    import torch

    from hybridhyst.physics.models import conditions_used
    from hybridhyst.testbed.cases import CASE_BY_NAME

    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    try:
        for name, control in ((MR, "voltage"), (RAMP, "pressure_mpa")):
            case = CASE_BY_NAME[name]
            assert case.category == "condition"
            records = case.records()
            train, val, test = records.split(**case.split)
            assert (len(train), len(val), len(test)) == (4, 1, 1)
            for r in records:
                assert set(r.controls) == {control} and set(r.conditions) == {"set"}
                assert isinstance(r.conditions["set"], str)
                assert np.ptp(r.controls[control]) > 0 and np.all(np.isfinite(r.y))
            nominal = case.nominal()
            assert not conditions_used(nominal)  # constant parameters: the dependence on the control is to be found
            assert not {e.name for e in nominal.effects.values()} & set().union(*case.expected)
    finally:
        torch.set_default_dtype(old)
    mr = CASE_BY_NAME[MR]
    assert mr.expected == (frozenset({"control_lag"}),) and mr.keys[0][0] == "lag_voltage.eta"
    volts = np.concatenate([r.controls["voltage"] for r in mr.records()])
    assert volts.min() >= 0.0 and volts.max() <= 2.0 and len(np.unique(np.round(volts, 6))) > 20
    pressures = [r.controls["pressure_mpa"] for r in CASE_BY_NAME[RAMP].records()]
    assert all(abs(p[-1] - p[0]) >= 0.03 for p in pressures)  # a ramp within every record
    assert {np.sign(p[-1] - p[0]) for p in pressures} == {-1.0, 1.0}  # up and down


def test_library_truth_reproduces_the_control_cases_to_the_noise():
    """The library's model of each truth (a lag of the voltage before functions of it; a Coulomb level linear in
    the pressure) simulates the records to their noise: what the loop is asked to find is expressible, and the
    generators' conventions (lag starting at the first voltage, n = 2 Bouc–Wen, A = 1) are the library's."""
    import torch

    from hybridhyst.physics.build import build_model
    from hybridhyst.simulate import simulate
    from hybridhyst.testbed.cases import CASE_BY_NAME, MM_UNITS, MR_ETA

    def lin(a, b, c):
        return {"kind": "linear", "intercept": a, "slope": b, "condition": c}

    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    try:
        mr = build_model("constitutive", {
            "lag_voltage": {"effect": "control_lag", "control": "voltage", "eta": MR_ETA},
            "viscous": {"effect": "viscous", "c": lin(1.0, 1.5, "voltage")},
            "stiffness": {"effect": "linear_stiffness", "k": 2.0},
            "hysteresis": {"effect": "bouc_wen", "kappa": lin(20.0, 60.0, "voltage"), "beta": 0.4, "gamma": 0.3,
                           "n": 2.0, "alpha": 0.0, "k": 1.0, "k1": 0.0, "A": 1.0, "D": 1.0,
                           "fixed": ["alpha", "k", "k1", "A", "D"]}}, units=MM_UNITS).double()
        ramp = build_model("constitutive", {
            "spring": {"effect": "linear_stiffness", "k": 4.0}, "viscous": {"effect": "viscous", "c": 0.6},
            "coulomb": {"effect": "coulomb", "Fc": lin(10.0, 400.0, "pressure_mpa"), "v_s": 0.1,
                        "fixed": ["v_s"]}}, units=MM_UNITS).double()
        for name, model in ((MR, mr), (RAMP, ramp)):
            case = CASE_BY_NAME[name]
            records = case.records().records
            with torch.no_grad():
                out = simulate(model, records, backend="reference")
            rmse = [float(np.sqrt(np.mean((o.numpy()[:, 0] - r.y) ** 2))) for o, r in zip(out, records)]
            assert max(rmse) < 1.1 * case.noise, (name, rmse)
            nominal = case.nominal()
            with torch.no_grad():
                out = simulate(nominal, records, backend="reference")
            assert min(float(np.sqrt(np.mean((o.numpy()[:, 0] - r.y) ** 2))) for o, r in zip(out, records)) \
                > 3 * case.noise, name  # the nominal as declared is far from the data
    finally:
        torch.set_default_dtype(old)
