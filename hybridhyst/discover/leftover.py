"""How much structure the final model leaves: a network fitted to what remains, scored on records it did not see.

Two networks, one question ("is anything structured left that the library did not name?"):

* ``residual_network`` (``leftover="static"``): a small MLP of (x, ẋ, sign ẋ, travel since reversal and the
  records' control channels) fitted to the residual, point by point. Cheap; it sees no memory beyond the
  travel since the last reversal.
* ``neural_leftover`` (``leftover="dynamics"``): a ``NeuralEffect`` — a force with a latent state of its
  own — added *inside* the final model's equations, its weights fitted through the simulator with every
  physical parameter held; the augmented model is then simulated on the validation records. It can
  represent what a pointwise correction cannot (a play, a slow state, a force that depends on the path).

Either gives ``explained_share``: the share of the remaining residual that the network removes on the
validation records (the training records without them); ``structure_flagged`` turns it into the flag.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import torch

from ..identify import fit_gradient
from ..identify.gradient import record_loss
from ..nets import MLP
from ..physics.effects import NeuralEffect
from ..simulate import SimulationSettings, simulate, simulate_resolved
from .candidates import Scales, _placed

__all__ = ["FLAG_SHARE", "LEFTOVER", "neural_leftover", "residual_network", "structure_flagged"]

FLAG_SHARE = 0.1  # residual a network recovers on validation above which structure is flagged
LEFTOVER = ("static", "dynamics")


def structure_flagged(network: dict, train_rmse: float, noise_sd: float | None) -> bool:
    """True when structure is left that the library did not name: with a known noise level, a training error
    above 1.2 × noise; without one, a leftover network that recovers more than ``FLAG_SHARE`` of the
    remaining residual on validation records (the static one also on training records when there are none)."""
    if noise_sd is not None and math.isfinite(train_rmse):
        return train_rmse > 1.2 * float(noise_sd)
    if network.get("network") == "dynamics" and network.get("on") != "val":
        return False  # fitted and scored on the same records: a network with a memory fits noise too
    share = network.get("explained_share")
    return share is not None and math.isfinite(share) and share > FLAG_SHARE


def residual_network(train, train_pred, val=None, val_pred=None, steps: int = 300, seed: int = 0) -> dict:
    """How much of the remaining residual a small network of (x, ẋ, sign ẋ, travel since reversal, the control
    channels every record carries) recovers:
    the share of residual variance it explains on validation records (training records without them). An
    honest "is anything structured left" number, not a model."""
    from .diagnose import features, shared_controls

    controls = shared_controls([*train, *(val or [])])  # what the records all carry: a coil current, a pressure

    def table(records, preds):
        X, R = [], []
        for rec, p in zip(records, preds):
            f = features(rec.t, rec.x)
            cols = [f["x"], f["v"], f["sign_v"], f["since_reversal"], *(rec.controls[c] for c in controls)]
            X.append(rec.scored(np.stack(cols, 1)))
            R.append(rec.scored(np.asarray(rec.y) - p))
        return np.concatenate(X), np.concatenate(R)

    X, R = table(train, train_pred)
    Xv, Rv = table(val, val_pred) if val else (X, R)
    mu, sd = X.mean(0), X.std(0) + 1e-12
    rs = R.std() or 1.0
    g = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    net = MLP(X.shape[1], 1, hidden=[32, 32], zero_last=False).double()
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    Xt, Rt = torch.as_tensor((X - mu) / sd), torch.as_tensor(R / rs)
    for _ in range(steps):
        idx = torch.randint(0, len(Xt), (min(len(Xt), 2048),), generator=g)
        loss = (net(Xt[idx])[:, 0] - Rt[idx]).square().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        pv = net(torch.as_tensor((Xv - mu) / sd))[:, 0].numpy() * rs
    share = 1 - float(np.var(Rv - pv) / max(np.var(Rv), 1e-300))
    return {"network": "static", "explained_share": share, "on": "val" if val else "train",
            "rmse_after_network": float(np.sqrt(np.mean((Rv - pv) ** 2))),
            "inputs": ["x", "ẋ", "sign ẋ", "travel since reversal", *controls]}


def neural_leftover(model, train, val=None, *, sim: SimulationSettings, conditions: dict | None = None,
                    hidden: str = "2x16", latent_states: int = 1, iterations: int = 40, seed: int = 0,
                    progress: bool = True) -> dict:
    """How much of the remaining error a network *inside* ``model``'s dynamics removes.

    A ``NeuralEffect`` (force and ``latent_states`` states of its own, inputs x and ẋ and the ``conditions``
    {name: training values}, scales from the training records: ``Scales``) is added to a copy of ``model``; it
    starts at zero, so the copy starts exactly at ``model``. Its weights are fitted by full-batch L-BFGS
    (``identify.fit_gradient``: strong-Wolfe line search, ``iterations`` at most, the best weights seen kept) on
    the training records' mean squared error, every physical parameter held. ``explained_share`` = 1 −
    MSE(augmented) / MSE(model) on the validation records: the share of the remaining mean squared error —
    offsets included — the network removes out of sample. Without validation records it is scored on the
    training records it was fitted to (``on="train"``), in sample: reported, but ``structure_flagged`` does
    not use it.

    Returns ``{"network": "dynamics", "explained_share", "on", "rmse_after_network", "rmse_before",
    "train_share", "evaluations", "wall_s"}``.
    """
    from ..physics.models import DrivenOscillator

    start = time.perf_counter()
    ref = next(itertools.chain(model.parameters(), model.buffers()))
    s = Scales.of(train, oscillator=isinstance(model, DrivenOscillator))
    cond = {c: (float(np.mean(v)), float(np.std(v))) for c, v in (conditions or {}).items()}
    with torch.random.fork_rng():  # the weights' draw does not move the caller's random state
        torch.manual_seed(seed)
        net = NeuralEffect(("x", "v"), latent_states, hidden, scales={"x": s.x, "v": s.v, "u": s.u, "F": s.F},
                           conditions=cond).to(device=ref.device, dtype=ref.dtype)
    augmented = _placed(model, "neural_leftover", net)  # a copy: the caller's model is not touched
    for p in augmented.parameters():
        p.requires_grad_(False)
    for w in augmented.effects["neural_leftover"].net.parameters():
        w.requires_grad_(True)
    fit = fit_gradient(augmented, list(train), steps=0, lbfgs_steps=int(iterations), progress=progress,
                       simulation=sim)

    def mse(m, records, substeps):
        preds = simulate(m, list(records), settings=sim.at(substeps))
        return float(record_loss(preds, list(records)))

    with torch.no_grad():
        scored = val or train
        train_before = mse(model, train, sim.substeps)
        if val:  # the validation records at the sub-steps they need (as the loop scores them), both models alike
            out, at, _ = simulate_resolved(model, list(val), settings=sim)
            before = float(record_loss(out, list(val)))
        else:
            at, before = sim.substeps, train_before
        after = mse(augmented, scored, at)
    return {"network": "dynamics", "explained_share": 1.0 - after / max(before, 1e-300),
            "on": "val" if val else "train", "rmse_after_network": math.sqrt(after), "rmse_before": math.sqrt(before),
            "train_share": 1.0 - fit.loss / max(train_before, 1e-300), "evaluations": fit.evaluations,
            "wall_s": time.perf_counter() - start}
