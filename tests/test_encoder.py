"""The window-start encoder: each training window's start state estimated from the samples before it."""

import lightning as L
import numpy as np
import pytest
import torch
from scipy import signal

from hybridhyst.data.datamodule import RecordDataModule
from hybridhyst.data.records import Record
from hybridhyst.physics.effects import EFFECTS
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate
from hybridhyst.training.losses import data_loss
from hybridhyst.training.modules import HybridModule, PhysicsModule

pytestmark = pytest.mark.usefixtures("float64")

K, C, M = 400.0, 2.0, 1.0


def _oscillator():
    return DrivenOscillator({"spring": EFFECTS["linear_stiffness"](k=K), "viscous": EFFECTS["viscous"](c=C)},
                            mass=M).double()


def _records():
    """The oscillator's exact response (scipy's linear simulation, input linear between samples: none of the
    library's integrator), noise-free, at 60 Hz: a start from the measured (y, forward-difference ẏ) is off."""
    system = signal.StateSpace([[0.0, 1.0], [-K / M, -C / M]], [[0.0], [1.0 / M]], [[1.0, 0.0]], [[0.0]])
    out = []
    for i, amp in enumerate((20.0, 30.0, 40.0)):
        t = np.arange(480) / 60.0
        u = amp * (np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 3.7 * t + 1.0))
        _, y, _ = signal.lsim(system, u, t)
        out.append(Record(f"r{i}", t, u, y, conditions={"amp": amp}, units={"x": "N", "y": "m"}))
    return out


def _module(dm, past, **kw):
    torch.manual_seed(0)
    return PhysicsModule(_oscillator(), dm.normaliser.to_dict(), encoder_past=past, encoder_hidden="1x16",
                         **kw)


def _windowed_loss(module, dm):
    with torch.no_grad():
        losses = [float(data_loss(module(b)["y"], b["y"], b["mask"], module.y_scale, "mse"))
                  for b in dm.train_dataloader()]
    return float(np.mean(losses))


def test_past_samples_are_the_ones_before_each_window():
    dm = RecordDataModule(_records(), window=64, warmup=0, past=8)
    dm.setup("fit")
    seen_start = seen_inside = False
    for b in dm.train_dataloader():
        for j in range(b["t"].shape[0]):
            p = dm.prepared["train"][int(b["index"][j])]
            s = int(b["start"][j])
            want = (np.repeat([[p["u"][0], p["y"][0]]], 8, axis=0) if s == 0
                    else np.stack([p["u"][s - 8:s], p["y"][s - 8:s]], axis=1))
            np.testing.assert_array_equal(b["past"][j].numpy(), want)
            seen_start, seen_inside = seen_start or s == 0, seen_inside or s > 0
    assert seen_start and seen_inside
    whole = dm.whole("train")[0]  # a whole record starts at its first sample: its past is that sample repeated
    np.testing.assert_array_equal(whole["past"].numpy(), np.repeat([[whole["u"][0], whole["y"][0]]], 8, axis=0))
    with pytest.raises(ValueError, match="past must be >= 0"):
        RecordDataModule(_records(), window=64, past=-1)


def test_a_zero_encoder_starts_where_the_plain_start_does_and_only_inside_records():
    dm = RecordDataModule(_records(), window=64, warmup=0, past=8, batch_size=64)
    dm.setup("fit")
    batch = next(iter(dm.train_dataloader()))
    plain, encoded = _module(dm, 0), _module(dm, 8)
    with torch.no_grad():
        assert torch.equal(plain(batch)["y"], encoded(batch)["y"])
        assert bool((encoded.state_scale > 0).all())  # fitted from the first batch
        torch.nn.init.normal_(encoded.encoder.head.weight, std=1.0)
        moved = (encoded(batch)["y"] - plain(batch)["y"]).abs().amax(1)
    inside = batch["start"] > 0
    assert bool((moved[inside] > 0).all()) and bool((moved[~inside] == 0).all())


def test_the_encoder_learns_the_start_state_the_measurement_lacks():
    """With the exact nominal held fixed, the only error left on windows scored from their first sample is
    their start state; training the encoder must remove most of it."""
    dm = RecordDataModule(_records(), window=64, warmup=0, stride=16, past=8, batch_size=16)
    dm.setup("fit")
    plain, encoded = _module(dm, 0), _module(dm, 8, lr=3e-3, nominal_lr=0.0)
    before = _windowed_loss(plain, dm)
    assert before > 1e-3  # the forward-difference velocity leaves a visible transient
    L.Trainer(max_epochs=40, logger=False, enable_checkpointing=False, enable_progress_bar=False,
              enable_model_summary=False, num_sanity_val_steps=0, limit_val_batches=0).fit(encoded, dm)
    after = _windowed_loss(encoded, dm)
    assert after < 0.05 * before, (before, after)


