"""Input preparation shared by every solver: rates of the input, delays, interpolation."""

from __future__ import annotations

import torch

from ..physics.models import InputSample


def with_rates(u: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Complete an input ``(batch, time, C)`` with C in {1, 2, 3} to [u, u̇, ü] ``(batch, time, 3)``.

    Missing rates are second-order finite differences on the (possibly non-uniform) grid ``t``.
    """
    channels = u.shape[-1]
    if channels not in (1, 2, 3):
        raise ValueError(f"input has {channels} channels; give 1 (u), 2 (u, du/dt) or 3 (u, du/dt, d2u/dt2)")
    cols = [u[..., i] for i in range(channels)]
    edge = 2 if u.shape[1] >= 3 else 1
    while len(cols) < 3:
        (d,) = torch.gradient(cols[-1], spacing=(t,), dim=1, edge_order=edge)
        cols.append(d)
    return torch.stack(cols, dim=-1)


def interpolate(U: torch.Tensor, t: torch.Tensor, tq: torch.Tensor) -> torch.Tensor:
    """Linear interpolation of ``U (batch, time, C)`` at query times ``tq`` (``(batch, Q)``), held at the ends."""
    T = t.shape[0]
    idx = torch.searchsorted(t.contiguous(), tq.detach().contiguous(), right=True) - 1
    idx = idx.clamp(0, T - 2)
    t0, t1 = t[idx], t[idx + 1]
    w = ((tq - t0) / (t1 - t0)).clamp(0.0, 1.0)[..., None]
    gather = lambda i: torch.gather(U, 1, i[..., None].expand(-1, -1, U.shape[-1]))  # noqa: E731
    return gather(idx) * (1 - w) + gather(idx + 1) * w


def delayed(U: torch.Tensor, t: torch.Tensor, tau: torch.Tensor) -> torch.Tensor:
    """The input read ``tau (batch,)`` earlier: U(t − τ), held at its first value before t0."""
    tq = t[None, :] - tau[:, None]
    out = interpolate(U, t, tq)
    # before t0 the input is held at rest: its value persists, its rates are zero
    before = (tq < t[0])[..., None]
    rates_mask = torch.tensor([False, True, True], device=U.device)
    return torch.where(before & rates_mask, torch.zeros_like(out), out)


def sample(U: torch.Tensor, k: int) -> InputSample:
    return InputSample(U[:, k, 0], U[:, k, 1], U[:, k, 2])


def lerp_sample(Uk: torch.Tensor, Uk1: torch.Tensor, frac: float) -> InputSample:
    v = Uk + (Uk1 - Uk) * frac
    return InputSample(v[:, 0], v[:, 1], v[:, 2])
