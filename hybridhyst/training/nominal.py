"""What the modules with a nominal model share (``NominalMixin``): the nominal simulated through ``simulate`` with
the run's ``SimulationSettings``, a window's start state (encoder), the conditions and controls per sample, and the
flat per-sample views the physics residual and the dynamics network evaluate."""

from __future__ import annotations

import torch
from torch import nn

from ..data.datamodule import Normaliser
from ..nets import build_net
from ..physics.models import DrivenOscillator
from ..simulate import SimulationSettings, simulate

__all__ = ["InputSampleOf", "NominalMixin", "load_nominal_state", "neural_scales"]


class NominalMixin:
    """A nominal model simulated along the batch (each row on its own time grid), on the compiled fast path.

    A training window that starts inside a record needs the state there. An oscillator whose output is the
    position starts at the measured (y, ẏ) and every other state at rest; the first ``warmup`` samples are not
    scored while the rest forgets. With an encoder (``_setup_encoder(past)``, ``encoder.past`` of
    ``hybridhyst-train``) an MLP reads the ``past`` samples of (u, y) before the window (and the conditions) and
    adds its estimate to that start, every state scaled by its spread in a simulation of the first training
    batch, as subspace-encoder methods do (Beintema, Tóth, Schoukens, "Deep subspace encoders for nonlinear
    system identification", Automatica 156, 2023). Its last layer starts at zero: training starts from the
    plain start. Whole records (validation, test) start at rest as before: the encoder only serves training.
    Instead of the encoder, ``window_start="run"`` (``_setup_window_start``) starts every state but the measured
    ones where a simulation of the whole training record with the current weights has it at the window's start.
    """

    nominal: nn.Module

    @property
    def model(self):
        """The model that is simulated (the nominal here; a hybrid's augmented model in ``HybridModule``)."""
        return self.nominal

    def _setup_encoder(self, past: int = 0, hidden="2x32"):
        """An MLP encoder of each window's start state from the ``past`` samples before it (0: none)."""
        self.past, self.encoder = int(past), None
        if self.past < 0:
            raise ValueError(f"encoder.past must be >= 0 samples, got {past}")
        if not self.past:
            return
        S = self.model.state_dim
        if not S:
            raise ValueError(f"encoder.past={past}: model {self.nominal.name!r} has no state to estimate at a window's "
                             "start (a memoryless model); use encoder.past=0")
        self.encoder = build_net("mlp", 2 * self.past + len(self.network_conditions), S, hidden, activation="tanh",
                                 zero_last=True).double()
        self.register_buffer("state_scale", torch.zeros(S, dtype=torch.float64))  # from the first training batch

    def _setup_nominal(self, nominal, backend: str, method: str, substeps: int, trainable: bool):
        self.nominal = nominal
        self.sim = SimulationSettings(method=method, substeps=int(substeps), backend=backend)
        for p in self.nominal.parameters():
            p.requires_grad_(bool(trainable))

    def conditions(self, batch, rows: int | None = None) -> dict[str, torch.Tensor]:
        """The conditions of a batch for the simulator: ``(batch,)`` per condition, ``(batch, time)`` per control
        channel; with ``rows``, each repeated to ``rows`` (the controls only where they are not signals)."""
        cond = {name: batch["cond"][:, j].to(self.dtype) for j, name in enumerate(self.condition_names)}
        if rows is not None:
            reps = rows // batch["cond"].shape[0]
            cond = {k: v.repeat_interleave(reps) for k, v in cond.items()}
        elif self.control_names:
            cond.update({c: batch["controls"][..., j].to(self.dtype) for j, c in enumerate(self.control_names)})
        return cond

    def _setup_window_start(self, window_start: str = "rest"):
        """``window_start``: where a training window's states start other than the measured (y, ẏ) -- "rest"
        (or the encoder's estimate) or "run": where a simulation of the whole training record with the current
        weights has them at the window's first sample (``refresh_run_states``, every epoch)."""
        if window_start not in ("rest", "run"):
            raise ValueError(f"unknown window_start {window_start!r}; choose 'rest' or 'run'")
        if window_start == "run" and getattr(self, "encoder", None) is not None:
            raise ValueError("window_start=run sets each window's states from a run of the whole record; an encoder "
                             "(encoder.past > 0) estimates them instead: choose one")
        self.window_start = window_start
        self._run_states: list | None = None

    def refresh_run_states(self, dm=None) -> None:
        """The states along every whole training record of ``dm`` (the trainer's data module), simulated from
        rest with the current weights (``window_start="run"``); a training window then starts from them."""
        dm = self.trainer.datamodule if dm is None else dm
        whole = dm.whole("train")
        with torch.no_grad():  # a record's first window starts at rest, as the whole record does
            self._run_states = [self.simulate_nominal({key: v[None] for key, v in whole[k].items()},
                                                      return_states=True, model=self.model)[1][0]
                                for k in range(len(whole))]

    def on_train_epoch_start(self):
        if getattr(self, "window_start", "rest") == "run" and getattr(self, "lm", None) is None:  # (the
            # Levenberg-Marquardt stage simulates whole records: no window starts)
            self.refresh_run_states()

    def _initial_state(self, batch, model=None):
        """The state each row starts from: oscillators whose output is the position start a mid-record window at
        the measured (y, ẏ); with an encoder, its estimate is added wherever a window starts inside a record."""
        measured = isinstance(self.nominal, DrivenOscillator) and self.nominal.outputs[0] == "x"
        inside = batch["start"] > 0
        base = None
        if measured:
            y0 = batch["y0"].to(self.dtype)
            base = torch.where(inside[:, None], y0, torch.zeros_like(y0))
        model = self.model if model is None else model
        run = getattr(self, "_run_states", None)
        if run is not None and model is self.model and self.training and bool(inside.any()):
            B = batch["t"].shape[0]
            s0 = model.initial_state(model.evaluate(self.conditions(batch), B), B, base=base)
            run = torch.stack([run[int(i)][int(s)] for i, s in zip(batch["index"], batch["start"])])
            k = base.shape[1] if base is not None else 0  # the measured coordinates stay measured
            s0 = s0.clone()
            s0[:, k:] = torch.where(inside[:, None], run[:, k:].to(s0), s0[:, k:])
            return s0
        if getattr(self, "encoder", None) is None or model is not self.model or not bool(inside.any()):
            return base  # the encoder estimates the simulated model's states (not the bare nominal's of a hybrid)
        B = batch["t"].shape[0]
        s0 = model.initial_state(model.evaluate(self.conditions(batch), B), B, base=base)
        if not bool((self.state_scale > 0).all()):
            self._fit_state_scale(batch, model, s0)
        past = batch["past"].to(self.dtype)
        feats = [self.norm.scale("u", past[..., 0]), self.norm.scale("y", past[..., 1])]
        feats += [(c if c.ndim == 1 else c[:, 0])[:, None] for c in self.condition_features(batch)]  # (controls: at
        # the window's start)
        offset = self.encoder(torch.cat(feats, dim=1)) * self.state_scale
        return s0 + torch.where(inside[:, None], offset, torch.zeros_like(offset))

    def _fit_state_scale(self, batch, model, s0):
        """Each state's spread along the batch, simulated from the plain start (1 where a state stays put: the
        network's latent states, dimensionless by design)."""
        U, t = self.sim_inputs(batch)
        with torch.no_grad():
            _, states = simulate(model, U, t=t, conditions=self.conditions(batch), initial_state=s0,
                                 return_states=True, settings=self.sim)
        sd = states.reshape(-1, states.shape[-1]).std(0)
        self.state_scale.copy_(torch.where(torch.isfinite(sd) & (sd > 1e-12), sd, torch.ones_like(sd)))

    def sim_inputs(self, batch) -> tuple[torch.Tensor, torch.Tensor]:
        """The simulator's input ``(batch, time, 3)`` (u, u̇, ü) and each row's times from its start."""
        t = (batch["t"] - batch["t"][:, :1]).to(self.dtype)
        return torch.stack([batch["u"], batch["du"], batch["ddu"]], dim=-1).to(self.dtype), t

    def simulate_nominal(self, batch, return_states: bool = False, model=None):
        """Nominal response ``(batch, time)`` (and states ``(batch, time, S)``) along each row's input; ``model``
        simulates another model with the nominal's structure instead (a hybrid's augmented model)."""
        U, t = self.sim_inputs(batch)
        model = self.nominal if model is None else model
        res = simulate(model, U, t=t, conditions=self.conditions(batch),
                       initial_state=self._initial_state(batch, model), return_states=return_states, settings=self.sim)
        return (res[0][..., 0], res[1]) if return_states else res[..., 0]

    def nominal_values(self) -> dict[str, float]:
        """Nominal parameters in their units: ``{"effect.param": value}`` for constants, and for parameters
        that are functions of a condition their value at each training condition,
        ``{"effect.param@pressure_mpa=0.03": value}`` (trajectories, TensorBoard, metrics.json)."""
        out, varying = {}, []
        for e, params in self.nominal.parameter_table().items():
            fns = self.nominal.effects[e].params if e in self.nominal.effects else self.nominal.structure_params
            for p, info in params.items():
                fn = fns[p]
                if isinstance(info["value"], (int, float)):
                    out[f"{e}.{p}"] = float(info["value"])
                elif fn.condition in self.control_names:  # a function of a control: its coefficients
                    out.update({f"{e}.{p}{c.suffix}": c.value for c in fn.coordinates()})
                else:
                    varying.append((e, p))
        levels = self._training_conditions()
        if varying and levels:
            with torch.no_grad():
                P = self.nominal.evaluate({k: torch.tensor([lv[k] for lv in levels], dtype=self.dtype)
                                           for k in levels[0]}, len(levels))
            for e, p in varying:
                for i, lv in enumerate(levels):
                    at = ",".join(f"{k}={v:g}" for k, v in lv.items())
                    out[f"{e}.{p}@{at}"] = float(P[e][p][i])
        return out

    def _training_conditions(self) -> list[dict[str, float]]:
        dm = getattr(getattr(self, "_trainer", None), "datamodule", None)
        if dm is None or not self.condition_names:
            return []
        rows = sorted({tuple(c) for c in dm.cond["train"]})
        return [dict(zip(self.condition_names, r)) for r in rows]

    def nominal_unit(self, key: str) -> str:
        """The unit of a ``nominal_values`` key (``"dahl.Fc"`` or ``"dahl.Fc@amplitude_in=1"``)."""
        effect, param = key.split("@")[0].split(".", 1)
        return self.nominal.parameter_table().get(effect, {}).get(param, {}).get("unit", "")

    def on_train_batch_end(self, outputs, batch, batch_idx):
        from ..physics.parameters import project_to_bounds

        project_to_bounds(self.nominal)  # amplitudes stored unconstrained stay inside their bounds

    def on_train_epoch_end(self):
        values = self.nominal_values()
        self.history.append({"epoch": self.epoch_offset + int(self.current_epoch), **values})
        for key, v in values.items():
            self.log(f"phys/{key} [{self.nominal_unit(key)}]", v)

    def flat(self, batch, detach: bool = True, model=None):
        """Masked collocation rows: inputs, times and the nominal's parameter values ``(N,)``; ``detach``
        makes the parameters constants (the hybrid: λ_phys regularises the branch, the data loss trains the
        nominal) or keeps them trainable (the standard PINN identifies the nominal through the residual);
        ``model``: another model's values (a hybrid's augmented model) instead of the nominal's."""
        m = batch["mask"].reshape(-1) > 0
        B, T = batch["u"].shape
        rows = {k: batch[k].reshape(-1)[m].to(self.dtype) for k in ("t", "u", "du", "ddu", "dddu")}
        cond = {k: (v.reshape(-1) if v.ndim == 2 else v.repeat_interleave(T))[m]
                for k, v in self.conditions(batch).items()}
        P = (self.nominal if model is None else model).evaluate(cond, int(m.sum()))
        if detach:
            P = {e: {n: v.detach() for n, v in ps.items()} for e, ps in P.items()}
        return m, rows, P


