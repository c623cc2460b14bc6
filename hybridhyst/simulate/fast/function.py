"""The fast path as a ``torch.autograd.Function``: compiled forward loop, exact discrete adjoint."""

from __future__ import annotations

import functools

import numpy as np
import torch

from ...physics.effects.neural import NeuralEffect
from ..fixed import TABLEAUX
from .build import compile_equations, prebuild
from .equations import build_equations

_COMPILED: dict[tuple, tuple] = {}


def _buffers(module) -> list:
    """The module's buffers and its submodules', depth first (what ``Module.buffers()`` yields, without its
    generators: this runs at every simulation)."""
    out = [b for b in module._buffers.values() if b is not None]
    for child in module._modules.values():
        if child is not None:
            out += _buffers(child)
    return out


def _constants(model) -> tuple:
    """What the generated code holds beyond the parameter values: which effect objects it was built from, and
    for networks their layer shapes, activation, inputs and buffers (scales and condition statistics, which a
    state dict may overwrite in place)."""
    out = []
    for key, e in model.effects.items():
        entry = (key, id(e), tuple(tuple(b.reshape(-1).tolist()) for b in _buffers(e)))
        if isinstance(e, NeuralEffect):
            entry += (id(e.net), tuple(tuple(lin.weight.shape) for lin in e.net.layers()), e.net.activation,
                      e.inputs, e.condition_names)
        out.append(entry)
    return tuple(out)


def compiled(model, controls: tuple[str, ...] = ()):
    """(equations, generated module) for a model with the control channels ``controls``, cached per model instance
    (and its networks' constants)."""
    key = (id(model), tuple(controls))
    hit = _COMPILED.get(key)
    constants = _constants(model)
    if hit is None or hit[0] is not model or hit[1] != constants:
        eq = build_equations(model, tuple(controls))
        hit = (model, constants, eq, compile_equations(eq))
        _COMPILED[key] = hit
    return hit[2], hit[3]


def prebuild_models(models, controls: tuple[str, ...] = ()) -> None:
    """Build the compiled loops a fit runs of several models side by side (one compiler process each, as many at
    once as there are cores), before they are simulated one after another: a discovery step's candidates (with the
    control channels ``controls`` of the records they will simulate). The loops: the values and the forward
    sensitivities."""
    prebuild([(build_equations(m, tuple(controls)), ("forward", "tangent")) for m in models])


def _theta(eq, P, model, B: int, like: torch.Tensor) -> torch.Tensor:
    """``(batch, P + weights)``: each row's parameter values, then every network's weights (shared)."""
    cols = [torch.stack([P[key][name].expand(B) for key, name in eq.param_keys], dim=1)] if eq.param_keys else []
    for net in eq.networks:
        flat = torch.cat([t.reshape(-1) for lin in model.effects[net.key].net.layers() for t in (lin.weight, lin.bias)])
        cols.append(flat.to(dtype=like.dtype, device=like.device).expand(B, -1))
    return torch.cat(cols, dim=1) if cols else like.new_zeros(B, 0)


def _numpy(x: torch.Tensor) -> np.ndarray:
    """A tensor as the contiguous float64 host array the compiled loops read."""
    return np.ascontiguousarray(x.detach().to(device="cpu", dtype=torch.float64).numpy())


@functools.cache
def _tableau(method: str):
    """The Butcher tableau ``(c, A, b)`` of ``method`` as the read-only arrays the loops take (built once)."""
    if method not in TABLEAUX:
        raise ValueError(f"unknown fixed-step method {method!r}; choose one of {sorted(TABLEAUX)}")
    c, a, b = TABLEAUX[method]
    A = np.zeros((len(c), len(c)))
    for j, row in enumerate(a):
        A[j, : len(row)] = row
    out = np.array(c, dtype=np.float64), A, np.array(b, dtype=np.float64)
    for arr in out:
        arr.flags.writeable = False
    return out


def _forward(theta, U, s0, h, module, method, substeps, output_dim) -> tuple:
    """The compiled forward loop on host arrays: ``(U, h, th, states, y)`` as numpy."""
    c, A, bw = _tableau(method)
    th, Un, s0n, hn = (_numpy(x) for x in (theta, U, s0, h))
    B, T = Un.shape[0], Un.shape[1]
    states = np.empty((B, T, s0n.shape[1]))
    y = np.empty((B, T, output_dim))
    module.forward(Un, hn, th, s0n, c, A, bw, int(substeps), states, y)
    return Un, hn, th, states, y


