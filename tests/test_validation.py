"""Leave-one-condition-out validation in the discovery loop (``discover.validation``). The data come from numpy
(F = k x + c(p) v, c linear in the pressure); the expected scores from numpy's least squares, not the library."""

import math

import numpy as np
import pytest

from hybridhyst.data.records import Record
from hybridhyst.discover import discover
from hybridhyst.discover.fitting import polish
from hybridhyst.discover.validation import Validation, condition_groups
from hybridhyst.physics.effects import LinearStiffness, Viscous
from hybridhyst.physics.models import Constitutive
from hybridhyst.physics.parameters import Linear

SIM = {"backend": "reference", "method": "rk4", "substeps": 1}
PRESSURES = (0.1, 0.2, 0.3, 0.4)
NOISE = 0.01

pytestmark = pytest.mark.usefixtures("float64")  # tests/conftest.py


def _c(p):
    return 0.2 + 1.0 * p


def _records(pressures=PRESSURES, seed=0) -> list[Record]:
    """One sine record per pressure: F = 2 x + c(p) ẋ (exact) + white noise, 1 Hz, 100 samples per cycle, 2 cycles."""
    rng = np.random.default_rng(seed)
    out = []
    for i, p in enumerate(pressures):
        t = np.arange(0, 2.0, 0.01)
        x = 0.5 * np.sin(2 * np.pi * t + 0.3 * i)
        v = np.pi * np.cos(2 * np.pi * t + 0.3 * i)
        y = 2.0 * x + _c(p) * v + NOISE * rng.standard_normal(len(t))
        out.append(Record(f"r{i}_p{p}", t, x, y, conditions={"pressure_mpa": p}))
    return out


def _model(c):
    return Constitutive({"spring": LinearStiffness(k=1.5), "viscous": Viscous(c=c)}).double()


def _loco_by_least_squares(records) -> float:
    """Pooled RMSE of each record predicted by F = k x + c v fitted (least squares) on the others, with v the
    velocity a model reads from a record of positions (numpy's second-order differences)."""

    def design(r):
        return np.stack([r.x, np.gradient(r.x, r.t, edge_order=2)], 1)

    sse, n = 0.0, 0
    for i, held in enumerate(records):
        rest = [r for j, r in enumerate(records) if j != i]
        A = np.concatenate([design(r) for r in rest])
        b = np.concatenate([r.y for r in rest])
        coef, *_ = np.linalg.lstsq(A, b, rcond=None)
        e = held.y - design(held) @ coef
        sse, n = sse + float(e @ e), n + len(e)
    return math.sqrt(sse / n)


def test_records_sharing_their_conditions_are_one_operating_point():
    a, b, c = _records((0.1, 0.2, 0.1))
    c.conditions = {"pressure_mpa": 0.1}
    assert [[r.name for r in g] for g in condition_groups([a, b, c])] == [[a.name, c.name], [b.name]]


def test_leave_one_condition_out_refits_on_the_others_and_scores_the_one_left_out():
    records = _records()
    fit = polish(_model(0.3), records, SIM, 25, 10.0)
    loco = Validation("loco", records, [], lm_steps=25, box_factor=10.0)(fit.model, SIM)
    assert loco == pytest.approx(_loco_by_least_squares(records), rel=1e-3)
    # the in-sample error of the same model is smaller: the score is not the training error
    in_sample = Validation("records", records, [], lm_steps=25, box_factor=10.0)(fit.model, SIM)
    assert in_sample < 0.9 * loco


def test_a_trend_that_carries_to_a_pressure_left_out_scores_at_the_noise_and_a_constant_does_not():
    records = _records()
    score = Validation("loco", records, [], lm_steps=25, box_factor=10.0)
    constant = polish(_model(0.3), records, SIM, 25, 10.0).model
    trend = polish(_model(Linear(slope=0.5, intercept=0.3, condition="pressure_mpa").double()), records, SIM, 25,
                   10.0).model
    assert score(trend, SIM) <= 1.2 * NOISE < 2 * NOISE < score(constant, SIM)


def test_loco_needs_two_operating_points_and_an_unknown_kind_is_refused():
    one = _records((0.2, 0.2))
    with pytest.raises(ValueError, match="share one"):
        Validation("loco", one, [], lm_steps=5, box_factor=10.0)
    with pytest.raises(ValueError, match="share one"):  # refused before the nominal's identification
        discover(one, _model(0.3), validation="loco", identify_options={"generations": 10_000}, progress=False)
    with pytest.raises(ValueError, match="unknown validation 'lofo'"):
        discover(_records(), _model(0.3), validation="lofo", progress=False)


def test_the_loop_with_loco_finds_the_pressure_trend_and_says_how_it_judged():
    records = _records((0.1, 0.15, 0.2, 0.3, 0.4))
    res = discover(records, _model(0.3), candidates=["coulomb"], split={"held_out": {"pressure_mpa": [0.4]}},
                   validation="loco", max_steps=1, fit_nominal=False, backend="reference", progress=False)
    rep = res.report
    assert rep["validation"]["kind"] == "loco" and "4 training operating points" in rep["validation"]["on"]
    assert [s["effect"] for s in rep["steps"]] == ["trends~pressure_mpa"]
    assert rep["validation"]["rmse_after"] <= 1.2 * NOISE < rep["validation"]["rmse_before"]
    assert rep["steps"][0]["val_rmse"] == pytest.approx(rep["validation"]["rmse_after"], rel=0.05)
    assert rep["after"]["test_rmse"] <= 1.5 * NOISE  # 0.4 MPa: beyond every training pressure