def neural_scales(nominal, norm: Normaliser) -> dict[str, float]:
    """Scales of a network inside ``nominal``'s dynamics, from the training data's standard deviations: the
    displacement and velocity the effects see, and a force. A damper law: the excitation, its rate and the
    response. An oscillator: the response (or the input) as displacement, the input's characteristic angular
    frequency ω = sd(u̇)/sd(u) for the velocity, the drive |g|·sd(u) (force drive) or m·sd(ü) (base motion)
    for the force."""
    sd = norm.sd
    if not isinstance(nominal, DrivenOscillator):
        return {"x": sd["u"], "v": sd["du"], "u": sd["u"], "du": sd["du"], "F": sd["y"]}
    sx = sd["y"] if nominal.outputs[0] == "x" else sd["u"]
    omega = sd["du"] / sd["u"]
    try:
        with torch.no_grad():
            P = nominal.evaluate(None, 1)["structure"]
        gain, mass = abs(float(P["drive_gain"][0].detach())), float(P["mass"][0].detach())
    except (ValueError, KeyError, TypeError):  # structure parameters that are functions of a condition
        gain, mass = 1.0, 1.0
    force = gain * sd["u"] if nominal.excitation == "force" else mass * sd["ddu"]
    return {"x": sx, "v": sx * omega, "u": sd["u"], "du": sd["du"], "F": max(force, 1e-300)}


