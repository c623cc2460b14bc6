"""Gradient identification through ``simulate``: parameter recovery on synthetic records, decimation."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybridhyst.data.decimate import decimate
from hybridhyst.data.records import Record
from hybridhyst.identify.gradient import fit_gradient
from hybridhyst.physics.effects import EFFECTS, Coulomb, Viscous
from hybridhyst.physics.models import Constitutive
from hybridhyst.simulate import simulate

pytestmark = pytest.mark.usefixtures("float64")  # tests/conftest.py




def _sine_records(model, amplitudes=(0.5, 1.5), f=1.0, n=64, cycles=2):
    t = np.arange(cycles * n + 1) / (f * n)
    records = []
    for a in amplitudes:
        x = a * np.sin(2 * np.pi * f * t)
        with torch.no_grad():
            y = simulate(model, x[None], t=t)[0, :, 0].numpy()
        records.append(Record(f"a{a}", t, x, y, conditions={"amplitude": a}))
    return records


def _dahl_model(c, fc_coulomb, fc_dahl, sigma0):
    return Constitutive({
        "viscous": Viscous(c=c),
        "coulomb": Coulomb(Fc=fc_coulomb, v_s=0.05, fixed=["v_s"]),
        "dahl": EFFECTS["dahl"](Fc=fc_dahl, sigma0=sigma0),
    })


def _values(model):
    return {f"{k}.{p}": float(fn(None, 1)[0].detach()) for k, e in model.effects.items() for p, fn in e.params.items()}


def test_recovers_coulomb_viscous_levels():
    truth = Constitutive({"viscous": Viscous(c=0.3), "coulomb": Coulomb(Fc=1.2, v_s=0.05, fixed=["v_s"])})
    records = _sine_records(truth)
    model = Constitutive({"viscous": Viscous(c=0.1), "coulomb": Coulomb(Fc=0.5, v_s=0.05, fixed=["v_s"])})
    result = fit_gradient(model, records, steps=0, lbfgs_steps=10, progress=False)
    got = _values(model)
    assert got["viscous.c"] == pytest.approx(0.3, rel=1e-4)
    assert got["coulomb.Fc"] == pytest.approx(1.2, rel=1e-4)
    assert got["coulomb.v_s"] == 0.05  # fixed parameters stay where they are
    assert result.loss < 1e-8 and result.steps == {"adam": 0, "lbfgs": result.steps["lbfgs"]}


def test_recovers_dahl_friction_from_a_wrong_start():
    truth = _dahl_model(0.05, 0.8, 2.0, 15.0)
    records = _sine_records(truth)
    model = _dahl_model(0.1, 0.4, 1.0, 8.0)
    result = fit_gradient(model, records, steps=30, lr=0.05, lbfgs_steps=15, progress=False, backend="fast")
    got = _values(model)
    assert result.loss < 1e-6
    assert got["dahl.sigma0"] == pytest.approx(15.0, rel=1e-2)
    assert got["dahl.Fc"] + got["coulomb.Fc"] == pytest.approx(2.8, rel=1e-2)  # the sliding level


def test_history_and_best_state():
    truth = _dahl_model(0.05, 0.8, 2.0, 15.0)
    records = _sine_records(truth, amplitudes=(1.0,))
    model = _dahl_model(0.1, 0.4, 1.0, 8.0)
    result = fit_gradient(model, records, steps=5, lr=0.05, progress=False)
    assert len(result.history) == 5 and result.steps == {"adam": 5, "lbfgs": 0}
    assert result.loss <= min(result.history) and result.n_samples == len(records[0])


def test_the_fit_says_whether_it_converged():
    """(On the compiled path: what is checked is the stopping, not the loop.)"""
    truth = _dahl_model(0.05, 0.8, 2.0, 15.0)
    records = _sine_records(truth, amplitudes=(1.0,))
    cut = fit_gradient(_dahl_model(0.1, 0.4, 1.0, 8.0), records, steps=0, lbfgs_steps=2, progress=False, backend="fast")
    assert cut.converged is False and cut.steps["lbfgs"] == 2 and cut.last_change > 1e-6
    done = fit_gradient(_dahl_model(0.1, 0.4, 1.0, 8.0), records, steps=0, lbfgs_steps=200, progress=False,
                        backend="fast")
    assert done.converged is True and done.steps["lbfgs"] < 200 and done.loss < 1e-3 * cut.loss
    adam = fit_gradient(_dahl_model(0.1, 0.4, 1.0, 8.0), records, steps=3, progress=False, backend="fast")
    assert adam.converged is None and np.isfinite(adam.last_change)


def test_decimation_per_record_and_validation():
    truth = Constitutive({"viscous": Viscous(c=0.3)})
    records = _sine_records(truth, n=64)
    thin = decimate(records[0], 4)
    assert len(thin) == 33 and thin.t[1] == records[0].t[4] and thin.conditions == records[0].conditions
    result = fit_gradient(Constitutive({"viscous": Viscous(c=0.1)}), records, steps=1,
                          downsample={"a0.5": 4, "a1.5": 8}, progress=False)
    assert result.n_samples == 33 + 17
    with pytest.raises(ValueError, match="decimation factor must be >= 1"):
        decimate(records[0], 0)
    with pytest.raises(ValueError, match="unknown loss"):
        fit_gradient(truth, records, steps=1, loss="huber", progress=False)


def test_diverging_simulation_is_a_clear_error():
    records = _sine_records(Constitutive({"viscous": Viscous(c=0.3)}), n=8)
    too_stiff = _dahl_model(0.1, 0.5, 1.0, 1e4)  # h·σ0|v|/Fc far beyond the RK4 stability limit
    with pytest.raises(ValueError, match="simulation diverged"):
        fit_gradient(too_stiff, records, steps=2, progress=False)


def _bouc_wen_loops(samples_per_cycle: int) -> list[Record]:
    """Classic Bouc–Wen damper loops (seed 004's caption shape, n = 4) integrated by scipy's solve_ivp on a grid
    50 times finer than the samples, shared with nothing in the library: sharp loops that an explicit step per
    sample cannot follow at 40 samples per cycle."""
    from scipy.integrate import solve_ivp

    A, beta, gamma, n, alpha, k = 6.0, 3.5, -2.5, 4.0, 0.35, 1.0

    def rate(s, z, amp):
        v = amp * 2 * np.pi * np.cos(2 * np.pi * s)
        return [A * v - beta * abs(v) * abs(z[0]) ** (n - 1) * z[0] - gamma * v * abs(z[0]) ** n]

    records = []
    for amp in (2.0, 5.0):
        t = np.arange(2 * samples_per_cycle + 1) / samples_per_cycle
        z = solve_ivp(rate, (0, t[-1]), [0.0], t_eval=t, args=(amp,), rtol=1e-10, atol=1e-12,
                      max_step=0.02 / samples_per_cycle).y[0]
        x = amp * np.sin(2 * np.pi * t)
        records.append(Record(f"a{amp}", t, x, alpha * k * x + (1 - alpha) * k * z, conditions={"amplitude": amp}))
    return records


def test_step_doubling_fits_loops_that_one_step_per_sample_cannot_follow():
    from hybridhyst.physics.compositions import bouc_wen_classic

    records = _bouc_wen_loops(40)
    start = dict(A=5.0, beta=3.0, gamma=-2.0)
    with pytest.raises(ValueError, match="diverged"):
        fit_gradient(bouc_wen_classic(**start), records, steps=5, progress=False, backend="fast")
    result = fit_gradient(bouc_wen_classic(**start), records, steps=30, lbfgs_steps=10, progress=False,
                          backend="fast", resolve=True)
    assert result.substeps >= 4 and result.resolution <= 1e-3
    with torch.no_grad():
        pred = simulate(result.model, records, substeps=result.substeps, backend="fast")
    rmse = float(np.sqrt(np.mean(np.concatenate([(p[:, 0].numpy() - r.y) ** 2 for p, r in zip(pred, records)]))))
    assert rmse < 0.05 * max(float(np.abs(r.y).max()) for r in records)
