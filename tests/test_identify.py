"""Batched identification: DE / CMA-ES, refinement, Fisher analysis, joint fits, the CLI and its configs, step
doubling; the search space's boxes and values: ``tests/test_identify_space.py``; Levenberg–Marquardt:
``tests/test_identify_refine.py``."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir

from hybridhyst.cli import identify as identify_cli
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.data import Record, RecordSet
from hybridhyst.identify import (
    RecordsProblem,
    SearchSpace,
    cma_es,
    differential_evolution,
    fisher_analysis,
    identify,
    output_jacobian,
    refine,
)
from hybridhyst.identify.refine import levenberg_marquardt
from hybridhyst.physics.effects import EFFECTS, Viscous
from hybridhyst.physics.models import Constitutive
from hybridhyst.simulate import simulate

TRUE = {"dahl.Fc": 2.0, "dahl.sigma0": 10.0, "viscous.c": 0.5}
BOUNDS = {"dahl.Fc": (0.5, 8.0), "dahl.sigma0": (2.0, 50.0), "viscous.c": (0.05, 2.0)}


def _dahl(Fc=1.0, sigma0=20.0, c=0.2) -> Constitutive:
    """Viscous + Dahl friction law (in, kip, s) in float64."""
    effects = {"viscous": Viscous(c=c), "dahl": EFFECTS["dahl"](Fc=Fc, sigma0=sigma0)}
    return Constitutive(effects, units={"x": "in", "F": "kip", "t": "s"}, name="dahl").double()


def _records(model, conditions_list, n=301) -> RecordSet:
    """Noise-free synthetic loops: 1 in, 1 Hz sine over 1.5 cycles, one record per condition set."""
    t = np.linspace(0.0, 1.5, n)
    x = np.sin(2 * np.pi * t)
    out = []
    for i, cond in enumerate(conditions_list):
        with torch.no_grad():
            y = simulate(model, torch.as_tensor(x)[None], t=torch.as_tensor(t), conditions=cond or None,
                         backend="fast")[0, :, 0].numpy()
        out.append(Record(name=f"r{i}", t=t, x=x, y=y, conditions=cond, units={"x": "in", "y": "kip"}))
    return RecordSet(out, "synthetic")


@pytest.fixture(scope="module")
def dahl_data():
    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    yield _records(_dahl(**{k.split(".")[1]: v for k, v in TRUE.items()}), [{}])
    torch.set_default_dtype(old)


def _problem(records, bounds=BOUNDS, model=None):
    space = SearchSpace(model or _dahl(), bounds)
    return RecordsProblem(space, list(records))


def _relative_error(space, x) -> float:
    return max(abs(float(x[i]) / TRUE[n] - 1) for i, n in enumerate(space.names))


def test_search_space_coordinates_bounds_and_write_back(float64):
    model = Constitutive({"viscous": Viscous(c=0.0), "dahl": EFFECTS["dahl"](
        Fc={"kind": "linear", "slope": 20.0, "intercept": 1.0}, sigma0=10.0)})
    space = SearchSpace(model, {"dahl.sigma0": (1.0, 100.0)})
    assert space.names == ["viscous.c", "dahl.sigma0", "dahl.Fc.c0", "dahl.Fc.c1"]
    c = {co.name: co for co in space.coordinates}
    assert (c["viscous.c"].lower, c["viscous.c"].upper) == (0.0, 1.0)  # v = 0: (-1, 1) within spec (0, 1e6)
    assert (c["dahl.Fc.c1"].lower, c["dahl.Fc.c1"].upper) == (2.0, 200.0)
    X = torch.tensor([[0.1, 5.0, 1.0, 20.0], [0.2, 6.0, 2.0, 10.0]])
    P = space.values(X, {"pressure_mpa": torch.tensor([0.0, 0.1, 0.2])}, 3)
    assert torch.allclose(P["dahl"]["Fc"], torch.tensor([1.0, 3.0, 5.0, 2.0, 3.0, 4.0]))
    assert torch.equal(P["viscous"]["c"], torch.tensor([0.1] * 3 + [0.2] * 3))
    space.to_model(X[1])
    assert torch.allclose(space.initial(), X[1])
    with pytest.raises(ValueError, match="unknown coordinate"):
        SearchSpace(model, {"dahl.nope": (0, 1)})


@pytest.mark.parametrize("search", [differential_evolution, cma_es])
def test_global_search_recovers_dahl_law(search, dahl_data):
    problem = _problem(dahl_data)
    kw = {"pop": 24, "generations": 150} if search is differential_evolution else {"generations": 150}
    found = search(problem.cost, problem.space, seed=1, target=1e-10, progress=False, **kw)
    assert found.cost < 1e-8 or _relative_error(problem.space, found.x) < 0.01
    assert _relative_error(problem.space, found.x) < 0.01
    assert found.history == sorted(found.history, reverse=True)  # best cost never increases


def test_a_coordinate_the_box_stops_is_reported_at_its_edge(dahl_data):
    """The truth (c = 0.5) lies above a box that ends at 0.2: the fit ends on that edge and says so; a box
    holding the truth flags nothing."""
    opts = {"search": "de", "pop": 16, "generations": 10, "seed": 0, "progress": False, "fisher": False}
    res = identify(_dahl(), dahl_data, bounds={**BOUNDS, "viscous.c": (0.05, 0.2)}, **opts)
    assert res.at_bounds == {"viscous.c": "upper"} and res.x["viscous.c"] == pytest.approx(0.2, rel=1e-3)
    assert identify(_dahl(), dahl_data, bounds=BOUNDS, **opts).at_bounds == {}


def test_same_seed_same_result_and_diverging_members_get_inf(dahl_data):
    # absurd bounds: sigma0 up to 1e9 makes the explicit RK4 state blow up for many members
    problem = _problem(dahl_data, {**BOUNDS, "dahl.sigma0": (2.0, 1e9)})
    runs = [differential_evolution(problem.cost, problem.space, pop=16, generations=8, seed=3, progress=False)
            for _ in range(2)]
    assert runs[0].non_finite > 0
    assert math.isfinite(runs[0].cost)
    assert torch.equal(runs[0].x, runs[1].x) and runs[0].history == runs[1].history
    other = differential_evolution(problem.cost, problem.space, pop=16, generations=8, seed=4, progress=False)
    assert not torch.equal(other.x, runs[0].x)


def test_fit_that_ends_non_finite_names_the_parameter(dahl_data):
    with pytest.raises(ValueError, match=r"dahl\.sigma0"):
        identify(_dahl(), dahl_data, bounds={**BOUNDS, "dahl.sigma0": (1e8, 1e9)}, pop=8, generations=2,
                 progress=False)


def test_refinement_reduces_cost(dahl_data):
    problem = _problem(dahl_data)
    starts = torch.tensor([[1.5, 14.0, 0.3], [3.0, 6.0, 0.8], [1.0, 30.0, 1.5]])
    c0 = problem.cost(starts)
    grad = refine(problem.cost, problem.space, starts, adam_steps=20, lbfgs_steps=20, progress=False)
    assert (grad.costs < c0).all() and grad.cost < 0.01 * float(c0.min())
    lm = levenberg_marquardt(problem.residuals, problem.space, starts, iters=30, progress=False)
    assert lm.cost < 1e-10 and _relative_error(problem.space, lm.x) < 1e-4
    K, D = starts.shape
    assert K * (D + 1) <= lm.evaluations <= K * (D + 1) * (len(lm.history))  # rows: Jacobians only on accepts


def test_search_on_decimated_records_still_identifies(dahl_data):
    """The global search may run on every 2nd sample; refinement and the reported cost use all samples."""
    res = identify(_dahl(), dahl_data, search="de", bounds=BOUNDS, pop=16, generations=15, search_decimate=2,
                   fisher=False, progress=False, seed=1)
    problem = _problem(dahl_data)
    x = torch.tensor([res.x[n] for n in problem.space.names])
    assert res.cost == pytest.approx(float(problem.cost(x[None])[0]), rel=1e-9)  # scored on the full grid
    assert _relative_error(problem.space, x) < 1e-3


def test_fisher_finds_the_sum_of_two_parallel_viscous_terms(float64):
    model = Constitutive([Viscous(c=1.0), Viscous(c=2.0)]).double()  # keys viscous, viscous_2
    t = np.linspace(0, 1, 101)
    rec = Record(name="v", t=t, x=np.sin(2 * np.pi * t), y=np.zeros_like(t))
    problem = RecordsProblem(SearchSpace(model), [rec], backend="reference")  # no compile for a one-off model
    x = problem.space.initial()
    J = output_jacobian(problem.predict, x, method="autograd")
    assert torch.allclose(J, output_jacobian(problem.predict, x, method="fd"), rtol=1e-5, atol=1e-8)
    lin = fisher_analysis(J, x, problem.space.names, sigma=0.1, log=torch.zeros(2, dtype=torch.bool))
    assert lin.eigenvalues[1] < 1e-10 * lin.eigenvalues[0]
    v = lin.eigenvectors[:, 0]
    assert torch.allclose(v / v[0], torch.ones(2))  # identifiable: c1 + c2
    assert lin.identifiable == ["+1·viscous.c +1·viscous_2.c"]
    assert set(lin.non_identifiable) == {"viscous.c", "viscous_2.c"} and math.isinf(lin.sd["viscous.c"])
    log = fisher_analysis(J, x, problem.space.names, sigma=0.1)  # log scale: direction ∝ ∇ log(c1 + c2) ∝ x
    v = log.eigenvectors[:, 0]
    assert torch.allclose(v / v[0], x / x[0])


def test_fisher_sd_matches_known_linear_regression(float64):
    J = torch.tensor([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [1.0, 3.0]])
    rep = fisher_analysis(J, torch.tensor([1.0, -2.0]), ["a", "b"], sigma=0.5, log=torch.zeros(2, dtype=torch.bool))
    cov = 0.25 * torch.linalg.inv(J.T @ J)
    assert rep.sd["a"] == pytest.approx(float(cov[0, 0].sqrt()))
    assert rep.sd["b"] == pytest.approx(float(cov[1, 1].sqrt()))
    assert rep.non_identifiable == []


def test_joint_identification_linear_in_pressure(float64):
    truth = _dahl(sigma0=10.0, c=0.5)
    truth.effects["dahl"].params["Fc"] = _linear(1.0, 20.0)
    pressures = [0.02, 0.05, 0.08]
    data = _records(truth, [{"pressure_mpa": p} for p in pressures])
    model = _dahl(sigma0=15.0, c=0.3)
    model.effects["dahl"].params["Fc"] = _linear(1.5, 12.0)
    res = identify(model, data, pop=24, generations=15, restarts=4, lm_steps=30, seed=0, progress=False,
                   noise_sd=None, target=1e-14)
    expected = {"dahl.Fc.c0": 1.0, "dahl.Fc.c1": 20.0, "dahl.sigma0": 10.0, "viscous.c": 0.5}
    for name, value in expected.items():
        assert res.x[name] == pytest.approx(value, rel=1e-2)
    assert set(res.per_record) == {"r0", "r1", "r2"} and res.rmse < 1e-4
    assert "pressure_mpa" in res.parameters["dahl"]["Fc"]["value"]


def _linear(intercept, slope):
    from hybridhyst.physics.parameters import Linear

    return Linear(slope=slope, intercept=intercept).double()


def test_cli_run_writes_summary(tmp_path, capsys):
    overrides = [f"run_dir={tmp_path}", "progress=false", "data.mixtures=[1:3]", "data.pressures=[0.05]",
                 "data.cycles=1", "data.samples_per_cycle=240", "identify.pop=8", "identify.generations=2",
                 "identify.restarts=2", "identify.lm_steps=2", "simulation.substeps=2"]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(config_name="identify", overrides=overrides)
    summary = identify_cli.run(cfg)
    saved = json.loads((tmp_path / "summary.json").read_text())
    for key in ("parameters", "rmse", "per_record", "wall_s", "identifiable"):
        assert key in saved and key in summary
    assert set(saved["per_record"]) == {"1:3_p0.05"} and saved["rmse"] > 0
    assert saved["parameters"]["hysteresis"]["k"]["unit"] == "Nm/deg"
    assert (tmp_path / "loops.png").stat().st_size > 0 and (tmp_path / "report.md").exists()
    out = capsys.readouterr().out  # a summary on the terminal: the error in the data's unit, the values, the report
    assert f"RMSE {saved['rmse']:.4g} Nm" in out and "hysteresis.k = " in out and "report.md" in out
    assert f"Pooled RMSE {saved['rmse']:.4g} Nm" in (tmp_path / "report.md").read_text()


MR_TRUTH = {"viscous.c": 2.0, "stiffness.k": 0.8, "hysteresis.kappa": 80.0, "hysteresis.beta": 0.3,
            "hysteresis.gamma": 0.3, "hysteresis.n": 2.0}


def _mr_loops(path, tests=((5.0, 1.0), (10.0, 0.5), (10.0, 2.0)), noise=2.0, seed=3):
    """MR-damper loops of my own (the test bed's scipy generator, ``testbed.generators.mr_damper``: 20 internal
    steps per sample, 400 Hz) written to a CSV."""
    import pandas as pd

    from hybridhyst.testbed.generators import mr_damper

    rng, rows = np.random.default_rng(seed), []
    for amp, f in tests:
        t = np.arange(0.0, 2 / f, 1 / 400)
        x = amp * np.sin(2 * np.pi * f * t)
        force = mr_damper(t, amp, f, *MR_TRUTH.values()) + rng.normal(0.0, noise, len(t))
        rows.append(pd.DataFrame({"record": f"a{amp}_f{f}", "t": t, "x_mm": x, "F_N": force}))
    pd.concat(rows).to_csv(path, index=False)
    return path


def _mr_config(tmp_path, path, *overrides):
    overrides = [f"run_dir={tmp_path / 'run'}", "progress=false", "data=table", f"data.path={path}",
                 "data.record=record", "data.input=x_mm", "data.output=F_N", "data.units={t: s, x: mm, y: N}",
                 "model=mr_damper", "noise_sd=2.0", *overrides]
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="identify", overrides=overrides)


def _identify_mr(tmp_path, path, *overrides):
    return identify_cli.run(_mr_config(tmp_path, path, *overrides))


def test_the_mr_damper_config_identifies_loops_made_without_the_library(tmp_path):
    """conf/model/mr_damper.yaml from its defaults on MR-damper loops of my own (2 N noise): every free
    parameter within 3 % of the truth, the RMSE at the noise."""
    summary = _identify_mr(tmp_path, _mr_loops(tmp_path / "mr.csv"), "identify.fisher=false")
    for name, value in MR_TRUTH.items():
        assert summary["coordinates"][name] == pytest.approx(value, rel=0.03), name
    assert summary["rmse"] < 1.05 * 2.0 and not summary["at_bounds"]
    # the app checks the sub-steps by step doubling (identify.resolve): 400 Hz needs one per sample
    assert summary["simulation"]["substeps"] == 1 and summary["simulation"]["resolution"] <= 1e-3


def test_standard_deviations_are_given_at_the_least_squares_minimum(tmp_path):
    """With noise_sd the search stops at cost <= (1.01 noise_sd)^2, short of the minimum; the Fisher standard
    deviations describe the minimum's scatter (in a Monte Carlo of 16 noise draws of this record the early-stopped
    κ scattered 1.47x its reported sd, the minimum's 0.97x), so identify goes on to the minimum before them:
    more Levenberg–Marquardt from the reported values lowers the cost by less than 1e-6 (early-stopped: 9e-4)."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    from hybridhyst.identify.identify import RecordsProblem
    from hybridhyst.identify.space import SearchSpace

    cfg = _mr_config(tmp_path, _mr_loops(tmp_path / "mr.csv", tests=((10.0, 1.0),), seed=100))
    summary = identify_cli.run(cfg)
    assert summary["uncertainty"] and summary["rmse"] < 1.05 * 2.0
    # white noise: the residual's lag-1 autocorrelation near 0 and no note doubting the sd
    report = (tmp_path / "run" / "report.md").read_text()
    assert abs(summary["residual_lag_1"]) < 0.1 and "autocorrelation" not in report
    model = instantiate(OmegaConf.load(tmp_path / "run" / "model" / "identified.yaml"), _convert_="all").double()
    space = SearchSpace(model)
    problem = RecordsProblem(space, list(identify_cli._load(cfg)), substeps=int(cfg.simulation.substeps))
    x = space.initial()
    before = float(problem.cost(x[None])[0])
    after = levenberg_marquardt(problem.residuals, space, x[None], iters=40, progress=False).cost
    assert before == pytest.approx(summary["rmse"] ** 2, rel=1e-6)
    assert (before - after) / before < 1e-6, (before, after)


