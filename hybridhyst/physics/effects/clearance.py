"""A clearance in series with a presliding friction element (backlash in a friction linkage)."""

from __future__ import annotations

from typing import ClassVar

from ..parameters import ParameterSpec
from .base import Effect, Kinematics, absolute, clamp, rates, sign


def dead_zone(q, r):
    """q − clamp(q, −r, r): 0 inside [−r, r], q ∓ r outside (r ≥ 0)."""
    return q - clamp(q, -r, r)


class Clearance(Effect):
    """A Dahl friction element driven through a clearance (gap) of half-width r.

    State and force::

        F = σ0 · dz(q),   dz(q) = q − clamp(q, −r, r)
        q̇ = v − |v| F / (Fc (1 + a sign v))

    q [x] is the gap opening plus the bristle deflection. With the gap closed (|q| > r) the element is
    Dahl's (deflection q ∓ r, saturating at ±Fc). After a reversal the bristle first unloads elastically
    (slope σ0), the force reaches zero, the gap opens and the force stays exactly zero while the input
    crosses the clearance (width 2r), then the element loads the other way. This is backlash in *series*
    with the friction element — the link transmits no force across the open gap — unlike ``backlash``, a
    play on the input whose downstream elements keep their state (and a Dahl element its saturated force)
    through the dead band. The sliding level may depend on the direction, Fc (1 ± a): a band brake is
    self-energising in one sense of rotation (the capstan ratio e^(μθ) between its two ends), a seal or
    guide may grip harder one way. r = 0, a = 0 is exactly ``Dahl``; with σ0 → ∞ it is ``backlash`` in
    front of ``asymmetric_coulomb`` (``coulomb`` at a = 0). The right side is continuous and piecewise
    smooth in q, so the fixed-step solver needs no smoothing width (the bristle relaxes at σ0 |v| / Fc, as
    in ``Dahl``: step doubling resolves it).

    Units: sigma0 [F/x] (> 0, presliding stiffness), Fc [F] (> 0, mean sliding level), a [-] (in
    [−0.9, 0.9], neutral 0: the level is Fc (1 + a) for v > 0 and Fc (1 − a) for v < 0), r [x] (≥ 0,
    neutral 0: no clearance). Shapes: ``(batch,)``; state ``(batch, 1)``, q(0) = 0 (the gap centred, no load) or ``q0``
    (optional: where the motion before a record left the gap).
    Source: P. R. Dahl, Aerospace Corp. TOR-0158(3107-18)-1, 1968 (friction element); a clearance in
    series as in M. Nordin, P.-O. Gutman, "Controlling mechanical systems with backlash — a survey",
    Automatica 38(10), 1633–1649, 2002 (the dead-zone model of a gap in a transmission).
    """

    name = "clearance"
    example_values = {"sigma0": 5.0, "Fc": 1.0, "a": 0.2, "r": 0.05}
    state_dim = 1
    equation = "F = sigma0 (q - clamp(q, -r, r));  dq/dt = v - |v| F / (Fc (1 + a sign v))"
    source = "Dahl 1968; Nordin & Gutman 2002 (dead-zone backlash)"
    special_cases = (("dahl",), ("backlash", "asymmetric_coulomb"), ("backlash", "coulomb"))
    start: ClassVar[dict[str, ParameterSpec]] = {
        "q0": ParameterSpec(0.0, "x", (-1e9, 1e9), "real", neutral=0.0, signed=True,
                            doc="gap opening + deflection at the start of each record (0: gap centred, no load)"),
    }
    specs: ClassVar[dict[str, ParameterSpec]] = {
        "sigma0": ParameterSpec(1e3, "F/x", (1e-9, 1e12), "positive", doc="presliding stiffness behind the gap"),
        "Fc": ParameterSpec(1.0, "F", (1e-12, 1e9), "positive", doc="sliding (Coulomb) friction level"),
        "a": ParameterSpec(0.0, "-", (-0.9, 0.9), "bounded", neutral=0.0, doc="direction asymmetry of the level"),
        "r": ParameterSpec(0.0, "x", (0.0, 1e6), "nonnegative", neutral=0.0, doc="half-width of the clearance"),
    }

    def rate(self, p, kin: Kinematics, state):
        F = self.force(p, kin, state)
        return rates(kin.v - absolute(kin.v) * F / (p["Fc"] * (1 + p["a"] * sign(kin.v))))

    def force(self, p, kin: Kinematics, state):
        return p["sigma0"] * dead_zone(state[:, 0], p["r"])
