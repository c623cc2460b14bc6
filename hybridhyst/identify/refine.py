"""Gradient refinement of several starting points at once: Adam, then L-BFGS, restarts as batch rows.

Each restart is its own batch row with its own parameter values (``simulate(values=...)``), so K
restarts cost one batched simulation per step. Bounds are respected without clamping: each row optimises
an unconstrained logit ``w`` with ``x = from_unit(sigmoid(w))`` inside the search box (log scale where the
box is), so the gradient never vanishes at an artificial clamp. Rows are independent problems; the
optimisers see their summed cost and each row keeps the best point it has visited.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import torch

from ..optim import marquardt_system
from ..progress import progress as progress_bar
from .space import Box

__all__ = ["RefineResult", "levenberg_marquardt", "refine"]

STALL_DAMPING = 1e6  # levenberg_marquardt(rtol > 0): a row damped this much (from 1e-3) only refuses steps
_EDGE = 1e-6  # start points are moved this far (unit-cube) inside the box, where the logit is finite


@dataclass
class RefineResult:
    """Outcome of ``refine``: best point ``x (D,)`` and cost, every row's best ``X (K, D)`` and ``costs (K,)``,
    the summed finite cost per step (``history``) and ``evaluations``: batched calls for ``refine``, simulated
    rows for ``levenberg_marquardt``."""

    x: torch.Tensor
    cost: float
    X: torch.Tensor
    costs: torch.Tensor
    history: list[float] = field(default_factory=list)
    evaluations: int = 0


class _Rows:
    """Evaluate all rows, keep each row's best logits, and return a finite total for the optimisers."""

    def __init__(self, loss_rows, box: Box, w: torch.Tensor):
        self.loss_rows, self.box, self.w = loss_rows, box, w
        self.best_w = w.detach().clone()
        self.best = torch.full((w.shape[0],), math.inf, dtype=torch.float64)
        self.evaluations = 0
        self.penalty = None

    def __call__(self) -> torch.Tensor:
        self.evaluations += 1
        costs = self.loss_rows(self.box.from_unit(torch.sigmoid(self.w)))
        c = costs.detach().to(torch.float64)
        finite = torch.isfinite(c)
        improved = finite & (c < self.best)
        self.best = torch.where(improved, c, self.best)
        self.best_w[improved] = self.w.detach()[improved]
        if self.penalty is None:
            self.penalty = 1e3 * (float(c[finite].abs().max()) + 1.0) if bool(finite.any()) else 1e30
        # a diverged row adds a large constant (no gradient) so that a line search backs off
        return torch.where(finite, costs, torch.full_like(costs, self.penalty)).sum()

    def backward(self, total: torch.Tensor) -> None:
        if total.requires_grad:
            total.backward()
        if self.w.grad is not None:
            self.w.grad.nan_to_num_(nan=0.0, posinf=0.0, neginf=0.0)


def _reached(rows: _Rows, target: float | None) -> bool:
    return target is not None and float(rows.best.min()) <= target


def _adam(rows: _Rows, steps: int, lr: float, history: list[float], bar, target: float | None) -> None:
    opt = torch.optim.Adam([rows.w], lr=lr)
    for _ in range(steps):
        if _reached(rows, target):
            return
        opt.zero_grad()
        total = rows()
        rows.backward(total)
        opt.step()
        history.append(float(total.detach()))
        bar.update(1)
        bar.set_postfix(cost=f"{float(rows.best.min()):.4g}")


def _lbfgs(rows: _Rows, iters: int, history: list[float], bar, target: float | None) -> None:
    opt = torch.optim.LBFGS([rows.w], lr=1.0, max_iter=1, max_eval=12, history_size=20,
                            line_search_fn="strong_wolfe", tolerance_grad=0.0, tolerance_change=0.0)

    def closure():
        opt.zero_grad()
        total = rows()
        rows.backward(total)
        return total

    for _ in range(iters):
        if _reached(rows, target):
            return
        total = float(opt.step(closure).detach())
        history.append(total)
        bar.update(1)
        bar.set_postfix(cost=f"{float(rows.best.min()):.4g}")
        if len(history) > 2 and abs(history[-2] - total) <= 1e-12 * max(abs(total), 1e-300):
            break