def test_a_residual_correlated_in_time_puts_the_standard_deviations_in_doubt():
    coloured = {"residual_lag_1": 0.8, "uncertainty": {"stiffness.k": 0.03}}
    assert "0.80" in identify_cli.coloured_note(coloured) and "larger" in identify_cli.coloured_note(coloured)
    assert identify_cli.coloured_note({**coloured, "residual_lag_1": 0.1}) == ""
    assert identify_cli.coloured_note({**coloured, "uncertainty": {}}) == ""  # no sd given: nothing to doubt


def test_step_doubling_identifies_loops_that_one_step_per_sample_cannot_follow():
    """Sharp classic Bouc–Wen loops (n = 4) by scipy's solve_ivp, 40 samples per cycle: at one RK4 step per
    sample the identified model is shaped by the integrator's error; with ``resolve`` identify goes on at the
    sub-steps step doubling chooses and ends near the data (noise-free), with the shape parameters close."""
    from scipy.integrate import solve_ivp

    from hybridhyst.physics.compositions import bouc_wen_classic

    A, beta, gamma, n, alpha = 6.0, 3.5, -2.5, 4.0, 0.35

    def rate(s, z, amp):
        v = amp * 2 * np.pi * np.cos(2 * np.pi * s)
        return [A * v - beta * abs(v) * abs(z[0]) ** (n - 1) * z[0] - gamma * v * abs(z[0]) ** n]

    records = []
    for amp in (2.0, 5.0):
        t = np.arange(81) / 40
        z = solve_ivp(rate, (0, 2), [0.0], t_eval=t, args=(amp,), rtol=1e-10, atol=1e-12, max_step=5e-4).y[0]
        x = amp * np.sin(2 * np.pi * t)
        records.append(Record(f"a{amp}", t, x, alpha * x + (1 - alpha) * z, conditions={"amplitude": amp}))
    def run(resolve, seed=4, **kw):
        model = bouc_wen_classic(A=5.0, beta=3.0, gamma=-2.0).double()
        kw = {"fisher": False, **kw}
        return identify(model, records, progress=False, resolve=resolve, generations=15, seed=seed, **kw)

    plain, resolved = run(False), run(True)
    assert plain.substeps == 1 and math.isnan(plain.resolution)
    assert resolved.substeps >= 4 and resolved.resolution <= 1e-3
    with torch.no_grad():
        pred = simulate(resolved.model, records, substeps=resolved.substeps, backend="fast")
    peak = max(float(np.abs(r.y).max()) for r in records)
    rmse = float(np.sqrt(np.mean(np.concatenate([(p[:, 0].numpy() - r.y) ** 2 for p, r in zip(pred, records)]))))
    assert rmse < 0.01 * peak and resolved.rmse == pytest.approx(rmse, rel=1e-6)
    # one step per sample: 2.3 % of the peak and n = 0.64 with γ at its box edge (measured); resolved: 5e-5, n = 3.99
    assert plain.rmse > 10 * resolved.rmse and resolved.x["hysteresis.n"] == pytest.approx(n, rel=0.05)
    # The refit at a finer step starts in the basin of the coarser fit, shaped by the integrator's error; the search
    # again at each finer step escapes it. Over search seeds 0-5, all 6 reach the resolved fit (8 sub-steps, 1.4e-4)
    # and 1 without the second search (the others stopped at 4 sub-steps, 0.7-1.1 % of the peak; measured 2026-11-25).
    reached = [seed for seed in range(6) if run(True, seed).rmse < 5e-4 * peak]
    assert len(reached) >= 5, reached


