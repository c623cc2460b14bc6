"""Input operators and structure modifiers: backlash (the play operator) and its relaxing follower, inertia and a
time delay."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from test_effects import respond, sine

from hybridhyst.physics.effects import (
    Backlash,
    Coulomb,
    Dahl,
    Inertia,
    LinearStiffness,
    RelaxingBacklash,
    TimeDelay,
    Viscous,
)
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate
from hybridhyst.testbed.generators import kelvin_behind_play

pytestmark = pytest.mark.usefixtures("float64")  # conftest: float64 default dtype, restored afterwards


# -- input operators and structure modifiers ----------------------------------------------------------------
def backlash_loop(r: float, downstream, dt: float = 2.5e-3):
    """One period of x = sin(2 pi t) through a play of half-width r."""
    t, x = sine(1.0, 1.0, 1.0, dt)
    model = Constitutive([Backlash(r=r), *downstream])
    return t, x, respond(model, x[None], t=t)[0]


def test_backlash_with_zero_width_is_transparent():
    t, x, F = backlash_loop(0.0, [Dahl(sigma0=5.0, Fc=1.0)])
    F_ref = respond(Constitutive([Dahl(sigma0=5.0, Fc=1.0)]), x[None], t=t)[0]
    assert torch.allclose(F, F_ref, atol=1e-12)


def test_backlash_dead_band_width():
    r, margin = 0.2, 0.05
    t, x, y = backlash_loop(r, [LinearStiffness(k=1.0)])
    assert float(y.max()) == pytest.approx(1.0 - r, abs=1e-3)  # output peak = input peak - r
    assert float(y.min()) == pytest.approx(-1.0 + r, abs=1e-3)
    v = torch.gradient(x, spacing=(t,))[0]
    sliding = (v.abs() > 5.5) & (t > 0.1)  # |x| < 0.48, past every dead band
    assert torch.allclose((x - y)[sliding], r * v[sliding].sign(), atol=1e-3)  # gap = r while sliding
    # after the reversal at t = 0.25 the output holds while x crosses 2r, then follows x + r
    after = (t > 0.25) & (t < 0.5)
    held = after & (x > 1.0 - 2 * r + margin)
    assert float((y[held] - (1.0 - r)).abs().max()) < 1e-3
    moving = after & (x < 1.0 - 2 * r - margin)
    assert torch.allclose(y[moving], x[moving] + r, atol=1e-3)


def exact_play(x: np.ndarray, r: float) -> np.ndarray:
    """The discrete play operator y_k = clamp(y_{k-1}, x_k - r, x_k + r), y_0 = x_0 (written independently)."""
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = min(max(y[k - 1], x[k] - r), x[k] + r)
    return y


def test_backlash_is_the_play_operator_at_any_sample_rate():
    """No smoothing width to resolve: from 16 samples per cycle on, the output is the discrete play operator
    up to the second-order error with which the gap integrates the input's velocity (it falls as h²)."""
    r, errors = 0.15, []
    for samples_per_cycle in (16, 40, 400):
        t, x, y = backlash_loop(r, [LinearStiffness(k=1.0)], dt=1.0 / samples_per_cycle)
        errors.append(float(np.abs(y.numpy() - exact_play(x.numpy(), r)).max()))
    assert errors[0] < 0.02 and errors[1] < 3e-3  # of a unit amplitude, r = 0.15
    assert errors[1] / errors[2] > 50  # ten times the rate: about a hundred times less error


def test_backlash_needs_the_projecting_fixed_step_solver():
    t, x = sine(1.0, 1.0, 1.0, 0.01)
    with pytest.raises(ValueError, match="cannot project bounded states"):
        simulate(Constitutive([Backlash(r=0.1), LinearStiffness(k=1.0)]), x[None], t=t, solver="torchdiffeq")


def test_backlash_coulomb_shows_dead_band_after_reversal():
    r, margin = 0.2, 0.05
    t, x, F = backlash_loop(r, [Coulomb(Fc=1.0, v_s=0.05)])
    F_direct = respond(Constitutive([Coulomb(Fc=1.0, v_s=0.05)]), x[None], t=t)[0]
    for t_rev, level, sgn in ((0.25, 1.0, -1.0), (0.75, -1.0, 1.0)):
        window = (t > t_rev) & (t < t_rev + 0.25)
        inside = window & ((x - level).abs() < 2 * r - margin) & ((x - level).abs() > margin)
        outside = window & ((x - level).abs() > 2 * r + margin)
        assert float(F[inside].abs().max()) < 0.01  # no friction in the dead band
        assert torch.allclose(F[outside], torch.full_like(F[outside], sgn), atol=0.01)
        assert torch.allclose(F_direct[inside], torch.full_like(F_direct[inside], sgn), atol=0.01)


