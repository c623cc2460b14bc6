"""Every effect's parameters get the right gradient, and an effect at its neutral values changes nothing."""

from __future__ import annotations

import math

import pytest
import torch
from test_effects import NEW_EFFECTS, raw

from hybridhyst.physics.effects import (
    LinearStiffness,
    Viscous,
)
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate

pytestmark = pytest.mark.usefixtures("float64")  # conftest: float64 default dtype, restored afterwards


# -- neutral values and gradients ---------------------------------------------------------------------------
def random_excitation(batch: int = 2, samples: int = 60, dt: float = 0.01):
    g = torch.Generator().manual_seed(1)
    t = torch.arange(samples) * dt
    freqs = torch.tensor([1.0, 2.3, 4.1])
    phases = 2 * math.pi * torch.rand(batch, 3, 1, generator=g)
    amps = 0.3 * torch.rand(batch, 3, 1, generator=g) + 0.1
    return t, (amps * torch.sin(2 * math.pi * freqs[:, None] * t + phases)).sum(1)


# where an effect's example values leave a parameter without effect on this test's small motion: a play narrower than
# the oscillator's travel (its gap must close for r to matter)
GRADIENT_VALUES = {"backlash": {"r": 0.02}, "clearance": {"sigma0": 25.0, "Fc": 0.5, "a": 0.2, "r": 0.02},
                   # a follower that creeps back acts only where it is away from rest: started so, inside the gap
                   "relaxing_backlash": {"d0": -0.01}}


def structures(effect):
    """The effect under test first (so a backlash or delay reaches the springs), then springs and damping."""
    def rest():
        return [LinearStiffness(k=3.0), Viscous(c=0.5)]

    return {"constitutive": Constitutive([effect, *rest()]),
            "oscillator": DrivenOscillator([effect, *rest()], mass=1.0)}


@pytest.mark.parametrize("structure", ["constitutive", "oscillator"])
@pytest.mark.parametrize("cls", NEW_EFFECTS, ids=lambda c: c.name)
def test_every_parameter_gets_the_right_gradient(cls, structure):
    """Every parameter gets a finite non-zero gradient, and it matches a central difference along it."""
    effect = cls(**{**cls.example_values, **GRADIENT_VALUES.get(cls.name, {})})
    model = structures(effect)[structure]
    t, u = random_excitation()
    leaves = [raw(effect, n) for n in effect.params]

    def loss():
        return simulate(model, u, t=t, substeps=2).square().sum()

    grads = torch.autograd.grad(loss(), leaves)
    for name, grad in zip(effect.params, grads, strict=True):
        assert torch.isfinite(grad) and grad != 0, f"{cls.name}.{name}: gradient {grad}"
    norm = torch.sqrt(sum(g**2 for g in grads))
    step = 1e-5
    with torch.no_grad():
        ends = []
        for sign in (1.0, -2.0, 1.0):  # +step, -step, back to the start
            for leaf, g in zip(leaves, grads, strict=True):
                leaf.add_(sign * step * g / norm)
            ends.append(loss())
    assert float((ends[0] - ends[1]) / (2 * step)) == pytest.approx(float(norm), rel=1e-6)


# every effect with neutral values (``ParameterSpec.neutral``): at them it adds nothing; discovery grows it from there
# (but those whose neutral friction level leaves their bristle stiffness dividing by zero: LuGre's and the clearance's
# state rate is sigma0 v |z| / Fc, so at Fc = 0 the state is not defined and they are grown from a small Fc instead)
NEUTRAL = tuple(cls for cls in NEW_EFFECTS if any(spec.neutral is not None for spec in cls.specs.values())
                and cls.name not in ("lugre", "clearance"))


@pytest.mark.parametrize("cls", NEUTRAL, ids=lambda c: c.name)
def test_neutral_effect_changes_nothing_and_still_learns(cls):
    """At its neutral values an added effect leaves the response unchanged, and its neutral parameters still
    get a gradient (so discovery can grow the effect from there): an amplitude at once; a parameter that only
    shapes another's amplitude (a drift's levelling rate λ: its force is the drift times a worked travel that λ
    bends) has none while that amplitude is 0, so it must get one as soon as the others leave neutral."""
    neutral = {n: s.neutral for n, s in cls.specs.items() if s.neutral is not None}
    effect = cls(**neutral)
    t, u = random_excitation()
    for name, model in structures(effect).items():
        reference = structures(Viscous(c=0.0))[name]  # the same structure without the effect
        y = simulate(model, u, t=t, substeps=2)
        assert torch.allclose(y, simulate(reference, u, t=t, substeps=2), atol=1e-12), name
        grads = dict(zip(neutral, torch.autograd.grad(y.square().sum(), [raw(effect, n) for n in neutral]),
                         strict=True))
        assert all(torch.isfinite(g) for g in grads.values()) and any(g != 0 for g in grads.values()), \
            f"{cls.name}: gradients {grads} at neutral ({name})"
        for pname in [p for p, g in grads.items() if g == 0]:
            grown = cls(**{**cls.example_values, **GRADIENT_VALUES.get(cls.name, {}), pname: neutral[pname]})
            y = simulate(structures(grown)[name], u, t=t, substeps=2)
            (grad,) = torch.autograd.grad(y.square().sum(), [raw(grown, pname)])
            assert torch.isfinite(grad) and grad != 0, f"{cls.name}.{pname}: gradient {grad} at neutral ({name})"