def test_step_doubling_with_a_noise_level_ends_at_the_least_squares_minimum():
    """With ``noise_sd`` the search stops at the noise level; the Fisher analysis needs the least-squares minimum,
    also where step doubling refitted at a finer step (lm_steps from the coarser fit): LM from the result gains
    nothing. The noise level given (0.02) is above the data's (none), so the search stops far short of it."""
    from scipy.integrate import solve_ivp

    from hybridhyst.physics.compositions import bouc_wen_classic

    def rate(s, z, amp):  # sharp classic Bouc–Wen loops by scipy (A, β, γ, n = 6, 3.5, -2.5, 4; α = 0.35)
        v = amp * 2 * np.pi * np.cos(2 * np.pi * s)
        return [6.0 * v - 3.5 * abs(v) * abs(z[0]) ** 3 * z[0] + 2.5 * v * abs(z[0]) ** 4]

    records = []
    for amp in (2.0, 5.0):
        t = np.arange(81) / 40
        z = solve_ivp(rate, (0, 2), [0.0], t_eval=t, args=(amp,), rtol=1e-10, atol=1e-12, max_step=5e-4).y[0]
        x = amp * np.sin(2 * np.pi * t)
        records.append(Record(f"a{amp}", t, x, 0.35 * x + 0.65 * z))
    start = bouc_wen_classic(A=5.0, beta=3.0, gamma=-2.0).double
    # Before, seed 1 ended at 7.3e-6 (8 sub-steps; the minimum 2e-8): a fit from the search again at the finer step,
    # stopped at the target, was taken for one refined on (measured 2026-11-25). Not every seed gets there: from
    # some points lm_steps (40) do not cross the valley of this sharp loop (2.8e-4 where 80 steps reach 4e-5).
    for seed in (1, 2):
        res = identify(start(), records, progress=False, resolve=True, generations=15, seed=seed, noise_sd=0.02)
        assert res.substeps >= 4 and res.fisher is not None
        problem = RecordsProblem(SearchSpace(start()), records, substeps=res.substeps)  # identify's own boxes
        x = torch.tensor([res.x[n] for n in problem.space.names], dtype=torch.float64)
        after = levenberg_marquardt(problem.residuals, problem.space, x[None], iters=40, progress=False).cost
        assert res.cost - after < 1e-3 * 0.02**2, (seed, res.cost, after)  # 0.1 % of the noise level's MSE


