"""Records → batch: one path (``data.batch``) for simulate, identify and training; every row on its own grid."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybridhyst.data import Record
from hybridhyst.data.batch import record_batches
from hybridhyst.identify import RecordsProblem
from hybridhyst.identify.space import SearchSpace
from hybridhyst.physics.compositions.friction import dahl_friction
from hybridhyst.simulate import simulate
from hybridhyst.simulate.inputs import gradient


def _jittered(n=241, seed=0):
    """Two records of one length with the same first and last time; the second's samples are jittered."""
    rng = np.random.default_rng(seed)
    t1 = np.linspace(0.0, 2.0, n)
    t2 = t1.copy()
    t2[1:-1] += rng.uniform(-0.3, 0.3, n - 2) * (t1[1] - t1[0])
    out = []
    for name, t, amp in (("even", t1, 1.0), ("jittered", t2, 1.0)):
        x = amp * np.sin(2 * np.pi * 1.0 * t)
        out.append(Record(name=name, t=t, x=x, y=np.zeros_like(x), conditions={"amplitude_in": amp},
                          units={"x": "in", "y": "kip"}))
    return out


def _alone(model, record, backend):
    with torch.no_grad():
        return simulate(model, torch.as_tensor(record.x)[None], t=torch.as_tensor(record.t),
                        conditions={"amplitude_in": 1.0}, backend=backend)[0, :, 0].numpy()


@pytest.mark.parametrize("backend", ["reference", "fast"])
def test_records_with_jittered_timestamps_are_simulated_on_their_own_grids(float64, backend):
    model = dahl_friction(Fc=1.0, sigma0=30.0, c=0.1, Fc_coulomb=0.2).double()
    records = _jittered()
    expected = [_alone(model, r, backend) for r in records]
    assert np.abs(expected[0] - expected[1]).max() > 1e-3  # the grids differ enough to matter
    with torch.no_grad():
        together = [y[:, 0].numpy() for y in simulate(model, records, backend=backend)]
    space = SearchSpace(model)
    problem = RecordsProblem(space, records, backend=backend)
    with torch.no_grad():
        pred = problem.predict(space.initial()[None])[0].reshape(len(records), -1).numpy()
    for i in range(len(records)):
        np.testing.assert_allclose(together[i], expected[i], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(pred[i], expected[i], rtol=1e-10, atol=1e-12)


def test_batches_group_by_length_only_and_keep_each_grid(float64):
    records = _jittered() + [Record(name="short", t=np.linspace(0, 1, 50), x=np.zeros(50), y=np.zeros(50),
                                    conditions={"kind": "a"})]
    batches = record_batches(records)
    assert [b.index for b in batches] == [[0, 1], [2]]
    np.testing.assert_array_equal(batches[0].t[1].numpy(), records[1].t)
    assert set(batches[0].conditions) == {"amplitude_in"} and batches[1].conditions == {}


def test_gradient_per_row_matches_numpy_on_nonuniform_grids(float64):
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0, 1, (3, 40)), axis=1)
    f = np.sin(5 * t)
    for edge in (1, 2):
        got = gradient(torch.as_tensor(f), torch.as_tensor(t), edge).numpy()
        want = np.stack([np.gradient(f[i], t[i], edge_order=edge) for i in range(3)])
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_fast_gradients_with_one_grid_per_row_match_the_reference(float64):
    records = _jittered(n=81)
    grads = {}
    for backend in ("reference", "fast"):
        model = dahl_friction(Fc=1.0, sigma0=30.0, c=0.1, Fc_coulomb=0.2).double()
        loss = sum(y.square().sum() for y in simulate(model, records, backend=backend))
        loss.backward()
        grads[backend] = torch.cat([p.grad.reshape(-1) for p in model.parameters() if p.grad is not None])
    torch.testing.assert_close(grads["fast"], grads["reference"], rtol=1e-8, atol=1e-10)
