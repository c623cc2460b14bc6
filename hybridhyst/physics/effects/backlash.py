"""Backlash (play operator): an input operator with a dead band."""

from __future__ import annotations

import math
from typing import ClassVar

import torch

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, rates, sign, tanh


class Backlash(Effect):
    """Smoothed play operator of half-width r acting on the displacement seen by later effects.

    The play output y [x] is the displacement that reaches the effects listed *after* this one (they see
    ``x = y``, ``v = ẏ``; effects before it, and inertia, see the unmodified motion). The state is the gap
    d = x − y (|d| ≤ r), and y = x − d::

        h = tanh((r − d · sign(v)) / ε)      share of the motion taken up by the gap
        ḋ = v · h
        ẏ = v · (1 − h)

    Inside the band (d · sign(v) < r − 2ε) h ≈ 1 and y stands still; once the gap closes in the direction of
    motion, d is pinned at ±r (exponentially, over a travel of a few ε) and y follows x with y = x ∓ r. So
    after each reversal y holds while x crosses the dead band of width 2r, and at r = 0 (with d(0) = 0) y = x
    exactly. ε → 0 recovers the exact play operator.

    Why not ẏ = v · sigmoid(((x − y) sign(v) − r) / ε): that rate never reaches v, so the gap creeps
    past r by about ε · ln(travel / ε) (≈ 8ε after a travel of 2000ε), widening the dead band and making
    r = 0 a lag instead of the identity. The tanh form has a stable fixed point at exactly d = ±r.

    Initial state: d(0) = 0, i.e. y(0) = x(0): the play starts centred on the excitation's initial value,
    whatever that value is (the operator acts on the coordinate relative to x(0)). Pass the full initial
    state to ``simulate`` to start at another gap.

    Units: r [x] (≥ 0, neutral 0, stored unconstrained), eps [x]; state d [x].

    Parameters
    ----------
    eps : smoothing width ε [x] (a fixed constant, stored as a buffer; default 1e-3). Keep ε ≪ r (a few %
        of r) and resolve it in time: the gap relaxes at rate |v| / ε, so the explicit solvers need
        |v| · h ≲ 2 ε (use ``substeps``).
    r : half-width of the play [x].

    Shapes: ``(batch,)``; state ``(batch, 1)``. ``force`` returns None (no force of its own).
    Source: M. A. Krasnosel'skii, A. V. Pokrovskii, "Systems with Hysteresis", Springer 1989 (play
    operator); backlash in gear and linkage transmissions.
    """

    name = "backlash"
    state_dim = 1
    equation = "h = tanh((r - d sign(v)) / eps);  dd/dt = v h;  later effects see x - d, v (1 - h)"
    source = "Krasnosel'skii & Pokrovskii 1989 (play operator)"
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "r": ParameterSpec(0.0, "x", (0.0, 1e6), "nonnegative", neutral=0.0, doc="half-width of the play"),
    }

    # for the discovery loop: a smoothing width of 2 % of the data's displacement scale (resolvable in time)
    discovery_constants = {"eps": ("x", 0.02)}

    def __init__(self, eps: float = 1e-3, **values):
        super().__init__(**values)
        if not math.isfinite(eps) or eps <= 0:
            raise ValueError(f"backlash: eps must be a positive number (smoothing width in x units), got {eps}")
        self.register_buffer("eps", torch.tensor(float(eps), dtype=torch.get_default_dtype()))

    def _taken_up(self, p, kin: Kinematics, gap: torch.Tensor) -> torch.Tensor:
        """h: ≈ 1 inside the dead band, 0 with the gap closed in the direction of motion."""
        return tanh((p["r"] - gap * sign(kin.v)) / float(self.eps))

    def rate(self, p, kin: Kinematics, state):
        return rates(kin.v * self._taken_up(p, kin, state[:, 0]))

    def transform(self, p, kin: Kinematics, state):
        gap = state[:, 0]
        return kin.moved(x=kin.x - gap, v=kin.v * (1 - self._taken_up(p, kin, gap)))
