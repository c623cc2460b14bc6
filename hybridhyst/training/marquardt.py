"""The Levenberg–Marquardt stage of training (``trainer.lm``): after the Adam epochs, damped Gauss–Newton steps
on the simulation error of every whole training record, from rest, as validation and test score it.

Each step needs the Jacobian of every simulated sample w.r.t. every trainable coordinate: the nominal's raw
parameters (through the values they give, ``Model.evaluate``) and the weights of a network inside the dynamics.
The compiled loop gives it in one forward pass (``simulate.simulate_jacobian(weights=True)``: forward
sensitivities, exact for the discrete map); only ``JᵀJ`` and ``Jᵀr`` are kept, record by record, so memory
does not grow with the number of records. The step solves Marquardt's damped normal equations
(``optim.marquardt_step``, shared with identification's Levenberg–Marquardt); a step that does not lower the
cost is refused and the damping raised, an accepted one lowers it.

Why a second-order stage: the in-the-loop hybrid's Adam epochs flatten out while the network is still
under-fitted, and quasi-Newton steps (``trainer.lbfgs``) keep lowering the error slowly
(experiments/boucwen_baselines). A network of a few thousand weights is small enough for Gauss–Newton, which
uses the least-squares structure of the loss that L-BFGS does not.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..optim import marquardt_step
from ..physics.parameters import project_to_bounds
from ..simulate import simulate_jacobian
from ..simulate.fast.function import weight_columns

__all__ = ["MarquardtStage", "StageStep", "check_module"]

TRIES = 10  # refused steps (each raising the damping 4×) before an iteration gives up


def check_module(module) -> None:
    """Refuse, with every reason at once, a module the stage cannot train (called before the Adam epochs too, so a
    run with settings it cannot honour stops at once): a model that is simulated (``nominal``), a squared loss,
    no physics or prior term, a network inside the dynamics rather than at the output."""
    if getattr(module, "nominal", None) is None:
        raise ValueError(f"trainer.lm trains a simulated model (module=physics or hybrid), not module={module.kind}")
    reasons = []
    if module.loss_kind != "mse":
        reasons.append(f"loss.kind={module.loss_kind} (Levenberg-Marquardt minimises squares: use mse)")
    if module.lambda_phys > 0:
        reasons.append("loss.lambda_phys > 0 (the stage minimises the data misfit alone: set it to 0)")
    if getattr(module, "prior_weight", 0.0):
        reasons.append("loss.prior_weight > 0 (the stage minimises the data misfit alone: set it to 0)")
    if getattr(module, "placement", "dynamics") != "dynamics":
        reasons.append("placement=output (the branch is outside the simulation; use trainer.lbfgs)")
    if reasons:
        raise ValueError("trainer.lm cannot train this run: " + "; ".join(reasons))


class MarquardtStage:
    """Levenberg–Marquardt over a module's nominal parameters and dynamics network (``use_lm``).

    ``damping``: the starting λ of ``JᵀJ + λ diag(JᵀJ)``; divided by 3 after an accepted step, multiplied by 4
    after a refused one.
    """

    def __init__(self, module, damping: float = 1e-3):
        if float(damping) <= 0:
            raise ValueError(f"trainer.lm.damping must be > 0, got {damping}")
        check_module(module)
        self.damping = float(damping)
        self.raw = [p for p in module.nominal.parameters() if p.requires_grad]
        self.weights = [w for _, ws in weight_columns(module.model, tuple(module.control_names)) for w in ws]
        if not self.raw and not self.weights:
            raise ValueError("trainer.lm: nothing to train (the nominal is frozen and no network is inside the "
                             "dynamics)")

    # -- coordinates -------------------------------------------------------------------------------
    def coordinates(self) -> torch.Tensor:
        return torch.cat([p.detach().reshape(-1) for p in (*self.raw, *self.weights)])

    def assign(self, x: torch.Tensor) -> None:
        at = 0
        with torch.no_grad():
            for p in (*self.raw, *self.weights):
                p.copy_(x[at: at + p.numel()].reshape(p.shape))
                at += p.numel()

    # -- residuals ---------------------------------------------------------------------------------
    def _scale(self, module) -> float:
        return module.y_scale if module.normalise_loss else 1.0

    def cost(self, module, records) -> float:
        """The stage's cost: the mean square of the scaled simulation error over every scored sample (inf where a
        simulation diverges)."""
        sse, n, scale = 0.0, 0.0, self._scale(module)
        with torch.no_grad():
            for batch in records:
                y = module.simulate_nominal(batch, model=module.model)
                m = batch["mask"].to(y)
                sse += float((((y - batch["y"].to(y)) / scale).square() * m).sum())
                n += float(m.sum())
        return sse / max(n, 1.0) if math.isfinite(sse) else math.inf

    def normal_equations(self, module, records) -> tuple[torch.Tensor, torch.Tensor, float]:
        """``JᵀJ``, ``Jᵀr`` (over the coordinates) and the cost, accumulated record by record."""
        model, scale = module.model, self._scale(module)
        R = sum(p.numel() for p in self.raw)
        n_coord = R + sum(w.numel() for w in self.weights)
        JtJ = np.zeros((n_coord, n_coord))
        Jtr = np.zeros(n_coord)
        sse, n = 0.0, 0.0
        for batch in records:
            U, t = module.sim_inputs(batch)
            cond = module.conditions(batch)
            B = U.shape[0]
            with torch.enable_grad():
                P = model.evaluate(cond, B)
            values = {k: {name: v.detach() for name, v in d.items()} for k, d in P.items()}
            y, dy, keys = simulate_jacobian(model, U, t, values=values, conditions=cond,
                                            initial_state=module._initial_state(batch), settings=module.sim,
                                            weights=True)
            dV = _value_jacobian(P, keys, self.raw, B)  # (B, K, R)
            w = (batch["mask"].to(y) / scale)[..., None]  # (B, T, 1): the scored samples, scaled
            r = (y[..., 0] - batch["y"].to(y))[..., None] * w
            J = torch.cat([torch.einsum("btk,bkr->btr", dy[..., 0, : len(keys)], dV), dy[..., 0, len(keys):]],
                          dim=-1).mul_(w).reshape(-1, n_coord).cpu().numpy()
            JtJ += J.T @ J  # numpy's BLAS, threaded as the compiled loops are (torch keeps the run's threads)
            Jtr += J.T @ r.reshape(-1).cpu().numpy()
            sse += float(r.square().sum())
            n += float(batch["mask"].sum())
        cost = sse / max(n, 1.0) if math.isfinite(sse) else math.inf
        return torch.from_numpy(JtJ), torch.from_numpy(Jtr), cost  # (on the host, as the compiled loops run)

    # -- one iteration -----------------------------------------------------------------------------
    def step(self, module, records) -> dict:
        """One Levenberg–Marquardt iteration in place: ``{"cost", "start_cost", "tries", "damping", "accepted"}``."""
        JtJ, Jtr, cost = self.normal_equations(module, records)
        if not math.isfinite(cost) or not bool(torch.isfinite(JtJ).all()):
            raise FloatingPointError("trainer.lm: the simulation or its Jacobian is not finite where the step starts "
                                     "(a diverging model)")
        x = self.coordinates()
        for tries in range(1, TRIES + 1):
            step = marquardt_step(JtJ, Jtr, self.damping).to(x)
            self.assign(x + step)
            project_to_bounds(module.nominal)  # an amplitude stored unconstrained stays in its domain: the cost
            # judged is the one of the values the step leaves
            new = self.cost(module, records) if bool(torch.isfinite(step).all()) else math.inf
            if new < cost:
                self.damping = max(self.damping / 3.0, 1e-12)
                return {"cost": new, "start_cost": cost, "tries": tries, "damping": self.damping, "accepted": True}
            self.damping = min(self.damping * 4.0, 1e12)
        self.assign(x)
        return {"cost": cost, "start_cost": cost, "tries": TRIES, "damping": self.damping, "accepted": False}


class StageStep(torch.optim.Optimizer):
    """The optimiser Lightning is given in the stage: its step runs the closure (one ``MarquardtStage.step``).
    Lightning counts optimiser steps (``global_step``) and checkpoints only after a step it counted, so the
    stage steps through it."""

    def __init__(self, params):
        super().__init__(list(params), {})

    def step(self, closure):  # noqa: D102 - the closure is the whole step
        return closure()


def _value_jacobian(P: dict, keys: list, raw: list, B: int) -> torch.Tensor:
    """``(B, K, R)``: the derivative of each row's parameter value ``keys[k]`` w.r.t. the R raw coordinates
    (the parameters' flattened elements) that ``P`` was evaluated from."""
    R = sum(p.numel() for p in raw)
    out = torch.zeros(B, len(keys), R, dtype=torch.float64)
    if not R:
        return out
    for k, (e, name) in enumerate(keys):
        v = P[e][name]
        if not v.requires_grad:
            continue
        v = v.expand(B)
        for b in range(B):
            grads = torch.autograd.grad(v[b], raw, retain_graph=True, allow_unused=True)
            out[b, k] = torch.cat([torch.zeros(p.numel(), dtype=torch.float64) if g is None else
                                   g.reshape(-1).to(torch.float64) for g, p in zip(grads, raw)])
    return out
