"""Lightning modules sharing one data and metric interface.

Every module maps a batch of ``RecordDataModule`` (training windows or whole records) to a predicted
response ``(batch, time)`` in physical units; ``base.SequenceModule`` owns the losses, logging and
optimiser:

- ``PhysicsModule``  — the nominal model alone, identified by gradient (seed 000's recipe available:
  positive parameters re-initialised near zero, MAE + λ·|p − p_init|).
- ``HybridModule``   — nominal + parallel residual branch (MLP on normalised t, x, ẋ, conditions with a
  zero-initialised last layer, or LSTM), optionally starting from an identified nominal (seed 003).
- ``MLPModule``, ``LSTMModule``, ``StdPINNModule`` — the baselines (``baselines.py``).

``λ_phys`` (``lambda_phys``) weighs the physics residual (``training.losses``) against the data loss
(``w_data = 1``); data-only modules ignore it.
"""

from __future__ import annotations

import warnings

import torch
from torch.nn.utils import parametrize

from ..nets import build_net
from ..physics.effects import NeuralEffect
from ..physics.models import DrivenOscillator
from .base import SequenceModule
from .baselines import LSTMModule, MLPModule, StdPINNModule
from .losses import constant_values, hybrid_physics_residual, parameter_prior, taylor_inputs
from .nominal import InputSampleOf, NominalMixin, _col, _flat_cond, _flat_controls, load_nominal_state, neural_scales

NEURAL = "neural"  # the key of the dynamics network among the augmented model's effects

__all__ = ["HybridModule", "LSTMModule", "MLPModule", "MODULES", "PhysicsModule", "SequenceModule", "StdPINNModule",
           "load_nominal_state"]


class PhysicsModule(NominalMixin, SequenceModule):
    """The nominal model alone, trained by gradient through the simulator.

    Parameters
    ----------
    nominal : the nominal model (``NominalModel``); its parameters are the trainable ones.
    init_noise : seed 000's recipe: re-initialise every positive (or nonnegative) constant parameter at
        max(N(0, init_noise), 1e-6) in its physical units, i.e. raw = softplus⁻¹ of that, near zero,
        before training; None keeps the given values.
    prior_weight, prior_kind : ``prior_weight · Σ|p − p_init|`` over the physical values ("l1", seed 000)
        or squared ("l2").
    backend, method, substeps : simulator settings.
    encoder_past, encoder_hidden : an MLP encoder of each training window's start state from the
        ``encoder_past`` samples of (u, y) before it (``NominalMixin``); 0: none.
    """

    kind = "physics"

    def __init__(self, nominal, normaliser: dict, init_noise: float | None = None, prior_weight: float = 0.0,
                 prior_kind: str = "l1", backend: str = "fast", method: str = "rk4", substeps: int = 1,
                 encoder_past: int = 0, encoder_hidden="2x32", window_start: str = "rest", **kw):
        super().__init__(normaliser, **kw)
        self._setup_nominal(nominal, backend, method, substeps, trainable=True)
        self._setup_encoder(encoder_past, encoder_hidden)
        self._setup_window_start(window_start)
        if init_noise:
            self._reinitialise(float(init_noise))
        self.prior_weight, self.prior_kind = float(prior_weight), prior_kind
        self.initial = {k: v.detach().clone() for k, v in constant_values(self.nominal).items()}

    def _reinitialise(self, sd: float):
        from ..physics.parameters import Constant

        g = torch.Generator().manual_seed(int(torch.initial_seed()) % (2**31))
        with torch.no_grad():
            for effect in self.nominal.effects.values():
                for pname, fn in effect.params.items():
                    spec = effect.param_specs[pname]
                    if isinstance(fn, Constant) and spec.constraint in ("positive", "nonnegative"):
                        v = max(float(torch.randn((), generator=g, dtype=torch.float64)) * sd, 1e-6)
                        value = torch.tensor(v, dtype=fn.value.dtype)
                        if parametrize.is_parametrized(fn, "value"):
                            fn.value = value  # softplus: raw = softplus⁻¹(v) (right_inverse)
                        else:
                            fn.value.copy_(value)

    def forward(self, batch):
        y = self.simulate_nominal(batch)
        return {"y": y, "nominal": y}

    def prior_loss(self):
        if not self.prior_weight:
            return None
        return parameter_prior(self.nominal, self.initial, self.prior_weight, self.prior_kind)