def _sine_damper_records(k, c, Fc=0.0, noise=0.5, seed=3) -> list[Record]:
    """Loops of F = k x + c v + Fc sgn(v) in closed form (numpy, no library code), white noise ``noise``."""
    rng = np.random.default_rng(seed)
    out = []
    for i, (amp, f) in enumerate([(2.0, 1.0), (1.0, 3.0)]):
        t = np.arange(0.0, 2.0, 1.0 / 400.0)
        x, v = amp * np.sin(2 * np.pi * f * t), amp * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
        y = k * x + c * v + Fc * np.sign(v) + noise * rng.standard_normal(t.size)
        out.append(Record(name=f"sine{i}", t=t, x=x, y=y, units={"x": "mm", "y": "N"}))
    return out


def test_a_declared_value_far_from_the_data_is_followed_out_of_its_box(float64):
    """A spring declared at 1/60 of what the loops show: the default box (÷/× 10 about it) stops the fit at its upper
    edge, which the result says; with ``recentre`` the search runs again around the edge, reaches the noise and
    says how many times it moved. A Coulomb level the data lack, pressed against its lower edge, is followed
    down only while that lowers the cost by 1 % or more (each box ends a factor 10 lower): not to the cap."""
    def model(k, Fc=None):
        effects = {"spring": EFFECTS["linear_stiffness"](k=k), "viscous": Viscous(c=30.0)}
        if Fc is not None:
            effects["coulomb"] = EFFECTS["coulomb"](Fc=Fc)
        return Constitutive(effects, units={"x": "mm", "F": "N", "t": "s"}).double()

    records = _sine_damper_records(600.0, 40.0)
    opts = {"progress": False, "fisher": False, "seed": 0}
    plain = identify(model(10.0), records, **opts)
    assert plain.at_bounds.get("spring.k") == "upper" and plain.rmse > 10 * 0.5 and plain.recentred == 0
    followed = identify(model(10.0), records, recentre=3, **opts)
    assert followed.recentred >= 1 and not followed.at_bounds
    assert followed.rmse < 1.05 * 0.5 and followed.x["spring.k"] == pytest.approx(600.0, rel=0.01)
    assert followed.evaluations > plain.evaluations and followed.wall_s > 0
    # the identifiability analysis at the point kept (the passes skip it): a standard deviation of k at 600
    analysed = identify(model(10.0), records, recentre=3, progress=False, seed=0, noise_sd=0.5)
    assert analysed.recentred >= 1 and 0 < analysed.uncertainty["spring.k"] < 0.01 * analysed.x["spring.k"]
    assert len(followed.history["search"]) == len(plain.history["search"]) + followed.recentred  # one generation each
    vanishing = identify(model(600.0, Fc=5.0), records, recentre=5, **opts)
    assert vanishing.rmse < 1.05 * 0.5 and 1 <= vanishing.recentred < 5
    assert vanishing.x["coulomb.Fc"] < 0.1
    # a box the user gave is theirs: its edge is reported, not followed (nothing more is simulated)
    bounded = identify(model(10.0), records, recentre=3, bounds={"spring.k": (1.0, 100.0)}, **opts)
    assert bounded.recentred == 0 and bounded.at_bounds == {"spring.k": "upper"}
    assert bounded.evaluations == identify(model(10.0), records, bounds={"spring.k": (1.0, 100.0)}, **opts).evaluations
    # a one-shot iterable of records serves every pass
    assert identify(model(10.0), iter(records), recentre=3, **opts).recentred == followed.recentred


