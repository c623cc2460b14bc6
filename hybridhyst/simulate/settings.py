"""``SimulationSettings``: how a model is integrated (scheme, sub-steps, backend, solver, tolerances, device), one
frozen object that apps, identification, discovery and training pass down instead of loose keyword arguments."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from ..settings import check_fields, from_mapping

__all__ = ["SimulationSettings"]

SCHEMES = ("euler", "heun", "midpoint", "rk4")


@dataclass(frozen=True)
class SimulationSettings:
    """How ``simulate`` integrates a model.

    Parameters
    ----------
    method : the integration scheme: for ``solver="fixed"`` one of "euler", "heun", "midpoint", "rk4"; for
        ``solver="torchdiffeq"`` a torchdiffeq method; None: the solver's default ("rk4", "dopri5").
    substeps : sub-steps per sample interval (fixed-step solver).
    backend : "fast" (a C loop generated and built per model, exact gradients) or "reference" (the plain
        PyTorch loop, the oracle); the fast backend runs the fixed-step solver only.
    solver : "fixed" or "torchdiffeq" (adaptive, ``rtol``/``atol``).
    device : where the inputs go ("cpu", "cuda", ...); None: the model's device.
    """

    method: str | None = "rk4"
    substeps: int = 1
    backend: str = "fast"
    solver: str = "fixed"
    rtol: float = 1e-7
    atol: float = 1e-9
    device: str | None = None

    def __post_init__(self):
        if self.backend not in ("fast", "reference"):
            raise ValueError(f"unknown backend {self.backend!r}; choose 'fast' or 'reference'")
        if self.solver not in ("fixed", "torchdiffeq"):
            raise ValueError(f"unknown solver {self.solver!r}; choose 'fixed' or 'torchdiffeq'")
        if self.solver == "fixed" and self.method is not None and self.method not in SCHEMES:
            raise ValueError(f"unknown fixed-step method {self.method!r}; choose one of {list(SCHEMES)}")
        if isinstance(self.substeps, bool) or int(self.substeps) != self.substeps or self.substeps < 1:
            raise ValueError(f"substeps must be a whole number >= 1, got {self.substeps!r}")
        if self.backend == "fast" and self.solver != "fixed":
            raise ValueError("backend='fast' runs the fixed-step solver only; use solver='fixed'")
        object.__setattr__(self, "substeps", int(self.substeps))

    def at(self, substeps: int) -> SimulationSettings:
        """The same settings at ``substeps`` sub-steps per sample interval."""
        return self.replace(substeps=int(substeps))

    def replace(self, **changes) -> SimulationSettings:
        """These settings with ``changes`` (field names; a misspelt one is a one-line error)."""
        check_fields(SimulationSettings, changes, "simulation")
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for JSON outputs and reports)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_config(cls, block, where: str = "simulation", **given) -> SimulationSettings:
        """From a config block (``simulation:`` of an app's config): unknown keys and wrong types are one-line
        errors naming the key."""
        return from_mapping(cls, block, where, **given)

    @classmethod
    def of(cls, settings: SimulationSettings | None, default: SimulationSettings | None = None,
           **overrides) -> SimulationSettings:
        """``settings`` (or ``default``, or the defaults) with the overrides that are not None laid over it."""
        base = settings if settings is not None else (default if default is not None else cls())
        changes = {k: v for k, v in overrides.items() if v is not None}
        return dataclasses.replace(base, **changes) if changes else base