class HybridModule(NominalMixin, SequenceModule):
    """Nominal physics plus a network, placed on the output or inside the dynamics.

    * ``placement="output"``: a parallel residual branch, ``ŷ = y_nom + sd_y · N(features)`` (seed 003).
    * ``placement="dynamics"``: a ``NeuralEffect`` inside the nominal's equations — a force ``F_N(x, v, z,
      conditions)`` that enters the equation of motion (or the damper's force sum), with ``latent_states``
      states ``ż = N_z(...)`` of its own — so the correction lives where the system's memory lives. The
      nominal (``self.nominal``) stays the physical part: the augmented model shares its parameters.

    Both start exactly at the nominal (the network's last layer is zero).

    Parameters
    ----------
    nominal : the nominal model; nominal_state : optional path to a ``model.pt`` state dict (e.g. written
        by ``hybridhyst-identify``) or a run directory holding one, loaded into ``nominal`` first.
    freeze_nominal : keep the nominal's parameters fixed (seed 003 trains the residual only).
    residual : "mlp" (pointwise, last layer zero-initialised) or "lstm" (output placement only); hidden :
        "4x128" etc.; activation : MLP activation (tanh as seed 003).
    placement : "output" or "dynamics"; latent_states : the dynamics network's latent states (≥ 0);
        dynamics_inputs : what that network reads besides its latent states and the conditions, among "x", "v"
        (the coordinates the nominal's effects act on), "u", "du" (the raw input and its rate). A network that
        reads v adds damping of its own: in a model whose mass is only a regulariser (the quasi-static piezo
        model of seed 003) that can make the fixed-step integration unstable (there 3 of 3 seeds diverged with
        ("x", "v"), none with ("x", "u")). latent_form : how the latent states change, "free" (with time) or
        "duhem" (with the travel, ż = (v / s_x) · N_z; ``NeuralEffect``).
    encoder_past, encoder_hidden : an MLP encoder of each training window's start state (the simulated model's:
        with ``placement="dynamics"`` the latent states included) from the ``encoder_past`` samples of (u, y)
        before it (``NominalMixin``); 0: none.
    """

    kind = "hybrid"

    def __init__(self, nominal, normaliser: dict, residual: str = "mlp", hidden="4x128", activation: str = "tanh",
                 freeze_nominal: bool = False, nominal_state: str | None = None, backend: str = "fast",
                 method: str = "rk4", substeps: int = 1, placement: str = "output", latent_states: int = 0,
                 dynamics_inputs=("x", "v"), latent_form: str = "free", encoder_past: int = 0,
                 encoder_hidden="2x32", window_start: str = "rest", **kw):
        super().__init__(normaliser, **kw)
        if placement not in ("output", "dynamics"):
            raise ValueError(f"unknown placement {placement!r}; choose 'output' or 'dynamics'")
        if placement == "dynamics" and residual != "mlp":
            raise ValueError("placement=dynamics evaluates the network at every instant inside the state equation: "
                             f"use residual=mlp (latent_states give it memory), not {residual!r}")
        if placement == "output" and int(latent_states):
            raise ValueError("latent_states belong to placement=dynamics; the output branch has none")
        dynamics_inputs = tuple(dynamics_inputs)
        if placement == "output" and dynamics_inputs != ("x", "v"):
            raise ValueError("dynamics_inputs belong to placement=dynamics; the output branch reads `features`")
        self.placement, self.latent_states = placement, int(latent_states)
        if nominal_state:
            nominal.load_state_dict(load_nominal_state(nominal_state))
        self._setup_nominal(nominal, backend, method, substeps, trainable=not freeze_nominal)
        self.residual_kind = residual
        if placement == "dynamics":
            conditions = {c: (self.norm.mean[c], self.norm.sd[c]) for c in self.network_conditions}
            self.net = NeuralEffect(dynamics_inputs, self.latent_states, hidden, activation,
                                    scales=neural_scales(nominal, self.norm), conditions=conditions,
                                    latent_form=latent_form)
            self.__dict__["_augmented"] = nominal.augmented({NEURAL: self.net})  # not a submodule: its parameters
        else:  # are registered as the nominal's and the net's
            self.net = build_net(residual, self.n_features, 1, hidden, activation=activation, zero_last=True)
            if residual == "lstm" and self.lambda_phys > 0 and isinstance(nominal, DrivenOscillator):
                raise ValueError("the physics residual of an oscillator needs pointwise time derivatives of the "
                                 "residual branch; use residual=mlp, or lambda_phys=0 with an LSTM branch")
        self._setup_encoder(encoder_past, encoder_hidden)
        self._setup_window_start(window_start)
        if window_start == "run" and self.latent_states and latent_form == "free":
            warnings.warn("window_start=run with latent_form=free: latent states that change with time can drift "
                          "over a whole record, and windows then start where the network saturates (on the Bouc-Wen "
                          "benchmark such a run's latent state drifted far out of range and it learned nothing); "
                          "latent_form=duhem keeps them still where the motion is", UserWarning, stacklevel=2)

    @property
    def model(self):
        """The model that is simulated: the nominal, or the nominal augmented with the network."""
        return self.__dict__.get("_augmented", self.nominal)

    def forward(self, batch):
        need_states = self.lambda_phys > 0 and self.training
        if self.placement == "dynamics":
            res = self.simulate_nominal(batch, return_states=need_states, model=self.model)
            y, states = res if need_states else (res, None)
            y_nom = None if self.training else self.simulate_nominal(batch)
            return {"y": y, "nominal": y_nom, "states": states}
        res = self.simulate_nominal(batch, return_states=need_states)
        y_nom, states = res if need_states else (res, None)
        r = self.net(self.features(batch))[..., 0] * self.y_scale
        out = {"y": y_nom + r, "nominal": y_nom}
        if states is not None:
            out["states"] = states
        return out

    def branch_at_offsets(self, batch, m, rows):
        """The residual branch at the collocation rows as a function of a time offset τ (zero-valued leaf):
        returns (τ, the Taylor-expanded inputs, r(τ) in response units). d/dτ of r is its total time
        derivative along the measured excitation."""
        tau = torch.zeros_like(rows["t"], requires_grad=True)
        inp = taylor_inputs(rows["u"], rows["du"], rows["ddu"], tau, rows["dddu"])
        one = {k: v[:, None] for k, v in rows.items()}
        feats = self.features({**one, "cond": _flat_cond(batch, m), "controls": _flat_controls(batch, m)},
                              inputs=_col(inp), t=(rows["t"] + tau)[:, None])
        return tau, inp, self.net(feats)[:, 0, 0] * self.y_scale

    def physics_loss(self, batch, out):
        if self.placement == "dynamics":  # the network's force is how far the hybrid departs from the nominal
            m, rows, P = self.flat(batch, detach=False, model=self.model)
            S = out["states"].reshape(-1, out["states"].shape[-1])[m].to(self.dtype)
            force = self.model.effect_forces(S, InputSampleOf(rows), P)[NEURAL]
            return (force / self.net.force_scale).square().mean()
        m, rows, P = self.flat(batch)
        S = out["states"].reshape(-1, out["states"].shape[-1])[m].to(self.dtype).detach()
        if self.residual_kind == "lstm":  # constitutive: the residual is the branch's own correction
            r = (out["y"] - out["nominal"]).reshape(-1)[m]
            return (r / self.y_scale).square().mean()
        tau, inp, r = self.branch_at_offsets(batch, m, rows)
        y_nom = out["nominal"].reshape(-1)[m].detach()
        if isinstance(self.nominal, DrivenOscillator) and self.nominal.outputs[0] == "x":
            with torch.no_grad():  # the nominal trajectory around each point: x + ẋ τ + ẍ τ²/2
                acc = self.nominal.derivative(S, InputSampleOf(rows), P)[:, 1]
            y = y_nom + S[:, 1] * tau + 0.5 * acc * tau.square() + r
            accel_scale = float(acc.std().clamp_min(1e-12))
        else:
            y, accel_scale = y_nom + r, 1.0
        return hybrid_physics_residual(self.nominal, P, S, y, inp, tau, self.y_scale, accel_scale)


MODULES = {"physics": PhysicsModule, "hybrid": HybridModule, "mlp": MLPModule, "lstm": LSTMModule,
           "std_pinn": StdPINNModule}
