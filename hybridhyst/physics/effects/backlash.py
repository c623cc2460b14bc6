"""Backlash (play operator): an input operator with a dead band, exact at any step size."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, clamp, rates, sign, step


class Backlash(Effect):
    """Play operator of half-width r acting on the displacement seen by later effects.

    The play output y [x] is the displacement that reaches the effects listed *after* this one (they see
    ``x = y``, ``v = ẏ``; effects before it, and inertia, see the unmodified motion). The state is the gap
    d = x − y, kept in [−r, r] by the simulator (``state_bounds``: projected after every step)::

        ḋ = v,   d ← clamp(d, −r, r)                 (the gap takes up the motion until it closes)
        y = x − clamp(d, −r, r),   ẏ = v · [d · sign(v) ≥ r]   (y moves only with the gap closed)

    Over one step of a monotone input this is the discrete play operator, d_{k+1} = clamp(d_k + Δx, −r, r),
    with Δx the integral of the interpolated input velocity (second-order accurate in the sample interval:
    1 % of the stroke at 16 samples per cycle, 2e-5 at 400): after each reversal y holds while x crosses
    the dead band of width 2r, then follows with y = x ∓ r. No smoothing width and no stiffness, so it is
    resolved at any sample rate (a smoothed ODE whose gap relaxes at |v|/ε needs steps far below ε / |v|).
    Only the fixed-step solver projects the state (``solver="torchdiffeq"`` refuses it). r = 0 is the identity
    (d ≡ 0, y = x), the neutral start of the discovery loop; the gradient with respect to r is exact almost
    everywhere (through the projection while the gap is closed).

    Initial state: d(0) = 0, i.e. y(0) = x(0): the play starts centred on the excitation's initial value.
    ``d0`` (optional) starts every record at another gap (where the motion before it left the play); or pass
    the full initial state to ``simulate``.

    Units: r [x] (≥ 0, neutral 0, stored unconstrained); state d [x].
    Shapes: ``(batch,)``; state ``(batch, 1)``. ``force`` returns None (no force of its own).
    Source: M. A. Krasnosel'skii, A. V. Pokrovskii, "Systems with Hysteresis", Springer 1989 (play
    operator); backlash in gear and linkage transmissions.
    """

    name = "backlash"
    example_values = {"r": 0.1}
    state_dim = 1
    equation = "dd/dt = v, d in [-r, r] (projected);  later effects see x - d, v [d sign(v) >= r]"
    source = "Krasnosel'skii & Pokrovskii 1989 (play operator)"
    start: ClassVar[dict[str, ParameterSpec]] = {
        "d0": ParameterSpec(0.0, "x", (-1e9, 1e9), "real", neutral=0.0, signed=True,
                            doc="gap at the start of each record (0: the play centred on the initial input)"),
    }
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "r": ParameterSpec(0.0, "x", (0.0, 1e6), "nonnegative", neutral=0.0, doc="half-width of the play"),
    }

    def rate(self, p, kin: Kinematics, state):
        return rates(kin.v)

    def state_bounds(self, p):
        return [(-p["r"], p["r"])]

    @staticmethod
    def closed(gap, driven, r):
        """1 where the gap is closed in the direction it is driven (``driven``: its free rate), else 0; always
        closed at r = 0 (the identity, even where the input reverses inside a step)."""
        return 1 - (1 - step(gap * sign(driven) - r)) * (1 - step(-r))

    def transform(self, p, kin: Kinematics, state):
        gap = state[:, 0]
        return kin.moved(x=kin.x - clamp(gap, -p["r"], p["r"]), v=kin.v * self.closed(gap, kin.v, p["r"]))
