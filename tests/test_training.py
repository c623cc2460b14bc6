"""Training stack units: data module (splits, windows, normalisation), nets, physics residuals, modules."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybridhyst.data import Record, RecordSet
from hybridhyst.data.datamodule import RecordDataModule
from hybridhyst.nets import MLP, LSTMNet, count_parameters, parse_hidden
from hybridhyst.physics.build import build_model
from hybridhyst.physics.models import InputSample
from hybridhyst.simulate import simulate
from hybridhyst.training import MODULES, predict_split, split_metrics
from hybridhyst.training.losses import hybrid_physics_residual, pinn_physics_residual, taylor_inputs


def _loops(levels=(1.0, 2.0, 3.0), n=200, offset=0.0) -> RecordSet:
    """Sine loops y = level·(x + 0.3 ẋ) + offset, condition 'level', 2 Hz-ish, 1 s."""
    t = np.linspace(0.0, 1.0, n)
    out = []
    for i, lv in enumerate(levels):
        x = np.sin(2 * np.pi * 2 * t)
        y = lv * (x + 0.3 * np.gradient(x, t)) + offset
        out.append(Record(name=f"r{i}", t=t, x=x, y=y, conditions={"level": lv, "kind": "sine"},
                          units={"x": "in", "y": "kip"}))
    return RecordSet(out, "loops")


def test_datamodule_splits_windows_and_normalises_on_training_records_only():
    dm = RecordDataModule(_loops(), held_out={"level": [3.0]}, val={"level": [2.0]}, conditions=["level"],
                          window=50, warmup=10, stride=25, batch_size=4)
    assert [len(dm.records(s)) for s in ("train", "val", "test")] == [1, 1, 1]
    y_train = dm.records("train").records[0].y
    assert dm.normaliser.mean["y"] == pytest.approx(y_train.mean())
    assert dm.normaliser.sd["y"] == pytest.approx(y_train.std())
    assert dm.normaliser.sd["level"] == 1.0  # one training level: a constant is not scaled
    starts = [s for _, s in dm._train.items]
    assert starts == [0, 25, 50, 75, 100, 125, 150]  # stride 25, the record's end covered
    first, later = dm._train[0], dm._train[1]
    assert first["mask"].sum() == 50 and later["mask"][:10].sum() == 0 and later["mask"][10:].sum() == 40
    assert later["y0"][0] == pytest.approx(y_train[25])
    whole = dm.whole("test")[0]
    assert whole["t"].shape == (200,) and whole["mask"].sum() == 200 and whole["cond"].tolist() == [3.0]


def test_a_records_warm_up_is_masked_in_every_window_and_whole_record():
    """``Record.warmup`` samples are simulated, not scored: a training window that starts inside it is masked up
    to its end (beside the window's own ``warmup``), a validation or test record over it."""
    import dataclasses

    loops = RecordSet([dataclasses.replace(r, warmup=30) for r in _loops()], "loops")
    dm = RecordDataModule(loops, held_out={"level": [3.0]}, val={"level": [2.0]}, window=50, warmup=10, stride=25,
                          batch_size=4)
    first, later, third = dm._train[0], dm._train[1], dm._train[2]
    assert first["mask"][:30].sum() == 0 and first["mask"][30:].sum() == 20  # record warm-up to sample 30
    assert later["mask"][:10].sum() == 0 and later["mask"][10:].sum() == 40  # 25 + 5 samples: the window's own
    assert third["mask"].sum() == 40
    for split in ("val", "test"):
        whole = dm.whole(split)[0]
        assert whole["mask"][:30].sum() == 0 and whole["mask"].sum() == 170


def test_datamodule_train_fraction_is_a_seeded_subset():
    kw = dict(held_out={"level": [3.0]}, window=20, warmup=2, stride=10)
    full = RecordDataModule(_loops(), **kw)
    half = RecordDataModule(_loops(), train_fraction=0.5, seed=3, **kw)
    again = RecordDataModule(_loops(), train_fraction=0.5, seed=3, **kw)
    assert len(half._train) == round(0.5 * len(full._train)) and half._train.items == again._train.items
    assert set(half._train.items) < set(full._train.items)


def test_datamodule_errors_are_clear():
    with pytest.raises(ValueError, match="leaves no training records"):
        RecordDataModule(_loops(), held_out={"level": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match=r"shorter than the window \(500 samples.*set datamodule.window below"):
        RecordDataModule(_loops(), window=500, warmup=10)
    with pytest.raises(ValueError, match="condition 'kind' is 'sine', not a number"):
        RecordDataModule(_loops(), conditions=["kind"])
    with pytest.raises(ValueError, match="train_fraction"):
        RecordDataModule(_loops(), train_fraction=0.0)


def test_nets_shapes_zero_last_layer_and_parameter_counts():
    assert parse_hidden("4x128") == [128] * 4 and parse_hidden([8, 4]) == [8, 4]
    with pytest.raises(ValueError, match="layers x width"):
        parse_hidden("four")
    mlp = MLP(3, 1, "4x128")
    assert count_parameters(mlp) == 50_177  # seed 003 Table 2: 4x128 on (t, u, u_dot)
    assert count_parameters(MLP(3, 1, "8x128")) == 116_225  # seed 003: "116,225 parameters"
    x = torch.randn(2, 7, 3)
    assert torch.equal(mlp(x), torch.zeros(2, 7, 1)) and LSTMNet(3, 1, "2x16")(x).abs().max() == 0


def _oscillator():
    effects = {"viscous": {"effect": "viscous", "c": 0.4}, "stiffness": {"effect": "linear_stiffness", "k": 30.0},
               "hysteresis": {"effect": "dahl", "Fc": 0.5, "sigma0": 20.0}}
    return build_model("oscillator", effects, units={"x": "m", "F": "N", "u": "N", "t": "s"}, mass=1.0,
                       fixed=["drive_gain"]).double()


def _constitutive():
    effects = {"viscous": {"effect": "viscous", "c": 0.2}, "hysteresis": {"effect": "dahl", "Fc": 1.0, "sigma0": 8.0}}
    return build_model("constitutive", effects, units={"x": "in", "F": "kip", "t": "s"}).double()


def _trajectory(model, n=400, dt=1e-3):
    t = torch.arange(n, dtype=torch.float64) * dt
    u = torch.sin(2 * math.pi * 3 * t)
    U = torch.stack([u, 6 * math.pi * torch.cos(6 * math.pi * t), -(6 * math.pi) ** 2 * u], -1)
    with torch.no_grad():  # the states the residuals are checked on (the compiled loop equals the reference's)
        y, s = simulate(model, U[None], t=t, return_states=True, substeps=4, backend="fast")
    return t, U, y[0, :, 0], s[0]


def test_hybrid_physics_residual_vanishes_on_the_nominal_solution_only(float64):
    model = _oscillator()
    t, U, y, s = _trajectory(model)
    k = slice(50, 350)
    P = model.evaluate(None, 300)
    inp0 = InputSample(U[k, 0], U[k, 1], U[k, 2])
    acc = model.derivative(s[k], inp0, P)[:, 1]
    tau = torch.zeros(300, dtype=torch.float64, requires_grad=True)
    inp = taylor_inputs(U[k, 0], U[k, 1], U[k, 2], tau)
    on = s[k, 0] + s[k, 1] * tau + 0.5 * acc * tau**2
    assert hybrid_physics_residual(model, P, s[k], on, inp, tau, 1.0, 1.0) < 1e-20
    off = 1.05 * on + 0.02 * tau  # a wrong trajectory (5 % too large, offset speed) violates the equation
    assert hybrid_physics_residual(model, P, s[k], off, inp, tau, 1.0, 1.0) > 1e-3
    con = _constitutive()
    _, U2, y2, s2 = _trajectory(con)
    P2 = con.evaluate(None, 400)
    inp2 = taylor_inputs(U2[:, 0], U2[:, 1], U2[:, 2], torch.zeros(400, dtype=torch.float64, requires_grad=True))
    assert hybrid_physics_residual(con, P2, s2, y2, inp2, None, 1.0, 1.0) < 1e-20
    assert float(hybrid_physics_residual(con, P2, s2, y2 + 0.1, inp2, None, 1.0, 1.0)) == pytest.approx(0.01)


def test_pinn_physics_residual_is_small_on_the_simulated_states_and_large_when_perturbed(float64):
    model = _constitutive()
    t, U, y, s = _trajectory(model, n=801, dt=5e-4)
    k = torch.arange(100, 700)
    dsdt = (s[k + 1] - s[k - 1]) / (t[k + 1] - t[k - 1])[:, None]  # central differences of the true states
    tau = torch.zeros(len(k), dtype=torch.float64, requires_grad=True)
    inp = taylor_inputs(U[k, 0], U[k, 1], U[k, 2], tau)
    P = model.evaluate(None, len(k))
    rate_scale = torch.ones(s.shape[1], dtype=torch.float64)
    good = pinn_physics_residual(model, P, s[k] + dsdt * tau[:, None], y[k], inp, tau, rate_scale, 1.0)
    bad = pinn_physics_residual(model, P, 1.2 * s[k] + 0.8 * dsdt * tau[:, None], y[k], inp, tau, rate_scale, 1.0)
    assert good < 1e-3 * bad and bad > 1.0


@pytest.mark.parametrize("kind", sorted(MODULES))
def test_every_module_trains_a_few_steps_and_reports_metrics(kind, float64):
    import lightning as L

    dm = RecordDataModule(_loops(), held_out={"level": [3.0]}, conditions=["level"], window=40, warmup=5,
                          batch_size=4)
    kw = dict(normaliser=dm.normaliser.to_dict(), condition_names=["level"], units=dm.units, lr=1e-2)
    if kind in ("physics", "hybrid", "std_pinn"):
        kw["nominal"] = _constitutive()
    if kind in ("hybrid", "std_pinn"):
        kw["lambda_phys"] = 0.1
    if kind != "physics":
        kw["hidden"] = "2x8"
    module = MODULES[kind](**kw)
    before = split_metrics(predict_split(module, dm, "test"))["rmse"]
    train_before = split_metrics(predict_split(module, dm, "train"))["rmse"]
    L.seed_everything(0, verbose=False)
    trainer = L.Trainer(max_epochs=3, precision="64-true", logger=False, enable_checkpointing=False,
                        enable_progress_bar=False, enable_model_summary=False)
    trainer.fit(module, dm)
    after = split_metrics(predict_split(module, dm, "test"))
    assert math.isfinite(after["rmse"]) and set(after["per_condition"]) == {"level=3, kind=sine"}
    assert after["rmse"] != before  # something was trained
    if kind != "std_pinn":  # the others fit their training records better after three epochs
        assert split_metrics(predict_split(module, dm, "train"))["rmse"] < train_before
    if kind == "hybrid":
        assert module.history and "viscous.c" in module.history[-1]
    if kind == "std_pinn":  # an inverse PINN: the physics residual moves the nominal's parameters
        assert module.history[-1]["viscous.c"] != pytest.approx(0.2, rel=1e-9)


def test_hybrid_starts_exactly_at_the_nominal(float64):
    dm = RecordDataModule(_loops(), held_out={"level": [3.0]}, window=40, warmup=5)
    module = MODULES["hybrid"](_constitutive(), dm.normaliser.to_dict(), hidden="2x8")
    p = predict_split(module, dm, "test")[0]
    assert np.array_equal(p["y_pred"], p["y_nominal"])


def _oscillator_records(n=600, dt=1e-3) -> RecordSet:
    model = _oscillator()
    t = np.arange(n) * dt
    out = []
    for i, amp in enumerate((1.0, 2.0)):
        u = amp * np.sin(2 * np.pi * 3 * t) + 0.3 * amp * np.sin(2 * np.pi * 7 * t)
        with torch.no_grad():
            y = simulate(model, torch.as_tensor(u)[None], t=torch.as_tensor(t), substeps=4)[0, :, 0].numpy()
        out.append(Record(name=f"o{i}", t=t, x=u, y=y, conditions={"amp": amp}, units={"x": "N", "y": "m"}))
    return RecordSet(out, "oscillator")


def test_hybrid_oscillator_physics_loss_starts_at_zero_and_its_time_derivatives_are_exact(float64):
    """The branch's autograd derivatives d/dτ, d²/dτ² equal finite differences along the record (this
    needs the jerk in the Taylor inputs), and with the zero-initialised branch the residual is ~0."""
    dm = RecordDataModule(_oscillator_records(), window=None, conditions=["amp"])
    module = MODULES["hybrid"](_oscillator(), dm.normaliser.to_dict(), condition_names=["amp"], hidden="2x8",
                               lambda_phys=1.0, backend="fast", substeps=4)
    batch = {k: v[None] for k, v in dm.whole("train")[0].items()}
    module.train()
    out = module(batch)
    assert float(module.physics_loss(batch, out)) < 1e-8
    torch.nn.init.normal_(module.net.head.weight, std=0.5)  # a non-trivial branch
    m, rows, _ = module.flat(batch)
    tau, _, r = module.branch_at_offsets(batch, m, rows)
    (dr,) = torch.autograd.grad(r.sum(), tau, create_graph=True)
    (ddr,) = torch.autograd.grad(dr.sum(), tau)
    r, dr, ddr, t = r.detach().numpy(), dr.detach().numpy(), ddr.numpy(), rows["t"].numpy()
    h = t[1] - t[0]
    fd1 = (r[2:] - r[:-2]) / (2 * h)
    fd2 = (r[2:] - 2 * r[1:-1] + r[:-2]) / h**2
    k = slice(10, -10)
    assert np.abs(dr[1:-1][k] - fd1[k]).max() < 1e-3 * np.abs(fd1[k]).max()
    assert np.abs(ddr[1:-1][k] - fd2[k]).max() < 2e-2 * np.abs(fd2[k]).max()


@pytest.mark.parametrize("val", [None, {"level": [2.0]}], ids=["no-validation-split", "validation-split"])
def test_validation_metrics_exist_only_where_validation_records_do(val, float64):
    """Without validation records the validation loop scores the training records (whole records): that is the
    training error and is logged as train/rmse, train/mae; val/* appear only with a validation split (before, the
    training records' error was logged as val/rmse)."""
    import lightning as L

    dm = RecordDataModule(_loops(), held_out={"level": [3.0]}, val=val, window=40, warmup=5, batch_size=4)
    module = MODULES["mlp"](dm.normaliser.to_dict(), hidden="2x8", lr=1e-2)
    L.seed_everything(0, verbose=False)
    trainer = L.Trainer(max_epochs=1, precision="64-true", logger=False, enable_checkpointing=False,
                        enable_progress_bar=False, enable_model_summary=False)
    trainer.fit(module, dm)
    logged = set(trainer.callback_metrics)
    part = "val" if val else "train"
    assert module.validated_split() == part
    assert {f"{part}/rmse", f"{part}/mae"} <= logged
    if not val:
        assert not [k for k in logged if k.startswith("val/")], logged
    # the number logged is that split's whole-record RMSE
    scored = split_metrics(predict_split(module, dm, part))["rmse"]
    assert float(trainer.callback_metrics[f"{part}/rmse"]) == pytest.approx(scored, rel=1e-9)