def refine(loss_rows: Callable[[torch.Tensor], torch.Tensor], space: Box, starts: torch.Tensor, *,
           adam_steps: int = 40, lbfgs_steps: int = 60, lr: float = 0.05, target: float | None = None,
           progress: bool = True) -> RefineResult:
    """Refine ``K`` starting points in one batch: Adam then L-BFGS, each row within the search box.

    Parameters
    ----------
    loss_rows : ``X (K, D) -> (K,)`` differentiable costs, one per row (e.g. the MSE of each restart).
    space : the search box (``SearchSpace`` or ``Box``).
    starts : ``(K, D)`` starting coordinates (e.g. the best K members of a global search).
    adam_steps, lbfgs_steps : iterations of each optimiser (0 skips it); lr : Adam step in logit units.
    target : stop as soon as one row's cost is at most this.

    Returns
    -------
    RefineResult; ``x`` is the best point any row visited.
    """
    starts = torch.as_tensor(starts, dtype=torch.float64).reshape(-1, space.dim)
    unit = space.to_unit(starts).clamp(_EDGE, 1 - _EDGE)
    w = torch.logit(unit).clone().requires_grad_(True)
    rows = _Rows(loss_rows, space, w)
    history: list[float] = []
    with progress_bar(total=adam_steps + lbfgs_steps, desc="refine", enabled=progress) as bar:
        if adam_steps:
            _adam(rows, int(adam_steps), lr, history, bar, target)
        if lbfgs_steps:
            _lbfgs(rows, int(lbfgs_steps), history, bar, target)
        with torch.no_grad():
            rows()  # score the last iterate too
    X = space.from_unit(torch.sigmoid(rows.best_w)).detach()
    i = int(torch.argmin(rows.best))
    return RefineResult(x=X[i], cost=float(rows.best[i]), X=X, costs=rows.best.clone(), history=history,
                        evaluations=rows.evaluations)


def _lm_residuals(residual_rows, space: Box, W: torch.Tensor) -> torch.Tensor:
    with torch.no_grad():
        return residual_rows(space.from_unit(torch.sigmoid(W))).to(torch.float64)


def _lm_jacobian(residual_rows, space: Box, W: torch.Tensor, r0: torch.Tensor, h: float,
                 free: torch.Tensor) -> torch.Tensor:
    """Forward-difference Jacobians ``(K, M, F)`` w.r.t. the ``free`` logits (F of D) at W ``(K, D)``
    (residuals r0 known)."""
    K, D = W.shape
    E = torch.eye(D, dtype=W.dtype)[free]
    Wall = (W[:, None, :] + E[None] * h).reshape(K * E.shape[0], D)
    R = _lm_residuals(residual_rows, space, Wall).reshape(K, E.shape[0], -1)
    return (R - r0[:, None]).transpose(1, 2) / h


