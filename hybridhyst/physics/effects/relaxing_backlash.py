"""A clearance whose far side returns to rest while the gap is open (a spring-dashpot behind a pin with play)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .backlash import Backlash
from .base import Kinematics, clamp, rates


class RelaxingBacklash(Backlash):
    """Play of half-width r whose follower relaxes to rest at the rate λ while the gap is open.

    ``backlash`` holds its follower y (the displacement the effects after it see) while the input crosses the
    gap: right for what stays where it was left (a dashpot alone, a friction element). An element with a spring
    behind a clearance does not stay: a spring k parallel to a dashpot c, driven through a pin with play, carries
    no force while the pin is free, so its piston creeps back, c ẏ + k y = 0, ẏ = −(k/c) y, and the pin meets it
    earlier on the way back. This effect is that follower: with the gap d = x − y in [−r, r],

        ḋ = v + λ y,   d ← clamp(d, −r, r)            (projected after every step, as ``backlash``)
        y = x − clamp(d, −r, r),   ẏ = v while the gap is closed in the direction it is driven, else −λ y

    so a spring k and a dashpot c after it transmit exactly no force across the open gap when λ = k / c (the
    data decide λ; other elements after it see a follower that returns to rest at that rate). λ = 0 is
    ``backlash`` (its special case), r = 0 the identity whatever λ. y relaxes to 0, the rest position of the
    stiffness after it (F = k x). A fast return (λ far above the records' rates: a spring with little damping
    behind the gap) is stiff: step doubling (``simulation.substeps``) resolves it. Discovery offers it where
    ``discover.candidates`` lists it, not by default.

    Initial state: d(0) = 0 (the follower at the input's initial value) or ``d0`` (optional), as ``backlash``.

    Units: r [x] (≥ 0, neutral 0), lam [1/t] (≥ 0, neutral 0: the follower held, ``backlash``); state d [x].
    Shapes: ``(batch,)``; state ``(batch, 1)``. ``force`` returns None (no force of its own).
    Source: a play operator (M. A. Krasnosel'skii, A. V. Pokrovskii, "Systems with Hysteresis", Springer 1989)
    driving a Kelvin–Voigt element through the gap (the dead-zone model of a clearance in a linkage:
    M. Nordin, P.-O. Gutman, Automatica 38(10), 1633–1649, 2002).
    """

    name = "relaxing_backlash"
    example_values = {"r": 0.02, "lam": 3.0}  # a play the gradient tests' short motion closes
    equation = ("dd/dt = v + lam (x - d), d in [-r, r] (projected);  later effects see x - d, "
                "v if the gap is closed else -lam (x - d)")
    source = "Krasnosel'skii & Pokrovskii 1989 (play operator); Nordin & Gutman 2002 (a Kelvin element behind a gap)"
    special_cases = (("backlash",),)
    # offered by the loop only where a user lists it (discover.candidates): as a default candidate its creeping
    # follower stood in for a friction element behind a gap (the first bed's clearance~current+start, 1.03 ->
    # 4.59 x noise; experiments/discovery_testbed/README.md)
    discovery_candidate = False
    specs: ClassVar[dict[str, ParameterSpec]] = {
        **Backlash.specs,
        "lam": ParameterSpec(0.0, "1/t", (0.0, 1e9), "nonnegative", neutral=0.0,
                             doc="rate at which the follower returns to rest while the gap is open (k / c of a "
                                 "spring-dashpot behind it)"),
    }

    def _follower(self, p, kin: Kinematics, state):
        """The follower y, the free gap rate v + λ y, and whether the gap is closed in that direction."""
        gap = clamp(state[:, 0], -p["r"], p["r"])
        y = kin.x - gap
        free = kin.v + p["lam"] * y
        return y, free, self.closed(state[:, 0], free, p["r"])

    def rate(self, p, kin: Kinematics, state):
        _, free, _ = self._follower(p, kin, state)
        return rates(free)

    def transform(self, p, kin: Kinematics, state):
        y, _, closed = self._follower(p, kin, state)
        return kin.moved(x=y, v=kin.v * closed - p["lam"] * y * (1 - closed))