def test_a_spring_dashpot_behind_a_relaxing_play_is_the_pin_linkage():
    """A spring k and a dashpot c behind the relaxing play with λ = k / c are the pin linkage of the test bed's
    own generator (exact exponential creep of the free piston, projection onto the contact; no library code): no
    force while the pin is free, the same loop where it pushes. ``backlash`` (the piston held) is not. On the
    compiled path (the reference loop gives the same numbers: ``test_fast.py``'s every-effect comparison)."""
    k, c, r, dt = 2.0, 0.25, 0.15, 1e-3
    t, x = sine(1.0, 1.0, 1.5, dt)
    x = -torch.cos(2 * math.pi * t)  # from rest at -1, as a displacement rig starts
    v = 2 * math.pi * torch.sin(2 * math.pi * t)
    exact = kelvin_behind_play(t.numpy(), x.numpy(), v.numpy(), r, k, c)  # the piston at rest, z0 = 0

    def loop(play):
        model = Constitutive({"play": play, "spring": LinearStiffness(k=k), "viscous": Viscous(c=c)})
        return respond(model, torch.stack([x, v], -1)[None], t=t, backend="fast")[0].numpy()

    # the piston at rest with the pin pressed against it from below: the gap closed at -r
    F = loop(RelaxingBacklash(r=r, lam=k / c, d0=-r))
    free = exact == 0.0
    assert free.mean() > 0.1 and np.abs(F[free]).max() < 0.02 * np.abs(exact).max()
    # a contact starts within a step of the exact one: the force jumps there by c times the relative speed
    assert np.sqrt(np.mean((F - exact) ** 2)) < 0.02 * np.abs(exact).max()
    held = loop(Backlash(r=r, d0=-r))
    assert np.sqrt(np.mean((held - exact) ** 2)) > 0.1 * np.abs(exact).max()
    # λ = 0 is backlash, r = 0 the identity
    assert np.allclose(loop(RelaxingBacklash(r=r, lam=0.0, d0=-r)), held, atol=1e-12)
    direct = respond(Constitutive([LinearStiffness(k=k), Viscous(c=c)]), torch.stack([x, v], -1)[None], t=t,
                     backend="fast")[0]
    assert np.allclose(loop(RelaxingBacklash(r=0.0, lam=k / c)), direct.numpy(), atol=1e-12)


def test_inertia_constitutive_gives_mass_times_acceleration():
    m, w = 2.0, 2 * math.pi
    t, x = sine(1.0, 1.0, 1.0, 1e-3)
    F = respond(Constitutive([Inertia(m=m)]), x[None], t=t)[0]
    expected = -m * w**2 * torch.sin(w * t)
    assert float((F - expected)[2:-2].abs().max()) < 1e-3 * m * w**2  # finite-difference accuracy


def test_inertia_adds_to_oscillator_mass():
    u = torch.randn(2, 301, generator=torch.Generator().manual_seed(0))
    with_inertia = DrivenOscillator([Inertia(m=1.5), LinearStiffness(k=4.0), Viscous(c=0.3)], mass=0.5)
    heavier = DrivenOscillator([LinearStiffness(k=4.0), Viscous(c=0.3)], mass=2.0)
    assert torch.allclose(respond(with_inertia, u, dt=0.01), respond(heavier, u, dt=0.01), atol=1e-12)


def test_time_delay_shifts_a_sine():
    tau, w = 0.0537, 2 * math.pi
    t, x = sine(1.0, 1.0, 1.0, 1e-3)
    F = respond(Constitutive([TimeDelay(tau=tau), LinearStiffness(k=1.0)]), x[None], t=t)[0]
    expected = torch.where(t >= tau, torch.sin(w * (t - tau)), torch.zeros_like(t))
    assert float((F - expected).abs().max()) < 1e-5  # linear interpolation error (w dt)^2 / 8


def test_a_delay_is_continuous_in_tau_for_a_record_that_starts_in_motion():
    """Before t0 the delayed input holds its first sample, rates included: as τ crosses a whole number of samples
    the response moves by O(ε), not by c·v(t0) (rates zeroed before t0 made the cost a sawtooth in τ and pulled
    fits to whole samples)."""
    t, x = sine(1.0, 1.0, 0.5, 1e-3)  # starts at x = 0 at full speed 2π
    model = lambda tau: Constitutive([TimeDelay(tau=tau), Viscous(c=1.0), LinearStiffness(k=3.0)])  # noqa: E731
    for m in (1, 7):
        below, above = (respond(model(m * 1e-3 + e), x[None], t=t)[0] for e in (-1e-9, 1e-9))
        assert float((below - above).abs().max()) < 1e-4


def test_identify_finds_a_delay_between_samples_on_records_that_start_in_motion():
    """Loops of F = c·ẋ(t − τ) + k·x(t − τ) evaluated exactly at t − τ (the motion continues before t0, which the
    model cannot know), τ = 7.3 ms at 1 kHz, white noise: the fit lands between the samples, not on one."""
    from hybridhyst.data import Record
    from hybridhyst.identify import identify

    rng = np.random.default_rng(3)
    tau, c, k, dt = 7.3e-3, 2.0, 3.0, 1e-3
    records = []
    for i, (a, f) in enumerate([(1.0, 2.0), (0.6, 5.0), (1.4, 1.0)]):
        t = np.arange(0.0, 1.0, dt)
        w, s = 2 * np.pi * f, t - tau
        y = c * a * w * np.cos(w * s) + k * a * np.sin(w * s) + 0.05 * rng.standard_normal(len(t))
        records.append(Record(name=f"r{i}", t=t, x=a * np.sin(w * t), y=y))
    model = Constitutive([TimeDelay(tau=1e-3), Viscous(c=1.0), LinearStiffness(k=1.0)])
    res = identify(model, records, progress=False, seed=0)
    assert res.x["time_delay.tau"] == pytest.approx(tau, abs=0.1e-3)
    assert abs(res.x["time_delay.tau"] / dt - round(res.x["time_delay.tau"] / dt)) > 0.05  # not pulled to a sample
    assert res.x["viscous.c"] == pytest.approx(c, rel=0.02)
    assert res.x["linear_stiffness.k"] == pytest.approx(k, rel=0.02)
