"""Fixed-step explicit Runge–Kutta integration on the sample grid (the reference path).

Each sample interval [t_k, t_k+1] is split into ``substeps`` equal steps; the input is linearly
interpolated inside the interval. One Python loop over time for the whole batch: records,
conditions and parameter sets all travel along the batch dimension.
"""

from __future__ import annotations

import torch

from .inputs import lerp_sample

# Butcher tableaux (c, a, b) of the explicit schemes; order in the comment.
TABLEAUX = {
    "euler": ((0.0,), ((),), (1.0,)),  # order 1
    "heun": ((0.0, 1.0), ((), (1.0,)), (0.5, 0.5)),  # order 2
    "midpoint": ((0.0, 0.5), ((), (0.5,)), (0.0, 1.0)),  # order 2
    "rk4": ((0.0, 0.5, 0.5, 1.0), ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)), (1 / 6, 1 / 3, 1 / 3, 1 / 6)),  # order 4
}
ORDER = {"euler": 1, "heun": 2, "midpoint": 2, "rk4": 4}


def state_bounds(model, P, state0) -> tuple[torch.Tensor, torch.Tensor] | None:
    """``(lower, upper)`` tensors ``(batch, state_dim)`` (±inf where unbounded), or None without bounds."""
    spec = model.state_bounds(P) if hasattr(model, "state_bounds") else None
    if spec is None:
        return None
    inf = torch.full_like(state0, float("inf"))
    lo, hi = [-inf[:, 0]] * state0.shape[1], [inf[:, 0]] * state0.shape[1]
    for i, (a, b) in enumerate(spec):
        if a is not None:
            lo[i] = a.expand(state0.shape[0]).to(state0.dtype)
        if b is not None:
            hi[i] = b.expand(state0.shape[0]).to(state0.dtype)
    return torch.stack(lo, dim=1), torch.stack(hi, dim=1)


def integrate_fixed(model, U, t, P, state0, method: str = "rk4", substeps: int = 1,
                    controls: tuple[str, ...] = ()) -> torch.Tensor:
    """States at every sample time, ``(batch, time, state_dim)``; ``U (batch, time, 3 + C)`` carries the C control
    channels named ``controls`` after the input and its rates."""
    if method not in TABLEAUX:
        raise ValueError(f"unknown fixed-step method {method!r}; choose one of {sorted(TABLEAUX)}")
    if int(substeps) < 1:
        raise ValueError(f"substeps must be >= 1, got {substeps}")
    c, a, b = TABLEAUX[method]
    S = int(substeps)
    T = U.shape[1]
    if state0.shape[1] == 0:
        return state0[:, None, :].expand(-1, T, -1)
    bounds = state_bounds(model, P, state0)
    h_all = ((t[..., 1:] - t[..., :-1]) / S).expand(state0.shape[0], -1)[:, :, None]  # (batch, time - 1, 1)
    state = state0
    states = [state]
    for k in range(T - 1):
        Uk, Uk1, h = U[:, k], U[:, k + 1], h_all[:, k]
        for s in range(S):
            ks = []
            for j in range(len(c)):
                y = state
                for i, aji in enumerate(a[j]):
                    if aji:
                        y = y + (h * aji) * ks[i]
                ks.append(model.derivative(y, lerp_sample(Uk, Uk1, (s + c[j]) / S, controls), P))
            incr = sum((bj * kj for bj, kj in zip(b, ks) if bj), torch.zeros_like(state))
            state = state + h * incr
            if bounds is not None:  # projection onto the states' bounds (exact rate-independent operators)
                state = torch.where(state > bounds[1], bounds[1], torch.where(state < bounds[0], bounds[0], state))
        states.append(state)
    return torch.stack(states, dim=1)
