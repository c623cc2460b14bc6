"""What the discovery loop found, typed: the changes it tried (``Step``), the effects it removed or replaced
(``Change``) and the whole result (``DiscoveryResult``). Turned into the ``discovery.json`` content by
``as_json`` / ``DiscoveryResult.report`` only."""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from .validation import parts

__all__ = ["AFTER_ADDED", "Change", "DiscoveryResult", "Step", "disagreement_line", "parameter_values"]

AFTER_ADDED = "right after its effect was added"  # a step's ``when``: a start state offered outside the ranking


@dataclass
class Step:
    """One change the loop tried: an effect, a start state or a condition trend (``kind``), accepted or not.

    ``val_before``/``val_after``: out-of-sample errors (``validation.Score``) of the model before and with it;
    ``ic_before``/``ic_after``: the information criterion; ``train_rmse``, ``val_rmse`` (None when the score is
    not out of sample), ``test_rmse`` (None without test records) and ``parameters`` of the model with it;
    ``details``: what the kind adds (the trends chosen; the candidates' ranking and comparison, new coordinates,
    sub-steps)."""

    effect: str
    kind: str
    description: str
    accepted: bool
    val_before: float
    val_after: float
    ic_before: float
    ic_after: float
    criterion: str
    parameters: dict
    train_rmse: float
    val_rmse: float | None
    test_rmse: float | None
    details: dict = field(default_factory=dict)
    evidence_details: dict = field(default_factory=dict)

    def as_json(self) -> dict:
        evidence = {**self.evidence_details, "val_rmse_before": self.val_before, "val_rmse_after": self.val_after,
                    **parts(before=self.val_before, after=self.val_after),
                    f"{self.criterion}_before": self.ic_before, f"{self.criterion}_after": self.ic_after}
        return {"effect": self.effect, "kind": self.kind, "description": self.description, **self.details,
                "evidence": evidence, "parameters": self.parameters, "train_rmse": self.train_rmse,
                "val_rmse": self.val_rmse, "test_rmse": self.test_rmse, "accepted": self.accepted}


@dataclass
class Change:
    """An effect removed, or replaced (``by`` the effects put in its place; ``replacement`` why: "special_case"
    or "rival_swap"), after ``after_step`` accepted steps."""

    effect: str
    key: str
    kind: str
    by: list
    replacement: str | None
    val_before: float
    val_after: float
    train_rmse: float
    after_step: int = 0

    def as_json(self) -> dict:
        return {"effect": self.effect, "key": self.key, "kind": self.kind, "by": list(self.by),
                "replacement": self.replacement, "val_rmse_before": self.val_before, "val_rmse_after": self.val_after,
                **parts(before=self.val_before, after=self.val_after), "train_rmse": self.train_rmse,
                "after_step": self.after_step}


@dataclass
class DiscoveryResult:
    """What ``discover`` found. ``model``: the final model; ``steps``/``rejected``/``removed``: the changes
    accepted, turned down and undone (typed); ``report``: the ``discovery.json`` content; ``predictions``:
    ``{"before"|"after": {split: [arrays per record]}}``; ``splits``: the record sets."""

    model: torch.nn.Module
    report: dict
    predictions: dict = field(default_factory=dict)
    splits: dict = field(default_factory=dict)
    initial_model: torch.nn.Module | None = None
    steps: list[Step] = field(default_factory=list)
    rejected: list[Step] = field(default_factory=list)
    removed: list[Change] = field(default_factory=list)


CROSS_NAMES = {"loco": "leave-one-condition-out RMSE of the training operating points",
               "records": "validation records' RMSE"}


def disagreement_line(step: dict, unit: str = "") -> str | None:
    """The one line that says a step's two out-of-sample errors disagree (``step["cross_check"]``, from the loop:
    the error the rule judged fell by the margin, the other rose or fell by less), or None. ``step``: a step as in
    ``discovery.json``."""
    cross = step.get("cross_check") or {}
    if not cross.get("disagrees"):
        return None
    ev, u = step["evidence"], f" {unit}" if unit else ""
    judged = CROSS_NAMES["records" if cross["kind"] == "loco" else "loco"]
    b, a = cross["before"], cross["after"]
    moved = "rose" if a > b else f"fell only {100 * (1 - a / b):.1f} %, less than the margin,"
    fell = 100 * (1 - ev["val_rmse_after"] / ev["val_rmse_before"])
    return (f"step {step['effect']}: the {judged} fell {fell:.1f} % ({ev['val_rmse_before']:.4g} -> "
            f"{ev['val_rmse_after']:.4g}{u}) but the {CROSS_NAMES[cross['kind']]} {moved} ({b:.4g} -> {a:.4g}{u}): "
            "the evidence disagrees, so the step may fit what the judged records share rather than what carries "
            "over to other conditions; " + ("the loop refused it (discover.cross_check=confirm)" if cross.get("refused")
                                            else "weigh the held-out error"))


def parameter_values(model) -> dict:
    """``{"effect.parameter": {"value", "unit"}}`` of ``model`` (functions as text, and their config under
    ``"function"``: kind, condition, coefficients), as discovery.json lists them."""
    return {f"{e}.{p}": {"value": info["value"], "unit": info["unit"],
                         **({"function": info["function"]} if "function" in info else {})}
            for e, params in model.parameter_table().items() for p, info in params.items()}
