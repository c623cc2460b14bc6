"""The test-bed case record: ``Case`` (its data, nominal, split and truth), the ``CATEGORIES``, the library
names each expected family accepts (``ALIASES``) and the units of the bed's dampers and oscillators."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

CATEGORIES = ("single", "pair", "condition", "clean", "out_of_library")
COULOMB = frozenset({"coulomb", "asymmetric_coulomb"})
DAHL = frozenset({"dahl", "lugre"})
ALIASES = {"coulomb": COULOMB, "dahl": DAHL}

DAMPER_UNITS = {"x": "in", "F": "kip", "t": "s"}
MM_UNITS = {"x": "mm", "F": "N", "t": "s"}
OSC_UNITS = {"x": "in", "F": "kip", "u": "kip", "t": "s"}


@dataclass(frozen=True)
class Case:
    """One test-bed case.

    name, category : identification and one of ``CATEGORIES``.
    expected : one set per missing effect family, each of the acceptable library names.
    keys : (coordinate ``"<effect>.<param>"`` as discover names it, true value in the library's
        parametrisation, relative tolerance).
    noise : the noise standard deviation [response units] (the marginal sd for AR(1) noise).
    make_records : () -> RecordSet (the data, from ``generators``); make_nominal : () -> nominal model.
    split : ``{"held_out": query, "val": query or None}`` as ``RecordSet.split``.
    description : the truth in words; samples_per_cycle and noise_kind for the table.
    """

    name: str
    category: str
    expected: tuple[frozenset[str], ...]
    keys: tuple[tuple[str, float, float], ...]
    noise: float
    make_records: Callable[[], object] = field(repr=False)
    make_nominal: Callable[[], object] = field(repr=False)
    split: dict = field(default_factory=dict)
    description: str = ""
    samples_per_cycle: str = ""
    noise_kind: str = "white"
    trends_ok: tuple[str, ...] = ()  # conditions a clean control's base-law parameters follow: their trend steps
    # ("trends~<condition>") are the truth, not additions

    def records(self):
        return self.make_records()

    def nominal(self):
        return self.make_nominal()
