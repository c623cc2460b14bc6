"""Input preparation shared by every solver: rates of the input, delays, interpolation."""

from __future__ import annotations

import torch

from ..physics.effects.base import signals
from ..physics.models import InputSample


def with_rates(u: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Complete an input ``(batch, time, C)`` with C in {1, 2, 3} to [u, u̇, ü] ``(batch, time, 3)``.

    Missing rates are second-order finite differences on the (possibly non-uniform) grid ``t``: one grid
    ``(time,)`` for every row, or one per row ``(batch, time)``.
    """
    channels = u.shape[-1]
    if channels not in (1, 2, 3):
        raise ValueError(f"input has {channels} channels; give 1 (u), 2 (u, du/dt) or 3 (u, du/dt, d2u/dt2)")
    cols = [u[..., i] for i in range(channels)]
    edge = 2 if u.shape[1] >= 3 else 1
    while len(cols) < 3:
        cols.append(gradient(cols[-1], t, edge))
    return torch.stack(cols, dim=-1)


def gradient(f: torch.Tensor, t: torch.Tensor, edge_order: int = 2) -> torch.Tensor:
    """df/dt of ``f (batch, time)`` on the grid ``t`` (``(time,)`` or ``(batch, time)``), as numpy's
    ``gradient``: second-order central differences inside, one-sided of ``edge_order`` at the ends."""
    if t.ndim == 1:
        (d,) = torch.gradient(f, spacing=(t,), dim=1, edge_order=edge_order)
        return d
    t = t.expand_as(f)
    if f.shape[1] < 3:
        d = (f[:, 1:] - f[:, :-1]) / (t[:, 1:] - t[:, :-1])
        return torch.cat([d, d[:, -1:]], dim=1) if f.shape[1] == 2 else torch.zeros_like(f)
    h = t[:, 1:] - t[:, :-1]
    a, b = h[:, :-1], h[:, 1:]  # the intervals left and right of each inner sample
    inner = (a**2 * f[:, 2:] - b**2 * f[:, :-2] + (b**2 - a**2) * f[:, 1:-1]) / (a * b * (a + b))
    if edge_order == 1:
        first = (f[:, 1] - f[:, 0]) / h[:, 0]
        last = (f[:, -1] - f[:, -2]) / h[:, -1]
    else:
        h0, h1 = h[:, 0], h[:, 1]
        first = (-(2 * h0 + h1) / (h0 * (h0 + h1)) * f[:, 0] + (h0 + h1) / (h0 * h1) * f[:, 1]
                 - h0 / (h1 * (h0 + h1)) * f[:, 2])
        hm, hn = h[:, -2], h[:, -1]
        last = (hn / (hm * (hm + hn)) * f[:, -3] - (hm + hn) / (hm * hn) * f[:, -2]
                + (2 * hn + hm) / (hn * (hm + hn)) * f[:, -1])
    return torch.cat([first[:, None], inner, last[:, None]], dim=1)


def interpolate(U: torch.Tensor, t: torch.Tensor, tq: torch.Tensor, slope: bool = False):
    """Linear interpolation of ``U (batch, time, C)`` sampled at ``t`` (``(time,)`` or ``(batch, time)``) at
    query times ``tq`` (``(batch, Q)``), held at the ends. ``slope``: also its derivative w.r.t. ``tq``, as
    ``(values, slopes)``: the slope of the interval (t_k, t_k+1] the query lies in, so at a sample the one of the
    interval before it (the side a delay that grows reads; autograd's the same), 0 where held (at t0 too)."""
    B, T, C = U.shape
    # the interval t_k < tq <= t_k+1 (left-open: a query on a sample lies in the interval before it)
    if t.ndim == 1:  # one grid for every row: searched and indexed as it is, not copied per row
        idx = (torch.searchsorted(t, tq.detach().contiguous()) - 1).clamp(0, T - 2)
        t0, t1 = (t.index_select(0, i.reshape(-1)).reshape(i.shape) for i in (idx, idx + 1))
    else:
        grid = t.expand(B, -1).contiguous()
        idx = (torch.searchsorted(grid, tq.detach().contiguous()) - 1).clamp(0, T - 2)
        t0, t1 = torch.gather(grid, 1, idx), torch.gather(grid, 1, idx + 1)
    r = (tq - t0) / (t1 - t0)
    # r <= 0 only at or before t0 (the input held): no derivative there, for autograd too
    w = torch.where(r > 0.0, r, torch.zeros_like(r)).clamp(max=1.0)[..., None]
    flat, first = U.reshape(B * T, C), (torch.arange(B, device=U.device) * T)[:, None]  # row b's samples at b·T

    def at(i):
        return flat.index_select(0, (i + first).reshape(-1)).reshape(B, -1, C)

    a, b = at(idx), at(idx + 1)
    out = a * (1 - w) + b * w
    if not slope:
        return out
    inside = ((r > 0.0) & (r <= 1.0)).to(U.dtype) / (t1 - t0)
    return out, (b - a) * inside[..., None]


def delayed(U: torch.Tensor, t: torch.Tensor, tau: torch.Tensor, derivative: bool = False):
    """The input read ``tau (batch,)`` earlier: U(t − τ), every channel (value and rates) held at its first sample
    before t0, so that the delayed input, and a fit's cost, is continuous in τ for a record that starts in motion
    as for one that starts at rest. ``derivative``: also its derivative w.r.t. τ (the forward sensitivities of a
    delay; 0 where held), as ``(input, derivative)``."""
    tq = t.expand(U.shape[0], -1) - tau[:, None]
    if not derivative:
        return interpolate(U, t, tq)
    out, slope = interpolate(U, t, tq, slope=True)
    return out, -slope


def input_sample(v: torch.Tensor, controls: tuple[str, ...] = ()) -> InputSample:
    """The input at one instant from a row ``(batch, 3 + C)``: u, u̇, ü, then the C control channels named
    ``controls`` (``with_controls``)."""
    return InputSample(v[:, 0], v[:, 1], v[:, 2], {c: v[:, 3 + i] for i, c in enumerate(controls)})


def lerp_sample(Uk: torch.Tensor, Uk1: torch.Tensor, frac: float, controls: tuple[str, ...] = ()) -> InputSample:
    return input_sample(Uk + (Uk1 - Uk) * frac, controls)


def with_controls(U: torch.Tensor, conditions: dict | None) -> tuple[torch.Tensor, tuple[str, ...]]:
    """The input ``(batch, time, 3)`` with the control channels among ``conditions`` (the ``(batch, time)``
    ones, in sorted order) as further columns, interpolated inside the sample intervals like the input; and
    their names."""
    names = tuple(sorted(signals(conditions)))
    if not names:
        return U, ()
    return torch.cat([U, torch.stack([conditions[c].to(U) for c in names], dim=-1)], dim=-1), names