def test_a_re_centred_pass_that_finds_nothing_better_leaves_the_model_at_the_fit_before_it(float64, monkeypatch):
    """The passes after the first fit keep the model only when they lower the cost: a pass that cannot (here one
    without a refinement, its 8 samples about the edge worse than the fit) is undone, the model's values are the
    result's, and the time it cost is counted."""
    import sys

    ident = sys.modules["hybridhyst.identify.identify"]  # the module (the package exports its function by that name)
    monkeypatch.setitem(ident.RECENTRED, "refine", "none")
    monkeypatch.setitem(ident.RECENTRED, "pop", 2)
    records = _sine_damper_records(600.0, 40.0)
    model = Constitutive({"spring": EFFECTS["linear_stiffness"](k=10.0), "viscous": Viscous(c=30.0)},
                         units={"x": "mm", "F": "N", "t": "s"}).double()
    opts = {"progress": False, "fisher": False, "seed": 0}
    first = identify(Constitutive({"spring": EFFECTS["linear_stiffness"](k=10.0), "viscous": Viscous(c=30.0)},
                                  units={"x": "mm", "F": "N", "t": "s"}).double(), records, **opts)
    res = identify(model, records, recentre=1, **opts)
    assert res.recentred == 0 and res.cost == first.cost and res.evaluations > first.evaluations
    assert float(model.effects["spring"].params["k"].value) == pytest.approx(res.x["spring.k"], rel=1e-12)