def _lm_exact(jacobian_rows, space: Box, W: torch.Tensor, free: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Residuals ``(K, M)`` and Jacobians ``(K, M, F)`` w.r.t. the ``free`` logits from ``jacobian_rows``
    (Jacobians w.r.t. the coordinates), chained through the box's map from logits (one coordinate each)."""
    X, dX = space.from_logits(W.detach())
    r, J = jacobian_rows(X, free)
    return r, J * dX[:, free][:, None, :]


def _lm_exact_or_fd(jacobian_rows, residual_rows, space: Box, W: torch.Tensor, free: torch.Tensor,
                    h: float) -> tuple[torch.Tensor, torch.Tensor, int]:
    """``_lm_exact``, with forward differences for the rows whose exact Jacobian is not finite where their
    residuals are (a sensitivity that overflows where the response does not), so that such a row still moves
    instead of getting zero steps. Also returns how many rows took differences."""
    r, J = _lm_exact(jacobian_rows, space, W, free)
    bad = ~_finite_rows(J) & _finite_rows(r)
    if bool(bad.any()):
        J[bad] = _lm_jacobian(residual_rows, space, W[bad], r[bad], h, free)
    return r, J, int(bad.sum())


def _finite_rows(a: torch.Tensor) -> torch.Tensor:
    """Whether each row (first axis) of ``a`` is finite everywhere: a finite row sum says so for most rows at the
    cost of one pass (a NaN or inf makes it non-finite); only the others are checked element by element (a sum
    of finite values can overflow)."""
    if a.ndim < 2:
        return torch.isfinite(a)
    ok = torch.isfinite(a.sum(dim=tuple(range(1, a.ndim))))
    if not bool(ok.all()):
        rows = ~ok
        ok[rows] = torch.isfinite(a[rows]).flatten(1).all(dim=1)
    return ok


def _lm_step(J: torch.Tensor, r: torch.Tensor, lam: torch.Tensor) -> torch.Tensor:
    """Damped Gauss–Newton steps ``(K, D)``; a row whose residuals or Jacobian are not finite (a diverged
    simulation) or whose system is singular gets a zero step instead of stopping the batch."""
    K, _, D = J.shape
    bad = ~(_finite_rows(J) & _finite_rows(r))
    if bool(bad.any()):
        J = torch.where(bad[:, None, None], torch.zeros_like(J), J)
        r = torch.where(bad[:, None], torch.zeros_like(r), r)
    JtJ = J.transpose(1, 2) @ J
    g = (J.transpose(1, 2) @ r[..., None])[..., 0]
    eye = torch.eye(D, dtype=J.dtype).expand(K, D, D)
    A = torch.where(bad[:, None, None], eye, marquardt_system(JtJ, lam))
    step, info = torch.linalg.solve_ex(A, -g[..., None])
    step = step[..., 0]
    return torch.where(((info != 0) | bad)[:, None] | ~torch.isfinite(step), torch.zeros_like(step), step)


def levenberg_marquardt(residual_rows: Callable[[torch.Tensor], torch.Tensor], space: Box, starts: torch.Tensor, *,
                        iters: int = 30, h: float = 1e-6, target: float | None = None,
                        free: torch.Tensor | None = None, progress: bool = True,
                        jacobian_rows: Callable | None = None, rtol: float = 0.0) -> RefineResult:
    """Batched Levenberg–Marquardt on the box logits: each row its own damping, one call per iteration.

    ``residual_rows(X (K, D)) -> (K, M)`` residuals; the cost is their mean square. Gauss–Newton steps are
    robust in the ill-conditioned valleys of traded-off parameters (Bouc–Wen D, A, α, k) where first-order
    methods crawl. Jacobians come from ``jacobian_rows(X, free) -> (residuals, (K, M, F))`` where given
    (``RecordsProblem.jacobian_rows``: exact forward sensitivities; forward differences for a row whose exact
    Jacobian is not finite), else forward differences (F more rows per accepted row). ``evaluations`` counts
    simulated rows either way (a Jacobian pass as one).
    ``free`` : ``(D,)`` booleans, the coordinates that may move (default all); the others keep each row's
    start value (the discovery loop re-balances a fitted model against a new effect's start this way).
    ``rtol`` : a row is converged, and simulated no more, once a nearly undamped accepted step (damping ≤ 1)
    lowers its cost by less than ``rtol`` (relative), or once refusals have grown its damping to
    ``STALL_DAMPING``; the run ends when every row has. 0 (the default) keeps every row to the last
    iteration; the discovery loop's fits use 1e-6 (``discover.fitting.LM_RTOL``).
    """
    starts = torch.as_tensor(starts, dtype=torch.float64).reshape(-1, space.dim)
    W = torch.logit(space.to_unit(starts).clamp(_EDGE, 1 - _EDGE))
    K, D = W.shape
    free = torch.ones(D, dtype=torch.bool) if free is None else torch.as_tensor(free, dtype=torch.bool).reshape(D)
    if not bool(free.any()):
        raise ValueError("levenberg_marquardt: no free coordinate (free is all False)")
    F = int(free.sum())
    free_index = torch.nonzero(free).reshape(-1)
    lam = torch.full((K,), 1e-3, dtype=torch.float64)

    def jacobians(Wa: torch.Tensor, ra: torch.Tensor) -> tuple[torch.Tensor, int]:
        """The Jacobians at the rows ``Wa`` (residuals ``ra``) and the simulated rows they cost."""
        if jacobian_rows is None:
            return _lm_jacobian(residual_rows, space, Wa, ra, h, free), Wa.shape[0] * F
        _, Ja, differenced = _lm_exact_or_fd(jacobian_rows, residual_rows, space, Wa, free, h)
        return Ja, Wa.shape[0] + differenced * F

    if jacobian_rows is None:
        r = _lm_residuals(residual_rows, space, W)
        J = _lm_jacobian(residual_rows, space, W, r, h, free)
    else:
        r, J, differenced = _lm_exact_or_fd(jacobian_rows, residual_rows, space, W, free, h)
    cost = r.square().mean(dim=1).nan_to_num(nan=math.inf)
    active = torch.ones(K, dtype=torch.bool)  # rows not yet converged (see rtol)
    history, evals = [float(cost.min())], K * (F + 1 if jacobian_rows is None else 1)
    if jacobian_rows is not None:
        evals += differenced * F
    with progress_bar(total=iters, desc="levenberg-marquardt", enabled=progress) as bar:
        for _ in range(iters):
            if target is not None and float(cost.min()) <= target:
                break
            rows = torch.nonzero(active).reshape(-1)
            if rows.numel() == 0:
                break
            every = rows.numel() == K  # no copies of the Jacobians while every row is active
            step = _lm_step(J if every else J[rows], r if every else r[rows], lam if every else lam[rows])
            if F < D:
                step = torch.zeros(rows.numel(), D, dtype=W.dtype).index_copy_(1, free_index, step)
            r_new = _lm_residuals(residual_rows, space, W[rows] + step)
            new = r_new.square().mean(dim=1).nan_to_num(nan=math.inf)
            ok = new < cost[rows]
            evals += rows.numel()
            gain = (cost[rows] - new) / cost[rows].clamp_min(1e-300)
            if bool(ok.all()) and rows.numel() == K:  # every row accepted: the new arrays replace the old ones
                W, r, cost = W + step, r_new, new
                J, n = jacobians(W, r)
                evals += n
            elif bool(ok.any()):  # Jacobians only where the step was accepted
                acc = rows[ok]
                W[acc] = W[acc] + step[ok]
                r[acc], cost[acc] = r_new[ok], new[ok]
                J[acc], n = jacobians(W[acc], r[acc])
                evals += n
            # converged rows: a negligible gain from a nearly undamped (Gauss–Newton) step, or a damping only
            # refusals reach
            small = ok & (gain < rtol) & (lam[rows] <= 1.0)
            lam[rows] = torch.where(ok, lam[rows] / 3, lam[rows] * 4).clamp(1e-12, 1e12)
            if rtol > 0:
                active[rows] = ~(small | (lam[rows] >= STALL_DAMPING))
            history.append(float(cost.min()))
            bar.update(1)
            bar.set_postfix(cost=f"{history[-1]:.4g}")
    X = space.from_unit(torch.sigmoid(W))
    i = int(torch.argmin(cost))
    return RefineResult(x=X[i], cost=float(cost[i]), X=X, costs=cost, history=history, evaluations=evals)