def InputSampleOf(rows):  # noqa: N802 - reads like the class it builds
    from ..physics.models import InputSample

    return InputSample(u=rows["u"], du=rows["du"], ddu=rows["ddu"])


def _col(inp):
    from ..physics.models import InputSample

    return InputSample(u=inp.u[:, None], du=inp.du[:, None], ddu=inp.ddu[:, None])


def _flat_cond(batch, m):
    T = batch["u"].shape[1]
    return batch["cond"].repeat_interleave(T, dim=0)[m]


def _flat_controls(batch, m):
    """The control channels at the masked collocation rows, ``(rows, 1, C)`` (each row a one-sample window)."""
    c = batch["controls"]
    return c.reshape(c.shape[0] * c.shape[1], c.shape[-1])[m][:, None, :]


def load_nominal_state(path) -> dict:
    """A nominal's state dict from a ``model.pt`` or a run directory holding one (``hybridhyst-identify``,
    ``hybridhyst-train``): tensors only (``files.load_weights``), and from a run directory only when its run
    finished (``runs.require_complete``)."""
    from pathlib import Path

    from ..files import load_weights
    from ..runs import is_run_dir, require_complete

    p = Path(path)
    if p.is_dir():
        p = p / "model.pt"
    if not p.exists():
        raise FileNotFoundError(f"nominal state {p} not found; give a model.pt or a run directory holding one")
    if is_run_dir(p.parent):  # a run killed while writing leaves a model.pt that belongs to no finished result
        require_complete(p.parent, f"the nominal state {p.name}", p.name)
    return load_weights(p)
