"""Identifiability at an optimum: Gauss–Newton Hessian, its eigen-analysis and parameter uncertainty.

With residuals r(θ) of M samples and noise standard deviation σ, the Fisher information (the
Gauss–Newton Hessian of the negative log-likelihood) is H = Jᵀ J / σ², J = ∂ŷ/∂θ (M × D). Positive
coordinates are analysed in log space (θ = log x, so ∂ŷ/∂log x = x ∂ŷ/∂x): an eigenvector v with a large
eigenvalue is an identifiable combination Π x_i^(v_i) (e.g. α·k), one with an eigenvalue near zero a
direction the data cannot see (raw Bouc–Wen D, A, α, k trade off; docs/units.md). Standard
deviations come from the pseudo-inverse of H.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import torch

__all__ = ["FisherReport", "fisher_analysis", "output_jacobian"]


@dataclass
class FisherReport:
    """Eigen-analysis of the Fisher information at an optimum.

    Attributes
    ----------
    names : coordinate names; scale : ``"log"`` or ``"linear"`` per coordinate.
    eigenvalues : ``(D,)`` descending; eigenvectors : ``(D, D)``, column i belongs to eigenvalue i.
    sd : standard deviation of each coordinate (absolute, in its unit); rel_sd : sd / |value|.
    combinations : one entry per eigenvector, best determined first: ``{"expression", "weights",
        "eigenvalue", "sd", "identifiable"}`` (``sd`` of the combination in its scale).
    non_identifiable : coordinates with a large weight in a non-identifiable direction.
    sigma : noise standard deviation used.
    """

    names: list[str]
    scale: list[str]
    eigenvalues: torch.Tensor
    eigenvectors: torch.Tensor
    sd: dict[str, float]
    rel_sd: dict[str, float]
    combinations: list[dict] = field(default_factory=list)
    non_identifiable: list[str] = field(default_factory=list)
    sigma: float = 1.0

    @property
    def identifiable(self) -> list[str]:
        """Expressions of the identifiable combinations."""
        return [c["expression"] for c in self.combinations if c["identifiable"]]


def output_jacobian(predict: Callable[[torch.Tensor], torch.Tensor], x: torch.Tensor, method: str = "autograd",
                    chunk: int = 512, rel_step: float = 1e-6) -> torch.Tensor:
    """J = ∂ŷ/∂x, ``(M, D)``, of ``predict(X (N, D)) -> (N, M)`` at ``x (D,)``.

    ``"autograd"``: reverse mode through the simulator, with batch row i selecting output i (``chunk`` rows
    per call, so M outputs cost M simulated rows forward and backward). ``"fd"``: central differences,
    one batched call with 2 D + 1 rows (step ``h = rel_step · max(|x|, 1e-3)``). Where one side of a
    difference is not finite and the other and ``x`` itself are (``x`` on the edge of a parameter's domain, e.g.
    a trend that reaches 0 at one record's condition: ``SearchSpace.values`` gives NaN just outside), that
    element takes the one-sided difference on the finite side (first order, error O(h)); where both sides, or one
    side and ``x`` itself, are not finite it stays NaN, so a diverged simulation is still caught
    (``fisher_analysis``).
    """
    x = torch.as_tensor(x, dtype=torch.float64).detach()
    D = x.shape[0]
    if method == "fd":
        h = rel_step * x.abs().clamp_min(1e-3)
        E = torch.diag(h)
        with torch.no_grad():
            Y = predict(torch.cat([x[None], x + E, x - E]))
        y0, up, down, h = Y[:1], Y[1:D + 1], Y[D + 1:], h[:, None]
        ok_up, ok_down = torch.isfinite(up), torch.isfinite(down)
        J = torch.where(ok_up & ok_down, (up - down) / (2 * h),
                        torch.where(ok_up, (up - y0) / h, torch.where(ok_down, (y0 - down) / h, math.nan)))
        return J.T
    if method != "autograd":
        raise ValueError(f"unknown jacobian method {method!r}; choose 'autograd' or 'fd'")
    with torch.no_grad():
        M = predict(x[None]).shape[1]
    rows = []
    for start in range(0, M, chunk):
        n = min(chunk, M - start)
        X = x.expand(n, D).clone().requires_grad_(True)
        Y = predict(X)
        sel = Y[torch.arange(n), start + torch.arange(n)]
        (g,) = torch.autograd.grad(sel.sum(), X)
        rows.append(g)
    return torch.cat(rows)


def _expression(names: Sequence[str], v: torch.Tensor, log: torch.Tensor, keep: float = 0.1) -> tuple[str, dict]:
    """Name an eigenvector: Π x_i^w_i over log coordinates, Σ w_i·x_i over linear ones (largest weight 1)."""
    v = v / v[v.abs().argmax()]
    weights = {n: float(w) for n, w in zip(names, v) if abs(float(w)) >= keep}
    prod = [f"{n}^{w:.2g}" if abs(w - 1) > 1e-3 else n for n, w in weights.items() if log[names.index(n)]]
    lin = [f"{w:+.2g}·{n}" for n, w in weights.items() if not log[names.index(n)]]
    parts = [" · ".join(prod)] if prod else []
    parts += [" ".join(lin)] if lin else []
    return " ; ".join(parts), weights


def fisher_analysis(J: torch.Tensor, x: torch.Tensor, names: Sequence[str], sigma: float, *,
                    log: torch.Tensor | None = None, rel_threshold: float = 1.0,
                    eig_floor: float = 1e-10) -> FisherReport:
    """Eigen-analysis of H = Jᵀ J / σ² at ``x``.

    Parameters
    ----------
    J : ``(M, D)`` output Jacobian w.r.t. the coordinates x; x : ``(D,)``; names : D coordinate names.
    sigma : noise standard deviation [response unit] (the residual RMSE when unknown).
    log : ``(D,)`` booleans, coordinates analysed in log space (default: the positive ones).
    rel_threshold : a direction is non-identifiable when its standard deviation 1/√λ exceeds this
        (relative for log coordinates, so 1.0 = 100 %), or when λ < ``eig_floor`` · λ_max.
    """
    x = torch.as_tensor(x, dtype=torch.float64)
    J = torch.as_tensor(J, dtype=torch.float64)
    log = (x > 0) if log is None else torch.as_tensor(log, dtype=torch.bool)
    Js = J * torch.where(log, x, torch.ones_like(x))[None]
    if not bool(torch.isfinite(Js).all()):
        raise ValueError("the output Jacobian at the optimum is not finite; the fit sits where the model diverges")
    H = Js.T @ Js / float(sigma) ** 2
    lam, V = torch.linalg.eigh(H)
    lam, V = lam.flip(0).clamp_min(0.0), V.flip(1)
    lam_max = float(lam[0]) if lam.numel() else 0.0
    cov = torch.linalg.pinv(H, rtol=eig_floor, hermitian=True)
    sd_scaled = cov.diagonal().clamp_min(0).sqrt()
    sd = torch.where(log, x.abs() * sd_scaled, sd_scaled)
    combos, weak = [], set()
    for i in range(len(lam)):
        li = float(lam[i])
        s = 1 / math.sqrt(li) if li > 0 else math.inf
        ok = li > eig_floor * lam_max and s <= rel_threshold
        expr, weights = _expression(list(names), V[:, i], log)
        combos.append({"expression": expr, "weights": weights, "eigenvalue": li, "sd": s, "identifiable": ok})
        if not ok:
            weak.update(n for n, w in weights.items() if abs(w) >= 0.3)
    null = [float(lam[i]) <= eig_floor * lam_max for i in range(len(lam))]
    for j in range(len(names)):  # a coordinate entangled with a null direction has no finite sd
        if any(nu and abs(float(V[j, i])) > 1e-3 for i, nu in enumerate(null)):
            sd[j] = math.inf
    rel = {n: float(sd[j] / abs(x[j])) if float(x[j]) != 0 else math.inf for j, n in enumerate(names)}
    return FisherReport(names=list(names), scale=["log" if b else "linear" for b in log.tolist()], eigenvalues=lam,
                        eigenvectors=V, sd={n: float(sd[j]) for j, n in enumerate(names)}, rel_sd=rel,
                        combinations=combos, non_identifiable=[n for n in names if n in weak], sigma=float(sigma))
