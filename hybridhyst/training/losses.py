"""Losses: data misfit, the nominal governing equation's residual (physics), and a parameter prior.

Physics residual
----------------
A nominal model is ``ṡ = f(s, u, u̇, ü; θ)`` with output ``y = g(s, u, u̇, ü; θ)`` (``model.derivative``
and ``model.output``). A prediction is substituted into these equations at collocation points (the
training samples) and the time derivatives of the predicted trajectory are taken by autograd. Each
collocation point carries a time offset τ (a zero-valued leaf tensor) and the inputs around it are their
third-order Taylor expansion ``u(τ) = u + u̇ τ + ü τ²/2 + u⃛ τ³/6``, ``u̇(τ) = u̇ + ü τ + u⃛ τ²/2``,
``ü(τ) = ü + u⃛ τ``, so the first and second ``d/dτ`` of a network output at τ = 0 are its total time
derivatives along the measured excitation (the jerk u⃛ is needed for the second: the network sees u̇).

- Standard PINN: the network predicts the output and every state; the residual is ``(dŝ/dτ − f, ŷ − g)``.
- Hybrid (nominal + residual branch): the nominal's own states satisfy its equations, so what is
  substituted is the corrected trajectory. For a ``Constitutive`` model (output = force law) the
  residual is ``ŷ − g(s_nom)``, i.e. the branch's correction; for a ``DrivenOscillator`` whose output is
  the position, the predicted position x̂ and its autograd derivatives replace the nominal's (x, ẋ) and
  the residual is the equation of motion ``d²x̂/dτ² − f_v(x̂, dx̂/dτ, z_nom)`` (seed 003, Eqs. (16)–(17)).
  For a constitutive nominal the residual therefore equals the branch's correction: λ_phys is then a
  penalty on the correction's size (how far the prediction may leave the nominal law).

In the hybrid the nominal's parameters and states enter the physics residual as constants (detached):
λ_phys acts on the branch, not on the nominal (which the data loss trains when it is not frozen). In the
standard PINN the residual is the only link to the nominal, so its parameters stay trainable there (an
inverse PINN, unless frozen).

Residuals are divided by the training scale of the quantity (output sd, or state-rate scale) so that
``λ_phys`` weighs comparable numbers (``w_data = 1``, seed 003).
"""

from __future__ import annotations

import torch

from ..physics.models import Constitutive, DrivenOscillator, InputSample

__all__ = ["constant_values", "data_loss", "hybrid_physics_residual", "parameter_prior", "pinn_physics_residual",
           "taylor_inputs"]


def data_loss(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor, scale: float, kind: str = "mse"):
    """Masked mean misfit of ``pred`` vs ``target`` (both ``(batch, time)``) in units of ``scale``."""
    err = (pred - target) / scale
    w = mask / mask.sum().clamp_min(1.0)
    if kind == "mse":
        return (w * err.square()).sum()
    if kind == "mae":
        return (w * err.abs()).sum()
    raise ValueError(f"unknown data loss {kind!r}; choose 'mse' or 'mae'")


def constant_values(model: torch.nn.Module) -> dict[str, torch.Tensor]:
    """The physical values of the nominal's trainable constant parameters, ``{module path: value}``."""
    from ..physics.parameters import Constant

    return {name: m.value for name, m in model.named_modules()
            if isinstance(m, Constant) and any(p.requires_grad for p in m.parameters())}


def parameter_prior(model: torch.nn.Module, initial: dict[str, torch.Tensor], weight: float, kind: str = "l1"):
    """``weight · Σ |p − p_init|`` (``kind="l1"``, seed 000) or squared, over the physical values of the
    nominal's constant parameters (``initial`` from ``constant_values`` at the start)."""
    if not weight:
        return torch.zeros(())
    total = 0.0
    for name, value in constant_values(model).items():
        if name in initial:
            d = value - initial[name].to(value)
            total = total + (d.abs().sum() if kind == "l1" else d.square().sum())
    return weight * total


def taylor_inputs(u, du, ddu, tau, dddu=None) -> InputSample:
    """The inputs at offset ``tau`` from each collocation point (third-order Taylor expansion; the jerk
    ``dddu`` defaults to 0)."""
    j = torch.zeros_like(u) if dddu is None else dddu
    t2, t3 = tau.square(), tau.square() * tau
    return InputSample(u=u + du * tau + 0.5 * ddu * t2 + j * t3 / 6.0, du=du + ddu * tau + 0.5 * j * t2,
                       ddu=ddu + j * tau)


def d_dtau(y: torch.Tensor, tau: torch.Tensor) -> torch.Tensor:
    """Derivative of each entry of ``y`` (N,) w.r.t. its own ``tau`` entry, keeping the graph."""
    (g,) = torch.autograd.grad(y.sum(), tau, create_graph=True)
    return g


def pinn_physics_residual(model, P, states: torch.Tensor, y: torch.Tensor, inp: InputSample, tau: torch.Tensor,
                          state_rate_scale: torch.Tensor, y_scale: float) -> torch.Tensor:
    """Mean squared scaled residual of predicted states ``(N, S)`` and output ``y (N,)`` (standard PINN)."""
    terms = []
    if states.shape[1]:
        rate = model.derivative(states, inp, P)
        ds = torch.stack([d_dtau(states[:, i], tau) for i in range(states.shape[1])], dim=1)
        terms.append(((ds - rate) / state_rate_scale).square().mean())
    g = model.output(states, inp, P)[:, 0]
    terms.append(((y - g) / y_scale).square().mean())
    return sum(terms)


def hybrid_physics_residual(model, P, nominal_states: torch.Tensor, y: torch.Tensor, inp: InputSample,
                            tau: torch.Tensor, y_scale: float, accel_scale: float) -> torch.Tensor:
    """Mean squared scaled residual of the hybrid's predicted output ``y (N,)`` (a function of ``tau``) in
    the nominal's governing equation, with the nominal's states ``(N, S)`` for everything else."""
    if isinstance(model, DrivenOscillator) and model.outputs[0] == "x":
        v = d_dtau(y, tau)
        a = d_dtau(v, tau)
        s = torch.cat([y[:, None], v[:, None], nominal_states[:, 2:]], dim=1)
        f_v = model.derivative(s, inp, P)[:, 1]
        return ((a - f_v) / accel_scale).square().mean()
    if isinstance(model, (Constitutive, DrivenOscillator)):
        g = model.output(nominal_states, inp, P)[:, 0]
        return ((y - g) / y_scale).square().mean()
    raise ValueError(f"no governing-equation residual for a {type(model).__name__}")
