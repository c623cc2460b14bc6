"""Gradient identification: fit a nominal model's parameters to records by differentiating ``simulate``.

Adam (with a learning rate scaled to each parameter's magnitude, so that a stiffness of 50 and a friction
level of 0.5 move by similar relative amounts) followed optionally by L-BFGS with a strong-Wolfe line
search. Records are decimated first: the fixed-step simulator runs one Python-level step per sample, so
the cost of a loss evaluation is proportional to the number of samples along the time axis.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import torch
from torch import nn

from ..data.decimate import decimate_all
from ..data.records import Record, RecordSet
from ..optim import line_search_loss
from ..physics.parameters import project_to_bounds
from ..progress import progress as progress_bar
from ..simulate import SimulationSettings, resolved_substeps, simulate
from ..simulate.api import REFERENCE

__all__ = ["FitResult", "fit_gradient", "record_loss"]

_LOSSES = ("mse", "mae")
_MAX_RETRIES = 6
TOLERANCE = 1e-9  # L-BFGS stops when one iteration changes the loss by at most this (relative)


@dataclass
class FitResult:
    """Outcome of ``fit_gradient``.

    Attributes
    ----------
    model : the fitted model (the same object that was passed in, now holding the best parameters).
    loss : best training loss reached (in the response unit squared for ``"mse"``).
    history : loss evaluated at every optimiser step (before its update), Adam first, then L-BFGS.
    steps : number of Adam steps and L-BFGS iterations taken, ``{"adam": n, "lbfgs": m}``.
    n_samples : number of (decimated) samples the loss was computed on.
    evaluations : number of simulations run (each one forward, most with a backward pass).
    wall_s : wall-clock time of the fit [s].
    substeps : sub-steps per sample the fit ended with (chosen by step doubling with ``resolve``).
    resolution : relative RMS change of the fitted model's response under halved steps at ``substeps``
        (``nan`` without ``resolve``; above ``simulate.api.RESOLVED`` where ``max_substeps`` did not resolve it).
    converged : whether L-BFGS stopped by itself: an iteration changed the loss by at most ``TOLERANCE``
        (relative), so it cannot lower it further from there (this includes a line search that finds no lower
        point, e.g. with a parameter held at a bound); None where no L-BFGS ran (Adam alone is not checked).
    stop : why L-BFGS stopped: "converged", "steps" (``lbfgs_steps`` reached) or "non-finite" (a step's loss was
        not finite; the best point is kept); None without L-BFGS.
    last_change : relative fall of the loss in the last optimiser step (L-BFGS iteration, else Adam step).
    """

    model: nn.Module
    loss: float
    history: list[float] = field(default_factory=list)
    steps: dict[str, int] = field(default_factory=dict)
    n_samples: int = 0
    evaluations: int = 0
    wall_s: float = 0.0
    substeps: int = 1
    resolution: float = math.nan
    converged: bool | None = None
    stop: str | None = None
    last_change: float = math.nan


def record_loss(predictions: Sequence[torch.Tensor], records: Sequence[Record], loss: str = "mse") -> torch.Tensor:
    """Pooled loss over every scored sample of every record (each record's ``warmup`` samples are simulated,
    not scored): mean of squared (``"mse"``) or absolute (``"mae"``) errors.

    ``predictions`` holds one ``(time, output_dim)`` tensor per record (as ``simulate`` returns for
    records); channel 0 is compared with the record's response ``y``.
    """
    if loss not in _LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {_LOSSES}")
    total, count = 0.0, 0
    for pred, r in zip(predictions, records):
        err = pred[r.warmup:, 0] - torch.tensor(r.y[r.warmup:], dtype=pred.dtype, device=pred.device)
        total = total + (err.square().sum() if loss == "mse" else err.abs().sum())
        count += len(r) - r.warmup
    return total / count


def _param_groups(model: nn.Module, lr: float) -> list[dict]:
    """One Adam group per parameter tensor, lr scaled by max(|raw value|, 1) (a relative step size)."""
    groups = []
    for p in model.parameters():
        if p.requires_grad:
            scale = max(float(p.detach().abs().mean()), 1.0)
            groups.append({"params": [p], "lr": lr * scale})
    if not groups:
        raise ValueError("the model has no trainable parameters; un-fix at least one parameter to fit it")
    return groups


class _Objective:
    """Loss of the model on the records, keeping the best parameters seen.

    Parameters are projected into their bounds before every evaluation, so the L-BFGS line search
    scores (and the best state keeps) only feasible points.
    """

    def __init__(self, model, records, loss, sim_kwargs):
        self.model, self.records, self.loss, self.sim_kwargs = model, records, loss, sim_kwargs
        self.best = math.inf
        self.evaluations = 0
        self.best_state = copy.deepcopy(model.state_dict())

    def __call__(self) -> torch.Tensor:
        project_to_bounds(self.model)
        self.evaluations += 1
        preds = simulate(self.model, self.records, **self.sim_kwargs)
        value = record_loss(preds, self.records, self.loss)
        v = float(value.detach())
        if math.isfinite(v) and v < self.best:
            self.best = v
            self.best_state = copy.deepcopy(self.model.state_dict())
        return value

    def restore(self) -> None:
        self.model.load_state_dict(self.best_state)


def _run_adam(obj: _Objective, steps: int, lr: float, progress: bool, history: list[float]) -> int:
    opt = torch.optim.Adam(_param_groups(obj.model, lr))
    failures, done = 0, 0
    with progress_bar(total=steps, desc="adam", enabled=progress) as bar:
        while done < steps:
            opt.zero_grad()
            value = obj()
            if not torch.isfinite(value):
                # a diverged explicit step (too stiff for the sample interval): back off
                failures += 1
                if failures > _MAX_RETRIES:
                    raise ValueError(
                        "simulation diverged during fitting (non-finite loss); lower the learning rate, "
                        "decimate less or add sub-steps"
                    )
                obj.restore()
                for g in opt.param_groups:
                    g["lr"] *= 0.5
                continue
            value.backward()
            opt.step()
            project_to_bounds(obj.model)
            done += 1
            history.append(float(value.detach()))
            bar.update(1)
            bar.set_postfix(loss=f"{history[-1]:.4g}")
    return done


def _run_lbfgs(obj: _Objective, iters: int, progress: bool, history: list[float]) -> tuple[int, str]:
    """L-BFGS iterations (at most ``iters``): (iterations taken, why it stopped: "converged", "steps" or
    "non-finite")."""
    params = [p for p in obj.model.parameters() if p.requires_grad]
    # max_iter=1 per call (one progress tick per iteration); max_eval leaves room for the line search
    opt = torch.optim.LBFGS(params, lr=1.0, max_iter=1, max_eval=11, history_size=20, line_search_fn="strong_wolfe")

    # the search minimises the loss relative to its first value: torch's tolerances on the gradient and on the
    # change of the loss are absolute, and a response in metres (a mean squared error of 1e-10) would stop it
    # at its start
    scale = []

    def closure():
        opt.zero_grad()
        value = obj()
        if not scale:
            v = float(value.detach())
            scale.append(1.0 / v if math.isfinite(v) and v > 0 else 1.0)
        value = value * scale[0]
        if torch.isfinite(value):
            value.backward()
        return line_search_loss(value, obj.best * scale[0])

    done, stop, first = 0, "steps", len(history)
    with progress_bar(total=iters, desc="lbfgs", enabled=progress) as bar:
        for _ in range(iters):
            value = opt.step(closure)  # the loss where this iteration started
            project_to_bounds(obj.model)
            done += 1
            if not torch.isfinite(value):
                stop = "non-finite"
                break
            history.append(float(value.detach()) / scale[0])
            bar.update(1)
            bar.set_postfix(loss=f"{history[-1]:.4g}")
            mine = history[first:]  # L-BFGS's own values (not Adam's last)
            if len(mine) > 1 and abs(mine[-2] - mine[-1]) <= TOLERANCE * max(abs(mine[-1]), 1e-12):
                stop = "converged"
                break
    return done, stop


def fit_gradient(model: nn.Module, records: Record | RecordSet | Sequence[Record], *, steps: int = 100,
                 lr: float = 0.05, downsample: int | Mapping[str, int] = 1, loss: str = "mse",
                 lbfgs_steps: int = 0, progress: bool = True, simulation: SimulationSettings | None = None,
                 input_channels: tuple[str, ...] = ("x",), resolve: bool = False, max_substeps: int = 16,
                 **overrides) -> FitResult:
    """Fit every trainable parameter of ``model`` to ``records`` by gradient descent through ``simulate``.

    Parameters
    ----------
    model : a nominal model (``Constitutive`` or ``DrivenOscillator``); fitted in place.
    records : the training records; the model is driven by ``input_channels`` and compared with ``y``.
    steps : Adam steps (learning rate ``lr`` times max(|raw parameter|, 1) per parameter tensor).
    lr : relative Adam learning rate.
    downsample : keep every ``downsample``-th sample, or a {record name: factor} mapping (records not
        named keep every sample). Stiff hysteretic states need enough samples per loop for the explicit
        scheme to stay stable; a diverging simulation is retried from the best parameters with half the
        learning rate.
    loss : ``"mse"`` or ``"mae"``, pooled over all samples.
    lbfgs_steps : L-BFGS iterations after Adam (strong-Wolfe line search; 0 to skip).
    progress : show tqdm progress bars.
    simulation : how the model is simulated (``SimulationSettings``; default the reference backend, RK4, one
        sub-step); ``overrides`` (method, substeps, backend) are laid over it.
    resolve : choose the sub-steps per sample by step doubling (``simulate.resolved_substeps``, from
        ``simulation.substeps`` up to ``max_substeps``) before fitting, and again after it: a fitted model that
        needs finer steps than it was fitted with (its loops got sharper) is fitted on from there at the finer
        step.

    Returns
    -------
    FitResult with the model holding the parameters of the lowest loss seen.
    """
    if loss not in _LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {_LOSSES}")
    if steps < 0 or lbfgs_steps < 0 or (steps == 0 and lbfgs_steps == 0):
        raise ValueError(f"give a positive number of Adam steps or L-BFGS steps (got steps={steps}, "
                         f"lbfgs_steps={lbfgs_steps})")
    if isinstance(records, Record):
        records = [records]
    records = list(records)
    if not records:
        raise ValueError("fit_gradient got no records; check the data selection")
    start = time.perf_counter()
    data = decimate_all(records, downsample, "gradient fitting")
    sim = SimulationSettings.of(simulation, REFERENCE, **overrides)
    channels = tuple(input_channels)

    def resolved(at: int, refit=None) -> tuple[int, float]:
        return resolved_substeps(model, data, settings=sim, substeps=at, max_substeps=max_substeps, refit=refit,
                                 input_channels=channels)

    history: list[float] = []
    done = {"adam": 0, "lbfgs": 0, "evaluations": 0, "stop": None, "best": math.inf}

    def fit_at(s: int) -> None:  # Adam then L-BFGS at s sub-steps per sample, from the model's current values
        obj = _Objective(model, data, loss, {"settings": sim.at(s), "input_channels": channels})
        done["adam"] += _run_adam(obj, steps, lr, progress, history) if steps else 0
        if lbfgs_steps:
            n, done["stop"] = _run_lbfgs(obj, lbfgs_steps, progress, history)
            done["lbfgs"] += n
        with torch.no_grad():
            obj()  # score the final parameters too, so the best state covers the last step
        obj.restore()
        done["evaluations"] += obj.evaluations
        done["best"] = obj.best

    substeps, resolution = resolved(sim.substeps) if resolve else (sim.substeps, math.nan)
    fit_at(substeps)
    if resolve:  # a fitted model that needs finer steps than it was fitted with is fitted on at the finer step
        substeps, resolution = resolved(substeps, refit=fit_at)
    last_change = (history[-2] - history[-1]) / abs(history[-2]) if len(history) > 1 and history[-2] else math.nan
    stop = done["stop"]
    return FitResult(model=model, loss=done["best"], history=history,
                     steps={"adam": done["adam"], "lbfgs": done["lbfgs"]},
                     n_samples=sum(len(r) - r.warmup for r in data),
                     evaluations=done["evaluations"], wall_s=time.perf_counter() - start, substeps=substeps,
                     resolution=resolution, converged=None if stop is None else stop == "converged", stop=stop,
                     last_change=last_change)
