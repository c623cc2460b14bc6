"""Loop metrics of one stabilized hysteresis cycle (seed 002, Section 3.4 and Table 1), and their trends.

Seed 002 (Rodak & Zalewski 2020) characterises a torque–angle loop M(Φ) at ±5° by

* the equivalent loading stiffness k_eq_l: the slope dM/dΦ of a straight line fitted to the loading
  branch on Φ ∈ <1, 3> deg (the region <0, 1> is left out on purpose: grain reorganisation and clearance);
* the equivalent unloading stiffness k_eq_u: the same on the unloading branch, Φ ∈ <5, 3.5> deg;
* the equivalent stiffness k_eq_a = (k_eq_l + k_eq_u) / 2;
* the maximum torque M_max: the torque at Φ = 5°, the amplitude (``peak_response``: the largest torque);
* the dissipated energy E_d: the area inside the loop by the midpoint rule.

Loading means |x| increasing (x ẋ > 0), unloading |x| decreasing, so a window on the negative side
(e.g. (−3, −1)) measures the other half of a symmetric loop with the same meaning. Units follow the
data: stiffness [F/x], peak [F], energy [F·x] (Nm·deg for seed 002; its Table 1 prints "Nm/deg", a
unit typo for an area; multiply by π/180 for J). ``fit_trend`` fits the metric's dependence on a
condition with seed 002's three-parameter exponentials (Figs. 9–11, eqs. 7–12).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

import numpy as np

from .metrics import r2

__all__ = ["LoopMetrics", "TrendFit", "dissipated_energy", "equivalent_stiffness", "fit_trend", "loop_metrics",
           "peak_response"]

SEED002_LOADING = (1.0, 3.0)  # deg: Φ ∈ <1, 3>
SEED002_UNLOADING = (3.5, 5.0)  # deg: Φ ∈ <5, 3.5>


def _cycle(x, y) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x.detach().cpu() if hasattr(x, "detach") else x, dtype=np.float64)
    y = np.asarray(y.detach().cpu() if hasattr(y, "detach") else y, dtype=np.float64)
    if x.ndim != 1 or x.shape != y.shape or len(x) < 4:
        raise ValueError(f"a loop needs 1-D x and y of the same length >= 4, got shapes {x.shape} and {y.shape}")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("the loop has non-finite samples (a diverged simulation?); metrics need finite x and y")
    return x, y


def equivalent_stiffness(x, y, window: tuple[float, float], branch: str = "loading") -> float:
    """Slope dy/dx [F/x] of a least-squares line through one branch of the loop inside ``window``.

    Parameters
    ----------
    x, y : one stabilized cycle, ``(T,)`` excitation [x] and response [F].
    window : ``(x_low, x_high)`` [x]: samples with x_low <= x <= x_high are used.
    branch : ``"loading"`` (|x| increasing, x ẋ > 0) or ``"unloading"`` (x ẋ < 0); ẋ by central differences.
    """
    x, y = _cycle(x, y)
    if branch not in ("loading", "unloading"):
        raise ValueError(f"branch must be 'loading' or 'unloading', got {branch!r}")
    lo, hi = sorted(float(w) for w in window)
    growing = x * np.gradient(x) > 0
    pick = (x >= lo) & (x <= hi) & (growing if branch == "loading" else ~growing)
    if np.count_nonzero(pick) < 2 or np.ptp(x[pick]) <= 0:
        raise ValueError(f"the {branch} branch has fewer than two distinct samples in x ∈ [{lo:g}, {hi:g}] "
                         f"(the loop spans [{x.min():.3g}, {x.max():.3g}]); choose a window inside the loop")
    return float(np.polyfit(x[pick], y[pick], 1)[0])


def peak_response(x, y) -> tuple[float, float]:
    """``(x_max, y_max)``: the amplitude [x] and the largest response over the cycle [F] (seed 002's M_max).

    Seed 002 reads M_max "at Φ = 5°", the amplitude, where its loops (stiffening towards the amplitude) have
    their maximum. The maximum is used rather than the sample at x_max itself because a velocity-dependent
    term passes through zero exactly at the turning point (ẋ = 0): a dry-friction loop is there halfway down
    its reversal jump.
    """
    x, y = _cycle(x, y)
    return float(x.max()), float(y.max())


def dissipated_energy(x, y) -> float:
    """Loop area ∮ y dx [F·x] by the midpoint rule, the contour closed from the last sample to the first.

    Σ ½ (y_i + y_{i+1}) (x_{i+1} − x_i): positive for a dissipative loop (clockwise in the x–y plane, the
    response leading the excitation), negative for one that would give energy back. For x = X sin ωt,
    y = F sin(ωt + φ) over one period it is π F X sin φ.
    """
    x, y = _cycle(x, y)
    xc, yc = np.append(x, x[0]), np.append(y, y[0])
    return float(np.sum(0.5 * (yc[1:] + yc[:-1]) * np.diff(xc)))


@dataclass(frozen=True)
class LoopMetrics:
    """Seed 002's loop metrics of one cycle (units of the data; seed 002: Nm/deg, Nm, deg, Nm·deg)."""

    loading_stiffness: float    # k_eq_l [F/x]
    unloading_stiffness: float  # k_eq_u [F/x]
    average_stiffness: float    # k_eq_a = (k_eq_l + k_eq_u) / 2 [F/x]
    peak_response: float        # M_max: largest response, reached at the amplitude in seed 002 [F]
    amplitude: float            # largest x [x]
    dissipated_energy: float    # E_d: loop area [F·x]

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def loop_metrics(x, y, loading: tuple[float, float] = SEED002_LOADING,
                 unloading: tuple[float, float] = SEED002_UNLOADING) -> LoopMetrics:
    """All of seed 002's metrics of one stabilized cycle ``x, y`` (``(T,)`` each).

    ``loading`` / ``unloading`` are the fitting windows [x]; the defaults are seed 002's for its ±5° tests
    (<1, 3> and <5, 3.5> deg). Pass exactly one cycle: earlier cycles carry the start-up transient.
    """
    k_l = equivalent_stiffness(x, y, loading, "loading")
    k_u = equivalent_stiffness(x, y, unloading, "unloading")
    amp, peak = peak_response(x, y)
    return LoopMetrics(k_l, k_u, 0.5 * (k_l + k_u), peak, amp, dissipated_energy(x, y))


_TRENDS = {
    "exp_rise": lambda c, y0, a, b: y0 + a * (1 - np.exp(-b * c)),
    "exp_decay": lambda c, y0, a, b: y0 + a * np.exp(-b * c),
    "exp_growth": lambda c, y0, a, b: y0 + a * np.exp(b * c),
}


@dataclass(frozen=True)
class TrendFit:
    """A fitted trend y = f(c; y0, a, b) of ``kind`` (forms as ``physics.parameters.ExpRise`` etc.)."""

    kind: str
    y0: float
    a: float
    b: float
    r2: float

    def __call__(self, c) -> np.ndarray:
        return _TRENDS[self.kind](np.asarray(c, dtype=np.float64), self.y0, self.a, self.b)


def fit_trend(c, y, kind: str = "exp_rise") -> TrendFit:
    """Least-squares fit (scipy ``curve_fit``) of seed 002's exponential forms to values ``y`` at conditions ``c``.

    kind : ``"exp_rise"`` y0 + a (1 − e^(−b c)) (rise to maximum, Figs. 9–11), ``"exp_decay"`` y0 + a e^(−b c)
    or ``"exp_growth"`` y0 + a e^(b c). The start is the data's end values with b = 3 / (c range); a fit
    that does not converge raises ``ValueError``. Returns the coefficients and R² on the given points.
    """
    from scipy.optimize import OptimizeWarning, curve_fit

    if kind not in _TRENDS:
        raise ValueError(f"unknown trend kind {kind!r}; choose one of {sorted(_TRENDS)}")
    c, y = np.asarray(c, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if c.ndim != 1 or c.shape != y.shape or len(c) < 4 or not (np.isfinite(c).all() and np.isfinite(y).all()):
        raise ValueError(f"fit_trend needs at least 4 finite (c, y) pairs of the same length, got {c.shape}, {y.shape}")
    order = np.argsort(c)
    first, last = y[order[0]], y[order[-1]]
    b0 = 3.0 / max(np.ptp(c), 1e-300)
    growth = (last - first) / math.expm1(3.0)
    p0 = {"exp_rise": (first, last - first, b0), "exp_decay": (last, first - last, b0),
          "exp_growth": (first - growth, growth, b0)}[kind]
    try:
        with warnings.catch_warnings():  # the covariance is not used: a flat trend may leave it undefined
            warnings.simplefilter("ignore", OptimizeWarning)
            coef, _ = curve_fit(_TRENDS[kind], c, y, p0=p0, maxfev=20000)
    except RuntimeError as err:
        raise ValueError(f"fit_trend({kind}) did not converge: {err}") from err
    y0, a, b = (float(v) for v in coef)
    return TrendFit(kind, y0, a, b, r2=r2(_TRENDS[kind](c, y0, a, b), y))