def test_a_re_centred_pass_is_kept_where_it_gains_or_finds_the_optimum_and_undone_where_a_value_runs_off(
        float64, monkeypatch):
    """With a gain no pass reaches (``RECENTRE_GAIN`` lowered): a pass that brings the value it followed inside its
    box (the spring's optimum found) is kept, and the passes end there; a pass that leaves it at an edge again (a
    Coulomb level the data lack, running off towards 0) is undone, and the model is the first fit's: followed for
    nothing it would only move the boxes that later fits start from (the control-blind first fit of an MR damper
    pushed its stiffness a decade lower for 0.02 %, and discovery then never found it again)."""
    import sys

    ident = sys.modules["hybridhyst.identify.identify"]
    records = _sine_damper_records(600.0, 40.0)
    opts = {"progress": False, "fisher": False, "seed": 0}

    def model(k, Fc=None):
        effects = {"spring": EFFECTS["linear_stiffness"](k=k), "viscous": Viscous(c=30.0)}
        if Fc is not None:
            effects["coulomb"] = EFFECTS["coulomb"](Fc=Fc)
        return Constitutive(effects, units={"x": "mm", "F": "N", "t": "s"}).double()

    monkeypatch.setattr(ident, "RECENTRE_GAIN", 1e-12)
    found = identify(model(10.0), records, recentre=3, **opts)
    assert found.recentred == 1 and not found.at_bounds and found.x["spring.k"] == pytest.approx(600.0, rel=0.01)
    first, m = identify(model(600.0, Fc=5.0), records, **opts), model(600.0, Fc=5.0)
    assert first.at_bounds["coulomb.Fc"] == "lower"
    res = identify(m, records, recentre=3, **opts)
    assert res.recentred == 0 and res.cost == first.cost and res.x == first.x
    assert float(m.effects["coulomb"].params["Fc"].value) == pytest.approx(first.x["coulomb.Fc"], rel=1e-12)


