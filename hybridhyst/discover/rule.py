"""The one rule every change of the model is judged by: an added effect, a parameter made a function of a
condition, a start state, a removal, a swap for a simpler or a rival effect.

A fitted model is seen by the rule as a ``Judged``: its out-of-sample error (a ``validation.Score``, which may
stand for several errors) and its information criterion on the training records (BIC or AIC). Then:

* ``adds(new, old)``: a richer model replaces the current one when its out-of-sample error falls by more than
  ``margin`` (relative, in every part) **and** its information criterion falls;
* ``simpler(new, old)``: a simpler model (an effect removed, or replaced by a special case or a rival)
  replaces the current one when its information criterion falls and its out-of-sample error rises by at most
  half the margin: between two models the data cannot tell apart, the one with fewer parameters;
* ``pick(options)``: of several fitted alternatives, the one with the lowest out-of-sample error, and among
  those within the margin of it the lowest information criterion (validation cannot tell them apart, so the
  more parsimonious wins);
* ``choose(first, accepted, more)``: a greedy step's candidate: the pick of the best-ranked, or, when none of
  them is accepted, the pick of those ranked below that are.

**Within the noise.** A relative margin alone lets a model that already predicts at the noise level take on an
element the data lack: a flexible friction term that lowers a validation error of 1.05 σ to 1.02 σ passes a
2 % margin. With a noise level σ (the user's, or estimated from the data: ``analysis.noise``), two models whose
mean squared errors differ by at most ``NOISE_SHARE`` σ² are *within the noise* of each other: an addition must
lower the mean squared error by more than that, a simpler model may raise it by up to that, and a pick treats
options within it of the best as tied (the fewer parameters win). Far above the noise the margin is the larger
requirement and decides, as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .validation import Score, errors, improves, within

__all__ = ["Acceptance", "Judged", "NOISE_SHARE", "check_criterion", "information_criterion"]

NOISE_SHARE = 0.5  # models whose mean squared errors differ by at most this many σ² are within the noise


def information_criterion(sse: float, n: int, k: int, kind: str = "bic") -> float:
    """BIC = n ln(SSE/n) + k ln n, or AIC = n ln(SSE/n) + 2k (Gaussian errors, k free coordinates)."""
    if n <= 0 or not math.isfinite(sse) or sse <= 0:
        return math.inf
    penalty = k * math.log(n) if kind == "bic" else 2 * k
    return n * math.log(sse / n) + penalty


def check_criterion(kind: str) -> None:
    """A one-line error for an information criterion other than "bic" or "aic"."""
    if kind not in ("bic", "aic"):
        raise ValueError(f"unknown information criterion {kind!r}; choose 'bic' or 'aic'")


@dataclass(frozen=True)
class Judged:
    """What the rule sees of a fitted model: out-of-sample error ``val`` and information criterion ``ic``."""

    val: Score | float
    ic: float


@dataclass(frozen=True)
class Acceptance:
    """The acceptance rule (module docstring). ``n``: training samples the criterion counts; ``noise``: the noise
    standard deviation σ in the response's unit (None: the margin alone)."""

    margin: float
    criterion: str
    n: int
    noise: float | None = None
    share: float = NOISE_SHARE

    @property
    def floor(self) -> float:
        """The difference in mean squared error within the noise (``share`` σ²; 0 without a noise level)."""
        return self.share * self.noise**2 if self.noise and math.isfinite(self.noise) else 0.0

    def _gains(self, new, old) -> list[float]:
        """Per error part: old² − new² (how much mean squared error ``new`` removes)."""
        return [o * o - n * n for n, o in zip(errors(new), errors(old), strict=True)]

    def _within_noise(self, new, old) -> bool:
        """Whether ``new`` adds at most the noise floor of mean squared error to ``old`` in every part."""
        return all(-g <= self.floor for g in self._gains(new, old))

    def __post_init__(self):
        check_criterion(self.criterion)

    def ic(self, fit) -> float:
        """The information criterion of a ``fitting.Fit`` (its training SSE and free coordinates)."""
        return information_criterion(fit.sse, self.n, fit.k, self.criterion)

    def adds(self, new: Judged, old: Judged) -> bool:
        """Whether a richer model ``new`` earns its place over ``old``."""
        return (improves(new.val, old.val, self.margin) and new.ic < old.ic
                and all(g > self.floor for g in self._gains(new.val, old.val)))

    def refusal(self, new: Judged, old: Judged) -> list[str]:
        """Which of ``adds``'s requirements a richer model ``new`` failed, each in words (empty: it passes)."""
        out = []
        if not improves(new.val, old.val, self.margin):
            out.append(f"the judged RMSE did not fall by more than the margin ({self.margin:.0%})")
        gains = self._gains(new.val, old.val)
        if self.floor > 0 and all(g > 0 for g in gains) and not all(g > self.floor for g in gains):
            # (an error that rose fails the margin already: it is not "within the noise")
            out.append(f"its mean square fell by no more than {self.share:g} noise variance ({self.share:g} σ², "
                       f"σ = {self.noise:.4g}): within the noise")
        if not new.ic < old.ic:
            out.append(f"the information criterion ({self.criterion.upper()}) did not fall")
        return out

    def simpler(self, new: Judged, old: Judged) -> bool:
        """Whether a simpler model ``new`` may replace ``old``: it loses at most half the margin, or stays within
        the noise of it."""
        return new.ic < old.ic and (within(new.val, old.val, self.margin / 2) or self._within_noise(new.val, old.val))

    def pick(self, options: list[Judged], accepted=None) -> int:
        """Index of the option the rule prefers (lowest error; within the margin or the noise of it, lowest
        criterion). ``accepted(i)``, where given, says whether the rule would accept option i as a step: a
        close option it would refuse is not preferred to one it would accept (a simpler rival within the noise of
        the best must not stop the loop where the best would have passed)."""
        best = min((o.val for o in options), key=lambda v: v.key if isinstance(v, Score) else float(v))
        close = [i for i, o in enumerate(options)
                 if within(o.val, best, self.margin) or self._within_noise(o.val, best)]
        if accepted is not None:
            close = [i for i in close if accepted(i)] or close
        return min(close, key=lambda i: options[i].ic)

    def choose(self, first: list[Judged], accepted, more=None) -> tuple[int, bool]:
        """A greedy step's choice: ``(index, accepted)``. ``first``: the best-ranked options (by the training
        fit); ``accepted(i)``: whether the rule accepts option i (indices run on through those ``more`` adds).
        The ``pick`` of ``first``; when the rule accepts none of them, ``more()`` judges the options ranked below
        (returns their ``Judged``, in order) and the pick of those it accepts is the step: a flexible element that
        fits the training records best may fail on validation where the effect the data hold, ranked below it,
        does not. Where none passes, the first pick, refused."""
        index = self.pick(first, accepted)
        passes = accepted(index)
        if passes or more is None:
            return index, passes
        rest = more()
        passing = [len(first) + i for i in range(len(rest)) if accepted(len(first) + i)]
        if not passing:
            return index, False
        return passing[self.pick([rest[i - len(first)] for i in passing])], True
