"""The structure left after discovery, measured by a network inside the model's dynamics (``leftover.py``).

Data from generators that share nothing with the library: an exact discrete play operator (an
elastic–perfectly-plastic element, F = k_p (y − p), p the play output of half-width r) written here, inside a
mass–spring–damper driven by a multisine force and integrated by semi-implicit Euler at 40 sub-steps per
sample. The model measured is the linear oscillator alone, at its true values: what is left is the
elasto-plastic force, which acts through the dynamics, so the output's residual is no function of the
input's present kinematics. The network inside the dynamics must remove most of it on a record with another
multisine, the pointwise network cannot; on data with nothing left (the model's own law plus noise) the
network must remove nothing.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybridhyst.data import Record
from hybridhyst.discover.leftover import FLAG_SHARE, neural_leftover, residual_network, structure_flagged
from hybridhyst.discover.validation import predict
from hybridhyst.physics.effects import LinearStiffness, Viscous
from hybridhyst.physics.models import DrivenOscillator
from hybridhyst.simulate import SimulationSettings

M, C, K, KP, R = 1.0, 0.3, 4.0, 6.0, 0.1  # mass [kg], damping [N s/m], springs [N/m], play half-width [m]
SIM = SimulationSettings()


def _record(seed: int, plastic: bool, n: int = 200, dt: float = 0.05, sub: int = 40) -> Record:
    """m ÿ + c ẏ + k y (+ k_p (y − p), p the exact play of y) = u; u a random multisine; 2 mm noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    freqs, phases = rng.uniform(0.1, 0.6, 4), rng.uniform(0, 2 * np.pi, 4)
    u = 3.0 * sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))
    y = v = p = 0.0
    ys, h = np.empty(n), dt / sub
    for i in range(n):
        ys[i] = y
        for j in range(sub if i < n - 1 else 0):
            ui = u[i] + (u[i + 1] - u[i]) * (j + 0.5) / sub
            v += h * (ui - C * v - K * y - (KP * (y - p) if plastic else 0.0)) / M
            y += h * v
            p = min(max(p, y - R), y + R)
    return Record(name=f"multisine_{seed}", t=t, x=u, y=ys + rng.normal(0.0, 0.002, n), units={"x": "N", "y": "m"})


def _model() -> DrivenOscillator:
    return DrivenOscillator({"spring": LinearStiffness(k=K), "dashpot": Viscous(c=C)}, mass=M, drive_gain=1.0,
                            units={"x": "m", "F": "N", "u": "N", "t": "s"}).double()


@pytest.mark.parametrize("plastic", [True, False])
def test_a_network_in_the_dynamics_recovers_a_force_left_out_and_nothing_when_nothing_is(plastic, float64):
    train, val = [_record(1, plastic), _record(2, plastic)], [_record(3, plastic)]
    model = _model()
    out = neural_leftover(model, train, val, sim=SIM, iterations=40, progress=False)
    static = residual_network(train, predict(model, train, SIM), val, predict(model, val, SIM))
    assert out["network"] == "dynamics" and out["on"] == "val" and out["evaluations"] >= 2
    if plastic:
        assert out["rmse_before"] > 0.1  # the elasto-plastic spring's effect, against 2 mm noise
        assert out["explained_share"] > 0.8, out
        assert structure_flagged(out, train_rmse=out["rmse_before"], noise_sd=None)
        assert static["explained_share"] < 0.5 < out["explained_share"]  # a pointwise network cannot see it
    else:
        assert out["rmse_before"] < 0.005  # the noise, and the two integrators' difference
        assert out["explained_share"] < FLAG_SHARE, out
        assert not structure_flagged(out, train_rmse=out["rmse_before"], noise_sd=None)
