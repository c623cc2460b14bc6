"""Hard ranges of physical parameters survive gradient training. Bouc–Wen's α is the elastic share of the
stiffness, F = α k x + (1 − α) κ z: outside [0, 1] one of the two springs has a negative stiffness. A loss
whose minimum lies outside that range (α = −2 or α = 3) is minimised with a large learning rate through the
library's two gradient paths, ``identify.fit_gradient`` and the Lightning ``PhysicsModule``; α must stay in
[0, 1] at every step and the response must stay finite."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybridhyst.data import Record, RecordSet
from hybridhyst.physics.effects import BoucWenHysteresis
from hybridhyst.physics.models import Constitutive
from hybridhyst.simulate import simulate

HELD = ["k", "k1", "D", "A", "beta", "gamma", "n"]  # only α is trained
TARGETS = [-2.0, 3.0]  # the α that minimises each loss: below and above the admissible range


def _model(alpha: float) -> Constitutive:
    bw = BoucWenHysteresis(alpha=alpha, k=2.0, k1=0.0, D=1.0, A=1.0, beta=3.0, gamma=1.0, n=1.0, fixed=HELD)
    return Constitutive({"bw": bw}, units={"x": "in", "F": "kip", "t": "s"}).double()


def _response(alpha: float, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return simulate(_model(alpha), torch.as_tensor(x)[None], t=torch.as_tensor(t))[0, :, 0].numpy()


def _records(target: float) -> RecordSet:
    """Two sine loops whose response is the model's at α = ``target``. The force is affine in α (z does not
    depend on it), so it is extrapolated from two admissible values: F(a) = F(½) + 4 (a − ½) (F(¾) − F(½))."""
    out = []
    for amp in (0.5, 1.0):
        t = np.linspace(0.0, 2.0, 201)
        x = amp * np.sin(2 * math.pi * t)
        half, three_quarters = _response(0.5, t, x), _response(0.75, t, x)
        y = half + 4.0 * (target - 0.5) * (three_quarters - half)
        out.append(Record(name=f"sine_{amp:g}", t=t, x=x, y=y, conditions={"amplitude_in": amp},
                          units={"x": "in", "y": "kip"}))
    return RecordSet(out, f"alpha={target:g}")


def _watch_alpha(model: Constitutive) -> list[float]:
    """Every value of α the model is simulated with (a hook on its parameter function)."""
    seen: list[float] = []
    model.effects["bw"].params["alpha"].register_forward_hook(
        lambda module, args, out: seen.extend(out.detach().reshape(-1).tolist()))
    return seen


def _alpha(model: Constitutive) -> float:
    with torch.no_grad():
        return float(model.effects["bw"].params["alpha"](None, 1)[0])


def test_the_target_loops_are_the_model_at_the_target_alpha(float64):
    """The extrapolated records are what the loss claims: at admissible α = 0.9 they equal the simulation."""
    rec = _records(0.9).records[1]
    assert np.allclose(rec.y, _response(0.9, np.asarray(rec.t), np.asarray(rec.x)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("target", TARGETS)
def test_alpha_stays_in_the_unit_interval_under_fit_gradient(target, float64):
    from hybridhyst.identify.gradient import fit_gradient

    model = _model(0.5)
    seen = _watch_alpha(model)
    res = fit_gradient(model, _records(target), steps=40, lr=0.5, progress=False, backend="fast")
    assert res.steps["adam"] == 40 and len(seen) >= 40  # every step simulated the model
    assert all(0.0 <= a <= 1.0 for a in seen), (min(seen), max(seen))
    final = _alpha(model)
    assert 0.0 <= final <= 1.0
    # the loss really pushed α to the bound nearest its minimum, and the fit stayed finite
    assert final == pytest.approx(0.0 if target < 0 else 1.0, abs=0.02)
    assert all(math.isfinite(v) for v in res.history) and math.isfinite(res.loss)
    with torch.no_grad():
        out = simulate(model, list(_records(target)))
    assert all(bool(torch.isfinite(o).all()) for o in out)


@pytest.mark.parametrize("target", TARGETS)
def test_alpha_stays_in_the_unit_interval_under_lightning_training(target, float64):
    import lightning as L

    from hybridhyst.data.datamodule import RecordDataModule
    from hybridhyst.training import MODULES

    dm = RecordDataModule(_records(target), window=None, warmup=0, batch_size=1)
    model = _model(0.5)
    seen = _watch_alpha(model)
    after_step: list[float] = []

    class AfterEveryStep(L.Callback):
        def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx):
            after_step.append(_alpha(pl_module.nominal))

    module = MODULES["physics"](model, dm.normaliser.to_dict(), units=dm.units, lr=0.5)
    L.seed_everything(0, verbose=False)
    trainer = L.Trainer(max_epochs=15, precision="64-true", logger=False, enable_checkpointing=False,
                        enable_progress_bar=False, enable_model_summary=False, num_sanity_val_steps=0,
                        limit_val_batches=0, callbacks=[AfterEveryStep()])
    trainer.fit(module, dm)
    assert len(after_step) == 30  # two records, one window each, fifteen epochs
    for values in (seen, after_step):
        assert all(0.0 <= a <= 1.0 for a in values), (min(values), max(values))
    assert after_step[-1] == pytest.approx(0.0 if target < 0 else 1.0, abs=0.05)
    with torch.no_grad():
        out = simulate(module.nominal, list(_records(target)))
    assert all(bool(torch.isfinite(o).all()) for o in out)


def test_an_alpha_at_an_end_point_is_refused_unless_fixed():
    """The sigmoid cannot hold α = 0 or 1 exactly: a trained end point is refused when the effect is built, with
    the fix in the message, and a fixed one is kept exactly (a buffer, not trained)."""
    for end in (0.0, 1.0, -0.2):
        with pytest.raises(ValueError, match=r"alpha must lie strictly inside \(0, 1\), got .*fixed=\['alpha'\]"):
            BoucWenHysteresis(alpha=end)
    held = BoucWenHysteresis(alpha=0.0, fixed=["alpha"])
    assert float(held.params["alpha"](None, 1)[0]) == 0.0
    assert not any(name.startswith("params.alpha") for name, _ in held.named_parameters())


@pytest.mark.xfail(strict=True, reason="known bug: a parameter function of a condition (linear, polynomial, exp) "
                   "is not held in its spec's range; seed 001's α(p) is a polynomial. The fix belongs in "
                   "physics/parameters (map the function's value through the spec's constraint)")
def test_alpha_as_a_function_of_a_condition_stays_in_the_unit_interval(float64):
    from hybridhyst.identify.gradient import fit_gradient

    linear = {"kind": "linear", "intercept": 0.5, "slope": 0.0, "condition": "amplitude_in"}
    bw = BoucWenHysteresis(alpha=linear, k=2.0, k1=0.0, D=1.0, A=1.0, beta=3.0, gamma=1.0, n=1.0, fixed=HELD)
    model = Constitutive({"bw": bw}, units={"x": "in", "F": "kip", "t": "s"}).double()
    fit_gradient(model, _records(-2.0), steps=40, lr=0.5, progress=False, backend="fast")
    with torch.no_grad():
        alpha = bw.params["alpha"]({"amplitude_in": torch.tensor([0.5, 1.0])}, 2)
    assert bool(((alpha >= 0) & (alpha <= 1)).all()), alpha.tolist()