class _FastSimulate(torch.autograd.Function):
    @staticmethod
    def forward(ctx, theta, U, s0, h, module, method, substeps, output_dim):
        Un, hn, th, states, y = _forward(theta, U, s0, h, module, method, substeps, output_dim)
        c, A, bw = _tableau(method)
        ctx.save_for_backward(theta, U, s0)
        ctx.numpy = (Un, hn, th, states, c, A, bw, int(substeps), module, y.shape)
        if any(ctx.needs_input_grad):
            states_out = states.copy()  # the adjoint keeps its own
        else:
            states_out = states  # no backward will read them
        S = torch.from_numpy(states_out).to(dtype=U.dtype, device=U.device)
        return torch.from_numpy(y).to(dtype=U.dtype, device=U.device), S

    @staticmethod
    def backward(ctx, gy, gs=None):
        theta, U, s0 = ctx.saved_tensors
        Un, hn, th, states, c, A, bw, sub, module, y_shape = ctx.numpy

        def numpy(g, shape):
            return np.zeros(shape) if g is None else _numpy(g)

        gth = np.zeros_like(th)
        gU = np.zeros_like(Un)
        gs0 = np.zeros((th.shape[0], states.shape[2]))
        module.backward(Un, hn, th, states, numpy(gy, y_shape), numpy(gs, states.shape), c, A, bw, sub,
                        gth, gU, gs0)

        def back(arr, like):
            return torch.from_numpy(arr).to(dtype=like.dtype, device=like.device)

        return back(gth, theta), back(gU, U), back(gs0, s0), None, None, None, None, None


def simulate_fast(model, U: torch.Tensor, t: torch.Tensor, P: dict, state0: torch.Tensor, method: str = "rk4",
                  substeps: int = 1, return_states: bool = False, controls: tuple[str, ...] = ()):
    """Outputs ``(batch, time, output_dim)`` of the compiled loop; differentiable like the reference. ``U (batch,
    time, 3 + C)``: the input, its rates and the C control channels named ``controls``.

    With ``return_states`` also the states ``(batch, time, state_dim)`` at the samples, differentiable like
    the outputs (their cotangent enters the same discrete adjoint).
    """
    if int(substeps) < 1:
        raise ValueError(f"substeps must be >= 1, got {substeps}")
    eq, module = compiled(model, controls)
    B = U.shape[0]
    theta = _theta(eq, P, model, B, U)
    h = (t[..., 1:] - t[..., :-1]).expand(B, -1).contiguous()  # (batch, time - 1): each row its own grid
    if torch.is_grad_enabled() and any(x.requires_grad for x in (theta, U, state0)):
        y, states = _FastSimulate.apply(theta, U.contiguous(), state0, h, module, method, int(substeps),
                                        model.output_dim)
    else:  # nothing to differentiate (a fit's residuals): the loop without autograd's bookkeeping
        *_, S, Y = _forward(theta, U, state0, h, module, method, int(substeps), model.output_dim)
        y, states = (torch.from_numpy(a).to(dtype=U.dtype, device=U.device) for a in (Y, S))
    return (y, states) if return_states else y


def tangent_fast(model, U: torch.Tensor, t: torch.Tensor, P: dict, state0: torch.Tensor, dstate0: torch.Tensor,
                 method: str = "rk4", substeps: int = 1, controls: tuple[str, ...] = (),
                 want: torch.Tensor | None = None, dU: torch.Tensor | None = None, dth: torch.Tensor | None = None):
    """Outputs ``(batch, time, output_dim)`` and their derivatives ``(batch, time, output_dim, n)`` w.r.t. the
    n columns of the compiled loop's ``th``: the parameter values of the equations in the order of
    ``compiled(model)[0].param_keys``, then every network's weights (``weight_columns``) -- forward sensitivities
    of the compiled loop, one pass for all n where finite differences take n simulations. ``dstate0 (batch,
    state_dim, n)``: the initial state's derivatives. ``want (n,)`` booleans: the columns asked for (None: all);
    the loop carries no other through the states, and their derivatives are 0. Where the input ``U`` moves with
    some columns (a delay): ``dU`` (like ``U``) its derivative w.r.t. each row's delay, ``dth (batch, n)`` the
    delay's derivative w.r.t. each column; those columns then take the inputs' share. Not differentiable itself."""
    if int(substeps) < 1:
        raise ValueError(f"substeps must be >= 1, got {substeps}")
    eq, module = compiled(model, controls)
    B, T = U.shape[0], U.shape[1]
    c, A, bw = _tableau(method)
    th = _numpy(_theta(eq, P, model, B, U))
    h = (t[..., 1:] - t[..., :-1]).expand(B, -1)
    y = np.empty((B, T, model.output_dim))
    dy = np.empty((B, T, model.output_dim, th.shape[1]))
    asked = np.ones(th.shape[1]) if want is None else _numpy(want)
    module.tangent(_numpy(U), _numpy(h), th, _numpy(state0), _numpy(dstate0), asked, c, A, bw, int(substeps), y, dy,
                   dU=None if dU is None else _numpy(dU), dth=None if dth is None else _numpy(dth))
    return (torch.from_numpy(y).to(dtype=U.dtype, device=U.device),
            torch.from_numpy(dy).to(dtype=U.dtype, device=U.device))


def weight_columns(model, controls: tuple[str, ...] = ()) -> list[tuple[str, list[torch.Tensor]]]:
    """Where each network's weights sit among ``tangent_fast``'s columns: per network ``(effect key, [weight,
    bias, weight, bias, ...])``, the tensors in the order their flattened values follow the parameter values."""
    eq, _ = compiled(model, controls)
    return [(net.key, [t for lin in model.effects[net.key].net.layers() for t in (lin.weight, lin.bias)])
            for net in eq.networks]