def test_warm_ups_of_records_of_two_lengths_interleaved(dahl_data):
    """Records of two lengths in turn (two groups whose records are not neighbours), each with its own warm-up:
    the cost, the per-record errors and the residuals are those of each record's samples after its warm-up."""
    clean = dahl_data[0]
    rng = np.random.default_rng(4)
    short = clean.slice(0, 201)
    records = [dataclasses.replace(r, name=f"r{i}", y=r.y + 0.05 * rng.standard_normal(len(r)), warmup=w)
               for i, (r, w) in enumerate([(clean, 40), (short, 10), (clean, 0), (short, 25)])]
    problem = _problem(records)
    X = problem.space.initial()[None].repeat(2, 1)
    X[1, 2] *= 0.7
    groups = problem.predict_groups(X)
    pred = {j: groups[g][:, col] for g, (idx, *_) in enumerate(problem.groups) for col, j in enumerate(idx)}
    res = [pred[j][:, r.warmup:] - torch.as_tensor(r.y[r.warmup:]) for j, r in enumerate(records)]
    assert problem.n_samples == sum(e.shape[1] for e in res) == 301 + 201 - 40 - 10 + 301 + 201 - 25
    assert torch.allclose(problem.cost(X), sum(e.square().sum(1) for e in res) / problem.n_samples)
    assert torch.allclose(problem.record_mse(X), torch.stack([e.square().mean(1) for e in res], 1))
    by_group = [torch.cat([res[j] for j in idx], 1) for idx, *_ in problem.groups]  # record-major within a group
    assert torch.allclose(problem.residuals(X), torch.cat(by_group, 1))
    r, J = problem.jacobian_rows(X, torch.ones(problem.space.dim, dtype=torch.bool))
    assert torch.allclose(r, problem.residuals(X)) and J.shape[1] == problem.n_samples