def test_encoder_options_are_checked():
    dm = RecordDataModule(_records(), window=64, warmup=0, past=8)
    dm.setup("fit")
    norm = dm.normaliser.to_dict()
    with pytest.raises(ValueError, match="no state to estimate"):
        PhysicsModule(Constitutive({"spring": EFFECTS["linear_stiffness"](k=1.0)}).double(), norm, encoder_past=8)
    hybrid = HybridModule(_oscillator(), norm, hidden="1x8", placement="dynamics", latent_states=2, encoder_past=8)
    assert hybrid.encoder.head.out_features == 4  # x, v and the network's two latent states
    from omegaconf import OmegaConf

    from hybridhyst.training.build import encoder_past

    assert encoder_past(OmegaConf.create({"module": "hybrid", "encoder": {"past": 16}})) == 16
    with pytest.raises(ValueError, match="belongs to a module with a nominal model"):
        encoder_past(OmegaConf.create({"module": "lstm", "encoder": {"past": 16}}))


def test_windows_start_where_a_run_of_the_whole_record_has_its_states():
    """window_start="run": a window inside a record starts at the measured (y, ẏ) and, for every other state
    (the network's latent ones), where a simulation of the whole record from rest with the current weights is
    at the window's first sample; a window at a record's start starts at rest. New weights, new run."""
    dm = RecordDataModule(_records(), window=64, warmup=8, batch_size=64)
    dm.setup("fit")
    torch.manual_seed(1)
    hybrid = HybridModule(_oscillator(), dm.normaliser.to_dict(), hidden="1x8", placement="dynamics",
                          latent_states=2, latent_form="duhem", window_start="run", backend="reference")
    for p in hybrid.net.net.parameters():
        torch.nn.init.normal_(p, std=0.5)
    hybrid.refresh_run_states(dm)
    whole = dm.whole("train")
    batch = next(iter(dm.train_dataloader()))
    with torch.no_grad():
        s0 = hybrid._initial_state(batch)
    checked, runs = 0, {}
    for j in range(batch["t"].shape[0]):
        i, s = int(batch["index"][j]), int(batch["start"][j])
        if s == 0:
            assert torch.equal(s0[j], torch.zeros(4, dtype=s0.dtype))
            continue
        assert torch.equal(s0[j, :2], batch["y0"][j])  # measured displacement and velocity
        if i not in runs:  # the whole record from rest, once per record
            w = {k: v[None] for k, v in whole[i].items()}
            with torch.no_grad():
                runs[i] = simulate(hybrid.model, torch.stack([w["u"], w["du"], w["ddu"]], -1),
                                   t=w["t"] - w["t"][:, :1], return_states=True)[1]
        assert torch.allclose(s0[j, 2:], runs[i][0, s, 2:], rtol=1e-12, atol=1e-14)
        assert float(s0[j, 2:].abs().max()) > 1e-3  # a latent state that has moved
        checked += 1
    assert checked
    with torch.no_grad():
        hybrid.net.net.head.weight.mul_(0.5)  # new weights: the stored run is refreshed (every epoch in training)
    hybrid.refresh_run_states(dm)
    with torch.no_grad():
        assert not torch.equal(hybrid._initial_state(batch)[:, 2:], s0[:, 2:])
    hybrid.eval()  # whole records (validation, test) start at rest as before
    with torch.no_grad():
        assert torch.equal(hybrid._initial_state(batch), PhysicsModule(_oscillator(), dm.normaliser.to_dict())
                           ._initial_state(batch))
    with pytest.raises(ValueError, match="choose one"):
        HybridModule(_oscillator(), dm.normaliser.to_dict(), hidden="1x8", placement="dynamics", latent_states=1,
                     encoder_past=8, window_start="run")
    with pytest.raises(ValueError, match="unknown window_start"):
        PhysicsModule(_oscillator(), dm.normaliser.to_dict(), window_start="measured")


def test_run_window_starts_with_free_latent_states_warn():
    dm = RecordDataModule(_records(), window=64, warmup=8)
    dm.setup("fit")
    with pytest.warns(UserWarning, match="can drift"):
        HybridModule(_oscillator(), dm.normaliser.to_dict(), hidden="1x8", placement="dynamics", latent_states=1,
                     window_start="run")
