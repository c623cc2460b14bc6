"""The base of parameter functions: ``ParameterFunction`` (a module mapping conditions to a parameter value,
owning its coordinates) and ``FunctionCoordinate`` (one free scalar as identification sees it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn.utils import parametrize

from .constraints import _interior

__all__ = ["FunctionCoordinate", "ParameterFunction"]


def _condition_tensor(conditions: dict[str, torch.Tensor] | None, name: str, like: torch.Tensor) -> torch.Tensor:
    if conditions is None or name not in conditions:
        known = sorted(conditions) if conditions else []
        raise ValueError(
            f"parameter function needs condition {name!r} but the records give {known}; give every record a "
            f"{name!r} condition (data.conditions) or control channel (data.controls) — for a generated input, "
            f"'+conditions.{name}=<value>' — or use a constant parameter"
        )
    return torch.as_tensor(conditions[name], dtype=like.dtype, device=like.device)


@dataclass(frozen=True)
class FunctionCoordinate:
    """One free scalar of a parameter function, as identification's global search sees it.

    Attributes
    ----------
    suffix : appended to ``effect.param`` to name it: ``""`` (a constant), ``".c1"``, ``".y0"``,
        ``"[pressure_mpa=0.05]"``, ``".net.head.weight[0]"``.
    value : its current value.
    own : a value of the parameter itself (constants, per-condition levels): the parameter's unit and
        ``ParameterSpec.bounds`` apply to it; coefficients have other units.
    power : the power of the condition the coordinate multiplies (polynomial coefficients), else 0.
    signed : its sign is not known in advance (network weights): search it in a box symmetric about 0.
    nonnegative : it is never negative (the coefficients of a ``Polynomial(..., nonnegative=True)``): every
        search box starts at 0 at the lowest.
    """

    suffix: str
    value: float
    own: bool = False
    power: int = 0
    signed: bool = False
    nonnegative: bool = False


class ParameterFunction(nn.Module):
    """Base class: ``forward(conditions, batch) -> (batch,)`` parameter values.

    A function owns its *coordinates*, the free scalars that identification searches: ``coordinates()``
    declares them (names, current values, box hints), ``coordinate_values()`` reads them ``(k,)``,
    ``set_coordinates`` writes them back (through the constraint's ``right_inverse``), and
    ``evaluate_batch(coords (P, k), conditions, batch) -> (P, batch)`` evaluates P coordinate vectors at
    once. ``forward`` is ``evaluate_batch`` at the function's own coordinates, so both use one formula.
    Subclasses list the tensors holding the coordinates in ``_attrs`` (in coordinate order) and describe
    each element in ``_coordinate`` (its name suffix and box hints); ``coordinates()`` reads the values from
    those tensors, so the coordinates are listed once.
    """

    condition: str | None = None
    _attrs: tuple[str, ...] = ()
    _own: str | None = None  # the attribute holding values of the parameter itself (projected to bounds)

    def forward(self, conditions: dict[str, torch.Tensor] | None, batch: int) -> torch.Tensor:
        return self.evaluate_batch(self.coordinate_values()[None], conditions, batch)[0]

    def evaluate_batch(self, coords: torch.Tensor, conditions: dict[str, torch.Tensor] | None,
                       batch: int) -> torch.Tensor:
        """Values ``(P, batch)`` for P coordinate vectors ``coords (P, k)`` (differentiable w.r.t. coords)."""
        raise NotImplementedError(f"{type(self).__name__} does not implement evaluate_batch")

    def coordinates(self) -> list[FunctionCoordinate]:
        """The free scalars, in the order of ``coordinate_values``: one per element of the tensors named in
        ``_attrs`` (``_coordinate_tensors``), each described by the subclass's ``_coordinate``."""
        if type(self)._coordinate is ParameterFunction._coordinate:
            raise NotImplementedError(
                f"{type(self).__name__} does not declare its coordinates; implement _coordinate(), _attrs and "
                "evaluate_batch() (see ParameterFunction), or use a constant, fixed, polynomial/linear, "
                "exponential, per-condition or neural function"
            )
        return [self._coordinate(path, i, v) for path, t in self._coordinate_tensors()
                for i, v in enumerate(t.detach().reshape(-1).tolist())]

    def _coordinate(self, path: str, index: int, value: float) -> FunctionCoordinate:
        """The description of element ``index`` (value ``value``) of the coordinate tensor ``path``."""
        raise NotImplementedError

    def _coordinate_tensors(self) -> list[tuple[str, torch.Tensor]]:
        return [(a, getattr(self, a)) for a in self._attrs]

    def coordinate_values(self) -> torch.Tensor:
        """The current coordinates ``(k,)`` in the function's dtype (differentiable; constrained values)."""
        parts = [t.reshape(-1) for _, t in self._coordinate_tensors()]
        if not parts:
            like = next(iter([*self.parameters(), *self.buffers()]), torch.zeros(()))
            return like.new_zeros(0)
        return torch.cat(parts) if len(parts) > 1 else parts[0]

    def set_coordinates(self, x) -> None:
        """Write coordinates ``x (k,)`` (constrained values; moved strictly inside a constraint's range)."""
        x = torch.as_tensor(x).detach().reshape(-1)
        sizes = [t.numel() for _, t in self._coordinate_tensors()]
        if x.shape[0] != sum(sizes):
            raise ValueError(f"{type(self).__name__} has {sum(sizes)} coordinates, got {x.shape[0]}")
        offset = 0
        with torch.no_grad():
            for (path, t), n in zip(self._coordinate_tensors(), sizes):
                value = x[offset:offset + n].reshape(t.shape).to(dtype=t.dtype, device=t.device)
                offset += n
                owner, _, attr = path.rpartition(".")
                module = self.get_submodule(owner) if owner else self
                if parametrize.is_parametrized(module, attr):
                    setattr(module, attr, _interior(module, attr, value))
                else:
                    getattr(module, attr).copy_(value)

    def project(self, lower: float, upper: float) -> None:
        """Clamp values of the parameter itself that are stored unconstrained into ``[lower, upper]``.

        Only ``Constant`` and ``PerCondition`` hold such values; a parametrized one is already admissible,
        and coefficients of a function of a condition have no bounds of their own.
        """
        if self._own is None or parametrize.is_parametrized(self, self._own):
            return
        with torch.no_grad():
            getattr(self, self._own).clamp_(min=lower if math.isfinite(lower) else None,
                                            max=upper if math.isfinite(upper) else None)

    # -- following a control signal ---------------------------------------------------------------------
    def suffixes(self) -> list[str]:
        """The names of the coordinates, appended to the parameter's (``".c0"``, ``".y0"``): the values a
        function of a control signal passes to the simulator in its place (``Effect.evaluate``)."""
        return [c.suffix for c in self.coordinates()]

    def at(self, coords: list, c):
        """The value at one instant from the coordinates ``coords`` (one entry per coordinate: ``(batch,)``
        tensors or sympy symbols) and the control's value ``c`` there: how a function of a control channel
        (``Record.controls``) is evaluated at every integration stage, on both backends. Functions of a level
        (per-condition values, a network) cannot follow a signal."""
        raise ValueError(f"a {type(self).__name__} parameter function cannot follow the control signal "
                         f"{self.condition!r}: give it as linear, polynomial or exponential in {self.condition!r}, "
                         "or use a condition constant within each record")

    def _c(self, conditions, batch: int, like: torch.Tensor) -> torch.Tensor:
        """The condition ``(1, batch)`` in ``like``'s dtype."""
        return _condition_tensor(conditions, self.condition, like).expand(batch)[None]

    def describe(self) -> str:
        return type(self).__name__

    def config(self):
        """The config value that ``build_function`` turns back into this function with its current values (a
        number or ``{"kind": ..., ...}``); the inverse that ``physics.model_config`` writes a model with."""
        raise NotImplementedError(f"{type(self).__name__} cannot be written as a config")