def test_warm_up_samples_are_simulated_but_not_scored(dahl_data):
    """A record's ``warmup`` samples (``Record``: simulated, not scored) leave every least-squares quantity
    untouched, whatever they hold; records of one length with different warm-ups are batched together."""
    clean = dahl_data[0]
    spoiled = clean.y.copy()
    spoiled[:40] += 100.0  # nonsense in the first 40 samples
    records = [dataclasses.replace(clean, name="a", y=spoiled, warmup=40),
               dataclasses.replace(clean, name="b", y=clean.y + 0.01, warmup=0)]
    problem = _problem(records)
    same = _problem([dataclasses.replace(records[0], y=clean.y), records[1]])  # the warm-up holding the truth
    X = problem.space.initial()[None].repeat(2, 1)
    X[1, 0] *= 1.3
    assert problem.n_samples == 2 * len(clean) - 40
    full = problem.predict_groups(X)[0]  # (2, 2, T): every sample simulated
    y = torch.as_tensor(np.stack([spoiled, clean.y + 0.01]))
    mse = torch.stack([(full[:, 0, 40:] - y[0, 40:]).square().mean(1), (full[:, 1] - y[1]).square().mean(1)], 1)
    assert torch.allclose(problem.record_mse(X), mse) and torch.allclose(same.record_mse(X), mse)
    sse = (full[:, 0, 40:] - y[0, 40:]).square().sum(1) + (full[:, 1] - y[1]).square().sum(1)
    assert torch.allclose(problem.cost(X), sse / problem.n_samples) and torch.allclose(same.cost(X), problem.cost(X))
    res = problem.residuals(X)
    assert res.shape == (2, problem.n_samples) and torch.allclose(res, same.residuals(X))
    assert torch.allclose(res[:, :len(clean) - 40], full[:, 0, 40:] - y[0, 40:])
    r, J = problem.jacobian_rows(X, torch.ones(problem.space.dim, dtype=torch.bool))
    assert torch.allclose(r, res) and J.shape == (2, problem.n_samples, problem.space.dim)
    h = 1e-6 * X[0, 0]
    step = X[:1].clone()
    step[0, 0] += h
    fd = (problem.residuals(step) - problem.residuals(X[:1]))[0] / h
    assert torch.allclose(J[0, :, 0], fd, rtol=1e-4, atol=1e-6)
