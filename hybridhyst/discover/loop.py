"""The closed loop: fit the nominal, diagnose the residual, rank candidate effects, add the best, refit,
accept on validation error and an information criterion, repeat; then say what is left.

Ranking: the model augmented by each candidate is refitted with every coordinate free (the candidate's few
starting values as restarts of one batched Levenberg–Marquardt, the other coordinates from their fitted
values, first re-balanced against each start; LM continued until converged), and the share of the training
residual's sum of squares that disappears is the candidate's evidence. Of the best ``top`` candidates the one
with the lowest validation RMSE is chosen (among those within ``margin`` of it, the one with the lowest
information criterion: validation cannot tell them apart, so the more parsimonious wins) and accepted if its
validation RMSE falls by more than ``margin`` (relative) and the information criterion (BIC by default)
improves.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from ..analysis.metrics import split_metrics
from ..data.records import Record, RecordSet
from ..identify import identify
from ..identify.identify import RecordsProblem
from ..identify.refine import levenberg_marquardt
from ..identify.space import SearchSpace
from ..simulate import simulate
from .candidates import Candidate, Scales, library_candidates
from .diagnose import diagnose

__all__ = ["DiscoveryResult", "discover", "information_criterion"]


@dataclass
class DiscoveryResult:
    """What ``discover`` found. ``model``: the final model; ``report``: the ``discovery.json`` content;
    ``predictions``: ``{"before"|"after": {split: [arrays per record]}}``; ``splits``: the record sets."""

    model: torch.nn.Module
    report: dict
    predictions: dict = field(default_factory=dict)
    splits: dict = field(default_factory=dict)
    initial_model: torch.nn.Module | None = None


def information_criterion(sse: float, n: int, k: int, kind: str = "bic") -> float:
    """BIC = n ln(SSE/n) + k ln n, or AIC = n ln(SSE/n) + 2k (Gaussian errors, k free coordinates)."""
    if n <= 0 or not math.isfinite(sse) or sse <= 0:
        return math.inf
    penalty = k * math.log(n) if kind == "bic" else 2 * k
    return n * math.log(sse / n) + penalty


def _as_records(records) -> list[Record]:
    return list(records.records if isinstance(records, RecordSet) else records)


def _predict(model, records, sim) -> list[np.ndarray]:
    if not records:
        return []
    with torch.no_grad():
        out = simulate(model, list(records), method=sim["method"], substeps=sim["substeps"], backend=sim["backend"])
    return [o[:, 0].numpy() for o in out]


def _metrics(records, preds, labels: Sequence[str] | None = None) -> dict:
    """Pooled RMSE and RMSE per condition label (``training.evaluate.split_metrics``); {} without records."""
    out = split_metrics([{"condition": _label(r, labels), "y": np.asarray(r.y), "y_pred": p, "warmup": r.warmup}
                         for r, p in zip(records, preds)])
    if out:
        out["per_condition"] = {k: v["rmse"] for k, v in out["per_condition"].items()}
    return out


def _label(r: Record, names: Sequence[str] | None = None) -> str:
    from ..data.datamodule import condition_label

    return condition_label(r, names)


def _numeric_conditions(records) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for r in records:
        for k, v in r.conditions.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)):
                out.setdefault(k, []).append(float(v))
    return {k: v for k, v in out.items() if len(v) == len(records)}


def _sse(problem: RecordsProblem, x: torch.Tensor) -> float:
    with torch.no_grad():
        c = float(problem.cost(x[None])[0])
    return c * problem.n_samples if math.isfinite(c) else math.inf


def _converged_lm(problem: RecordsProblem, space: SearchSpace, starts: torch.Tensor, lm_steps: int,
                  rounds: int = 4, rtol: float = 1e-3):
    """Batched LM in rounds of ``lm_steps`` iterations, continued while the best cost still falls by more
    than ``rtol`` (relative) per round, at most ``rounds`` rounds. A fixed budget can stop a fit halfway
    down a long valley (a new hysteretic state pulling the damping and stiffness with it); the next
    candidate would then get the credit for finishing it."""
    lm = levenberg_marquardt(problem.residuals, space, starts, iters=lm_steps, progress=False)
    for _ in range(rounds - 1):
        if not math.isfinite(lm.cost):
            break
        more = levenberg_marquardt(problem.residuals, space, lm.X, iters=lm_steps, progress=False)
        done = more.cost > (1 - rtol) * lm.cost
        lm = more  # each row continues from its own end, so no row gets worse
        if done:
            break
    return lm


def _fit_new(candidate: Candidate, model, train, sim, lm_steps, box_factor) -> tuple[float, object, dict]:
    """Fit the model augmented by ``candidate``: every coordinate free (the new ones within the candidate's
    bounds, the others in a box around their fitted values), one batched Levenberg–Marquardt whose rows
    start from the fitted values with each of the candidate's starts. Returns (SSE, model, coordinates).

    Freeing the old coordinates matters: a nominal fitted without friction has, say, an inflated viscous
    coefficient, which the new Coulomb term can only replace if that coefficient may come down. Before the
    joint fit, ``lm_steps // 2`` iterations move only the old coordinates with the new effect held at each
    start: a start that is not neutral (a Bouc–Wen element adds its initial stiffness k) is first absorbed
    by the fitted model (the linear spring gives up that stiffness), so the joint fit starts near the
    fitted response instead of in another basin. On the Bouc–Wen benchmark this is the difference between
    finding the hysteresis and not (experiments/boucwen_discovery)."""
    aug = candidate.build(model)
    space = SearchSpace(aug, bounds=candidate.bounds, factor=box_factor)
    problem = RecordsProblem(space, train, method=sim["method"], substeps=sim["substeps"], backend=sim["backend"])
    current = dict(zip(space.names, space.initial().tolist()))
    starts = torch.tensor([[s.get(n, current[n]) for n in space.names] for s in candidate.starts],
                          dtype=torch.float64).clamp(space.lower, space.upper)
    old = torch.tensor([n not in candidate.free for n in space.names])
    if bool(old.any()):  # re-balance the fitted coordinates against each start of the new effect
        starts = levenberg_marquardt(problem.residuals, space, starts, iters=max(lm_steps // 2, 1), free=old,
                                     progress=False).X
    lm = _converged_lm(problem, space, starts, lm_steps)
    if not math.isfinite(lm.cost):
        return math.inf, None, {}
    space.to_model(lm.x)
    return lm.cost * problem.n_samples, aug, dict(zip(space.names, lm.x.tolist()))


def _polish(model, train, sim, lm_steps, box_factor) -> tuple[float, int]:
    """Refit the current model (every coordinate, LM from its values) so that its training error is
    converged the same way each candidate's is: a candidate then gets credit only for what it adds, not
    for finishing the previous fit. Returns (SSE, number of coordinates); the model is updated in place."""
    space = SearchSpace(model, factor=box_factor)
    problem = RecordsProblem(space, train, method=sim["method"], substeps=sim["substeps"], backend=sim["backend"])
    x0 = space.initial().clamp(space.lower, space.upper)
    lm = _converged_lm(problem, space, x0[None], lm_steps)
    x = lm.x if math.isfinite(lm.cost) and lm.cost <= _sse(problem, x0) / problem.n_samples else x0
    space.to_model(x)
    return _sse(problem, x), space.dim


def _rmse_of(model, records, sim) -> float:
    return _metrics(records, _predict(model, records, sim)).get("rmse", math.inf) if records else math.inf


def _parameters(model) -> dict:
    return {f"{e}.{p}": {"value": info["value"], "unit": info["unit"]}
            for e, params in model.parameter_table().items() for p, info in params.items()}


def discover(records, nominal, candidates: Sequence[str] | None = None, split: Mapping | None = None, *,
             conditions: bool | Sequence[str] = True, label_conditions: Sequence[str] | None = None,
             margin: float = 0.02, criterion: str = "bic", max_steps: int = 4,
             top: int = 3, lm_steps: int = 25, box_factor: float = 10.0, noise_sd: float | None = None,
             fit_nominal: bool = True, identify_options: Mapping | None = None, backend: str = "fast",
             method: str = "rk4", substeps: int = 1, progress: bool = True) -> DiscoveryResult:
    """Find, name and add the effects a nominal model lacks; report the error before and after.

    Parameters
    ----------
    records : a ``RecordSet`` (or list of records) with operating conditions.
    nominal : the starting ``NominalModel`` (fitted in place and then augmented copies of it).
    candidates : library effect names to consider (default: the whole library, see ``candidates.py``).
    split : ``{"held_out": query, "val": query}`` as ``RecordSet.split``; test = held-out conditions.
    conditions : also try making each constant parameter a linear function of each numeric condition
        (True), of the conditions named (a list), or of none (False). Name only conditions that mean the
        same physical thing on the held-out records (e.g. not a test frequency that is 0 for an earthquake).
    label_conditions : conditions shown in per-condition labels (default: all).
    margin : relative fall of the validation RMSE (training RMSE without validation records) required.
    criterion : "bic" or "aic", which must also fall; max_steps : effects added at most.
    top : best-ranked candidates compared on validation error; lm_steps : LM iterations per round of
        a fit (more rounds while the cost still falls by more than 0.1 %, at most 4).
    noise_sd : known noise level (reported beside the residual RMSE; not used by the rule).
    fit_nominal : identify the nominal on the training records first (``hybridhyst.identify``, options in
        ``identify_options``); else start from its current values.
    backend, method, substeps : simulator settings ("fast": compiled, cached per model structure).

    Raises
    ------
    ValueError
        Unknown candidate names, a split leaving no training records, records too short to identify.
    """
    start = time.perf_counter()
    if criterion not in ("bic", "aic"):
        raise ValueError(f"unknown information criterion {criterion!r}; choose 'bic' or 'aic'")
    records = records if isinstance(records, RecordSet) else RecordSet(_as_records(records))
    from ..physics.effects import EFFECTS

    unknown = [c for c in (candidates or []) if c not in EFFECTS]
    if unknown:
        raise ValueError(f"unknown candidate effect(s) {unknown}; the library has {sorted(EFFECTS)}")
    split = dict(split or {})
    train_set, val_set, test_set = records.split(held_out=split.get("held_out"), val=split.get("val"))
    train, val, test = _as_records(train_set), _as_records(val_set), _as_records(test_set)
    sim = {"backend": backend, "method": method, "substeps": int(substeps)}
    n_train = sum(len(r) for r in train)
    for r in train:
        r.require_samples(16, "discovery (identifying a candidate effect)")
    model = nominal
    if fit_nominal:
        opts = {"method": "cma", "pop": 24, "generations": 30, "restarts": 4, **dict(identify_options or {})}
        identify(model, train, fisher=False, progress=progress, backend=backend, ode_method=method,
                 substeps=substeps, **opts)
    import copy

    scored = val or train
    splits = {"train": train, "val": val, "test": test}

    def evaluate(m):  # predictions of every split (simulated once) and their metrics
        preds = {s: _predict(m, rs, sim) for s, rs in splits.items()}
        return preds, {s: _metrics(splits[s], preds[s], label_conditions) for s in splits}

    sse, k = _polish(model, train, sim, lm_steps, box_factor)
    initial = copy.deepcopy(model)  # "before": the nominal as fitted (identified, then polished)
    preds_before, before = evaluate(initial)
    ic = information_criterion(sse, n_train, k, criterion)
    val_rmse = before["val" if val else "train"]["rmse"]
    diag_before = diagnose(train, preds_before["train"], noise_sd)
    steps, rejected = [], []
    tried = set()
    from ..physics.models import DrivenOscillator

    scales = Scales.of(train, oscillator=isinstance(model, DrivenOscillator))
    cond_values = _numeric_conditions(train) if conditions else {}
    if conditions and not isinstance(conditions, bool):
        missing = [c for c in conditions if c not in cond_values]
        if missing:
            raise ValueError(f"condition(s) {missing} are not numeric conditions of every training record; "
                             f"available: {sorted(cond_values)}")
        cond_values = {c: cond_values[c] for c in conditions}
    for _step in range(int(max_steps)):
        cands = [c for c in library_candidates(model, scales, cond_values, candidates) if c.name not in tried]
        if not cands:
            break
        ranking = []
        for cand in _progress(cands, progress, "rank candidates"):
            try:
                c_sse, aug, coords = _fit_new(cand, model, train, sim, lm_steps, box_factor)
            except (ValueError, RuntimeError) as exc:  # a candidate that cannot be simulated is skipped
                c_sse, aug, coords = math.inf, None, {"error": str(exc)}
            ranking.append((cand, c_sse, aug, coords))
        ranking.sort(key=lambda item: item[1])
        evidence = {c.name: (1 - s / sse if math.isfinite(s) and sse > 0 else None) for c, s, _, _ in ranking}
        finals = [(cand, aug, c_sse, len(coords), coords, _rmse_of(aug, scored, sim))
                  for cand, c_sse, aug, coords in ranking[: int(top)] if aug is not None]
        if not finals:
            break
        # the lowest validation error; among candidates validation cannot tell apart (within the margin),
        # the lowest information criterion (the most parsimonious explanation)
        best_val = min(f[5] for f in finals)
        close = [f for f in finals if f[5] <= (1 + margin) * best_val]
        cand, aug, f_sse, f_k, f_coords, f_val = min(
            close, key=lambda f: information_criterion(f[2], n_train, f[3], criterion))
        f_ic = information_criterion(f_sse, n_train, f_k, criterion)
        accepted = f_val < (1 - margin) * val_rmse and f_ic < ic
        entry = {"effect": cand.name, "kind": cand.kind, "description": cand.describe,
                 "evidence": {"explained_share": evidence[cand.name], "ranking": evidence,
                              "val_rmse_before": val_rmse, "val_rmse_after": f_val,
                              f"{criterion}_before": ic, f"{criterion}_after": f_ic,
                              "refitted": [f[0].name for f in finals]},
                 "parameters": {k: v for k, v in _parameters(aug).items()},
                 "new_coordinates": {n: f_coords.get(n) for n in cand.free},
                 "train_rmse": math.sqrt(f_sse / n_train) if math.isfinite(f_sse) else math.inf,
                 "val_rmse": f_val if val else None,
                 "test_rmse": _rmse_of(aug, test, sim) if test else None, "accepted": accepted}
        if not accepted:
            rejected.append(entry)
            break
        steps.append(entry)
        tried.add(cand.name)
        model = aug
        sse, k = _polish(model, train, sim, lm_steps, box_factor)
        ic, val_rmse = information_criterion(sse, n_train, k, criterion), _rmse_of(model, scored, sim)
    preds_after, after = evaluate(model)
    diag_after = diagnose(train, preds_after["train"], noise_sd)
    report = {
        "before": {"test_rmse": before["test"].get("rmse"), "train_rmse": before["train"]["rmse"],
                   "val_rmse": before["val"].get("rmse"), "per_condition": before["test"].get("per_condition", {}),
                   "parameters": _parameters(initial), "diagnostics": diag_before},
        "after": {"test_rmse": after["test"].get("rmse"), "train_rmse": after["train"]["rmse"],
                  "val_rmse": after["val"].get("rmse"), "per_condition": after["test"].get("per_condition", {}),
                  "parameters": _parameters(model), "diagnostics": diag_after},
        "steps": steps, "rejected": rejected,
        "unexplained": {"train_rmse": after["train"]["rmse"], "noise_sd": noise_sd,
                        "dependence": diag_after["dependence"], "whiteness": diag_after["whiteness"],
                        "where": diag_after["where"],
                        "residual_network": residual_network(train, preds_after["train"], val or None,
                                                             preds_after["val"] or None)},
        "settings": {"margin": margin, "criterion": criterion, "max_steps": max_steps, "top": top,
                     "lm_steps": lm_steps, "candidates": list(candidates) if candidates else "library",
                     "conditions": conditions if isinstance(conditions, bool) else list(conditions),
                     "backend": backend, "substeps": substeps},
        "records": {"train": [r.name for r in train], "val": [r.name for r in val], "test": [r.name for r in test]},
        "wall_s": time.perf_counter() - start,
    }
    return DiscoveryResult(model=model, report=report, predictions={"before": preds_before, "after": preds_after},
                           splits=splits, initial_model=initial)


def residual_network(train, train_pred, val=None, val_pred=None, steps: int = 300, seed: int = 0) -> dict:
    """How much of the remaining residual a small network of (x, ẋ, sign ẋ, travel since reversal,
    conditions) recovers: the share of residual variance it explains on validation records (training
    records without them). An honest "is anything structured left" number, not a model."""
    from .diagnose import features

    def table(records, preds):
        X, R = [], []
        for rec, p in zip(records, preds):
            f = features(rec.t, rec.x)
            cols = [f["x"], f["v"], f["sign_v"], f["since_reversal"]]
            X.append(np.stack(cols, 1))
            R.append(np.asarray(rec.y) - p)
        return np.concatenate(X), np.concatenate(R)

    X, R = table(train, train_pred)
    Xv, Rv = table(val, val_pred) if val else (X, R)
    mu, sd = X.mean(0), X.std(0) + 1e-12
    rs = R.std() or 1.0
    g = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    net = torch.nn.Sequential(torch.nn.Linear(X.shape[1], 32), torch.nn.Tanh(), torch.nn.Linear(32, 32),
                              torch.nn.Tanh(), torch.nn.Linear(32, 1)).double()
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    Xt, Rt = torch.as_tensor((X - mu) / sd), torch.as_tensor(R / rs)
    for _ in range(steps):
        idx = torch.randint(0, len(Xt), (min(len(Xt), 2048),), generator=g)
        loss = (net(Xt[idx])[:, 0] - Rt[idx]).square().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        pv = net(torch.as_tensor((Xv - mu) / sd))[:, 0].numpy() * rs
    share = 1 - float(np.var(Rv - pv) / max(np.var(Rv), 1e-300))
    return {"explained_share": share, "on": "val" if val else "train",
            "rmse_after_network": float(np.sqrt(np.mean((Rv - pv) ** 2)))}


def _progress(items, enabled: bool, what: str):
    if not enabled:
        return items
    from tqdm.auto import tqdm

    return tqdm(items, desc=what, leave=False)
