"""Residual diagnostics: is the residual white, what does it depend on, where in the loop does it live."""

from __future__ import annotations

import math

import numpy as np

from ..analysis.noise import autocorrelation

__all__ = ["FEATURES", "FEATURE_UNITS", "diagnose", "features", "shared_controls", "structure_explained"]

FEATURES = ("x", "v", "sign_v", "since_reversal", "phase", "time", "travel")
# each feature's unit as a template in the records' units (x: the excitation's, t: time's; physics render_unit)
FEATURE_UNITS = {"x": "x", "v": "x/t", "sign_v": "-", "since_reversal": "x", "phase": "rad", "time": "t",
                 "travel": "x"}
_BINS = 12


def features(t: np.ndarray, x: np.ndarray, controls: dict | None = None) -> dict[str, np.ndarray]:
    """Per-sample features of one record: x, ẋ, sign(ẋ), distance travelled since the last reversal,
    loop phase (angle of (x, ẋ) normalised by their spreads, radians), time, cumulative travel; and each of
    ``controls`` (``{name: channel}``, a record's control channels) as ``control:<name>``."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    v = np.gradient(x, t, edge_order=2) if len(x) > 2 else np.zeros_like(x)
    s = np.sign(v)
    since = np.zeros_like(x)
    anchor = x[0]
    for i in range(1, len(x)):
        if s[i] != 0 and s[i - 1] != 0 and s[i] != s[i - 1]:
            anchor = x[i - 1]
        since[i] = abs(x[i] - anchor)
    phase = np.arctan2(v / (np.std(v) or 1.0), (x - x.mean()) / (np.std(x) or 1.0))
    travel = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(x)))])
    return {"x": x, "v": v, "sign_v": s, "since_reversal": since, "phase": phase, "time": t - t[0], "travel": travel,
            **{f"control:{k}": np.asarray(c, float) for k, c in (controls or {}).items()}}


def shared_controls(records) -> list[str]:
    """The control channels every record carries (``Record.controls``), in the first record's order."""
    records = list(records)
    return [c for c in (records[0].controls if records else {}) if all(c in r.controls for r in records)]


def structure_explained(feature: np.ndarray, r: np.ndarray, bins: int = _BINS) -> float:
    """Correlation ratio η² of the residual on a feature: the share of the residual's variance explained by
    its mean in quantile bins of the feature (0: no dependence; 1: the residual is a function of it), in its
    unbiased form ε² (noise alone in k bins of n samples would give η² ≈ (k − 1)/n; clipped at 0)."""
    r = np.asarray(r, float)
    total = float(np.var(r))
    if total <= 0 or len(r) < 2 * bins:
        return 0.0
    f = np.asarray(feature, float)
    edges = np.unique(np.quantile(f, np.linspace(0, 1, bins + 1)))
    if len(edges) < 3:
        groups = np.unique(f, return_inverse=True)[1]  # a few discrete values (sign, a condition)
    else:
        groups = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, len(edges) - 2)
    counts = np.bincount(groups)
    means = np.bincount(groups, weights=r) / np.maximum(counts, 1)
    k, n = int((counts > 0).sum()), len(r)
    within = float(np.sum((r - means[groups]) ** 2)) / max(n - k, 1)  # ε²: η² less the share noise alone gives
    return max(0.0, 1.0 - within / (total * n / (n - 1)))


def _within(feature: np.ndarray, r: np.ndarray, groups: list[np.ndarray]) -> float:
    """η² of the residual on a feature within each group (boolean masks), weighted by the groups' residual
    variance: the share of the within-group variance that the feature explains."""
    parts = [(float(np.var(r[g])) * g.sum(), structure_explained(feature[g], r[g])) for g in groups]
    total = sum(w for w, _ in parts)
    return sum(w * e for w, e in parts) / total if total > 0 else 0.0


def diagnose(records, predictions, noise_sd: float | None = None) -> dict:
    """Diagnostics of the residual (measured − predicted) over ``records`` (lists of the same length), each
    record's samples after its ``warmup``.

    Returns
    -------
    ``{"rmse", "noise_sd", "whiteness": {"lag_1", "lag_5", "lag_20", "white"}, "dependence": {feature:
    η²}, "scale": {condition: {level: residual RMS}}, "where": {"phase_deg": centre of the phase bin with the
    largest mean |residual|, "share": that bin's share of the residual energy}}``; the features are those of
    ``features`` plus every numeric condition (per record) and every control channel the records all carry
    (``control:<name>``, per sample: a residual that follows a coil current the model reads wrongly). ``white`` is
    true when the lag-1 autocorrelation is below 0.3.
    """
    controls = shared_controls(records)
    r_all, feats = [], {k: [] for k in [*FEATURES, *(f"control:{c}" for c in controls)]}
    conds: dict[str, list] = {}
    acs = []
    for rec, pred in zip(records, predictions):
        r = rec.scored(np.asarray(rec.y, float) - np.asarray(pred, float))  # a warm-up settles, unscored
        r_all.append(r)
        for k, v in features(rec.t, rec.x, {c: rec.controls[c] for c in controls}).items():
            feats[k].append(rec.scored(v))
        for k, v in rec.operating.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                conds.setdefault(k, []).append(np.full(len(r), float(v)))
        acs.append(autocorrelation(r))
    r = np.concatenate(r_all)
    # a feature's η² within each operating point (records of equal numeric conditions), weighted by the point's
    # residual sum of squares: a structure whose sign or size changes with the condition cancels in a pooled mean
    points = [tuple(float(v[i][0]) for v in conds.values() if len(v) == len(r_all)) for i in range(len(r_all))]
    ids = {p: j for j, p in enumerate(dict.fromkeys(points))}
    point = np.concatenate([np.full(len(ri), ids[p]) for ri, p in zip(r_all, points)])
    groups = [point == j for j in ids.values()]
    dep = {k: _within(np.concatenate(v), r, groups) for k, v in feats.items()}
    for k, v in conds.items():
        if len(v) == len(r_all) and len({float(a[0]) for a in v}) > 1:
            dep[f"condition:{k}"] = structure_explained(np.concatenate(v), r)
    phase = np.concatenate(feats["phase"])
    edges = np.linspace(-math.pi, math.pi, 13)
    idx = np.clip(np.searchsorted(edges, phase, side="right") - 1, 0, 11)
    energy = np.bincount(idx, weights=r**2, minlength=12)
    k = int(np.argmax(energy))
    white = {key: float(np.nanmean([a[key] for a in acs])) for key in acs[0]}
    white["white"] = bool(white["lag_1"] < 0.3)
    scale = {}  # the residual's size per level of a condition: a spread that grows with it has no mean to show
    for name, per_record in conds.items():
        if len(per_record) == len(r_all) and len({float(a[0]) for a in per_record}) > 1:
            levels = np.concatenate(per_record)
            scale[name] = {f"{lv:g}": float(np.sqrt(np.mean(r[levels == lv] ** 2))) for lv in np.unique(levels)}
    return {"rmse": float(np.sqrt(np.mean(r**2))), "noise_sd": noise_sd, "whiteness": white, "dependence": dep,
            "scale": scale, "where": {"phase_deg": float(np.degrees(0.5 * (edges[k] + edges[k + 1]))),
                                      "share": float(energy[k] / max(energy.sum(), 1e-300))}}
