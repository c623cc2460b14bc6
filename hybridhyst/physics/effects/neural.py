"""Neural effect: a network as one term of a nominal model (a force, and optionally latent states).

The network lives where the memory of a hysteretic system lives — inside the state equation — instead of
being added to the model's output. In a ``DrivenOscillator`` its force enters the equation of motion
(m ẍ + Σ F_e + F_N = g u), so it changes the trajectory; its latent states give it a memory of its own
(a hysteretic state, a friction state) that a pointwise correction of the output cannot have.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import torch

from ...nets import build_net, parse_hidden
from ..parameters import ParameterSpec
from .base import Effect, Kinematics, signals

__all__ = ["NeuralEffect"]

_INPUTS = ("x", "v", "u", "du")
_FORMS = ("free", "duhem")


class NeuralEffect(Effect):
    """A force ``F = s_F · N(x, v, z, c)`` with latent states ``ż = ω_s · N_z(x, v, z, c)`` (``latent_form="free"``)
    or ``ż = (v / s_x) · N_z(x, v, z, c)`` (``"duhem"``).

    Inputs are normalised by the data's scales: x/s_x, v/s_v (and u/s_u, du/s_du when listed), each latent
    state z (dimensionless, starts at 0) and each condition c as (c − mean)/sd. One MLP gives the force and
    the latent rates; its last layer starts at zero, so a model with this effect starts exactly at its
    nominal (F = 0, ż = 0) and training moves it from there.

    Parameters
    ----------
    inputs : kinematic inputs among "x", "v" (what the effect acts on: the excitation of a ``Constitutive``
        model, the relative or absolute coordinate of a ``DrivenOscillator``), "u", "du" (the raw input).
    latent_states : number of latent states z (0: a memoryless force).
    latent_form : "free" — the latent states change with time at the network's rate; "duhem" — with the
        travel: the network gives dz/dx per scale s_x of travel, multiplied by the velocity, as in Duhem's
        form of a hysteresis operator (Bouc–Wen, Dahl, LuGre without viscosity are of it). The states then stand
        still when the motion does, and a sign change of the velocity, which the network can only smooth, is
        multiplied by a velocity near zero.
    hidden, activation : MLP widths ("2x32" or a list) and activation.
    scales : {"x", "v", "u", "du", "F": scale} in the model's units: s_F [F] sets the force unit, ω_s =
        s_v / s_x [1/t] the latent states' rate unit. Missing ones are 1.
    conditions : {name: (mean, sd)} of the operating conditions the network reads (empty: none).

    Units: no physical parameters; the weights are trained (``hybridhyst-train placement=dynamics``, or
    through the simulator by the discovery loop's leftover measure, ``discover.leftover=dynamics``) and are
    not coordinates of ``identify``'s search. Shapes: ``(batch,)`` per instant; state ``(batch,
    latent_states)``. Both backends run it: on the compiled fast path the network is a generated C
    kernel whose weights are coordinates of the exact discrete adjoint (``simulate.fast``), on the
    reference loop it is the torch module (in the weights' dtype; the compiled path computes in float64).
    The scales and condition statistics are constants of the generated code: changing them (a state dict)
    rebuilds it on the next call.
    Source: universal differential equations (Rackauckas et al., arXiv:2001.04385, 2020); model
    augmentation (Beintema, Schoukens, Tóth, "Deep subspace encoders for nonlinear system identification",
    Automatica 156, 2023).
    """

    name = "neural"
    discovery_candidate = False  # names no physical effect (the loop measures what is left with its own network)
    state_dim = 0
    equation = ("F = s_F N(x/s_x, v/s_v, z, c);  dz/dt = (s_v/s_x) N_z(x/s_x, v/s_v, z, c) (free) or "
                "(v/s_x) N_z(x/s_x, v/s_v, z, c) (duhem)")
    source = "Rackauckas et al. 2020 (universal differential equations); Beintema et al. 2023"
    specs: ClassVar[dict[str, ParameterSpec]] = {}

    def __init__(self, inputs: Sequence[str] = ("x", "v"), latent_states: int = 0, hidden="2x32",
                 activation: str = "tanh", scales: Mapping[str, float] | None = None,
                 conditions: Mapping[str, Sequence[float]] | None = None, latent_form: str = "free"):
        super().__init__()
        if latent_form not in _FORMS:
            raise ValueError(f"neural effect: unknown latent_form {latent_form!r}; choose from {_FORMS}")
        if latent_form == "duhem" and not {"x", "v"} & set(inputs):
            raise ValueError("neural effect: latent_form='duhem' measures travel in the scale of x; give 'x' or 'v' "
                             "among the inputs")
        bad = [i for i in inputs if i not in _INPUTS]
        if bad or not inputs:
            raise ValueError(f"neural effect: unknown input(s) {bad}; choose from {_INPUTS}")
        if int(latent_states) < 0:
            raise ValueError(f"neural effect: latent_states must be >= 0, got {latent_states}")
        scales = dict(scales or {})
        unknown = set(scales) - {*_INPUTS, "F"}
        if unknown:
            raise ValueError(f"neural effect: unknown scale(s) {sorted(unknown)}; give x, v, u, du and F")
        for key, value in scales.items():
            if not float(value) > 0:
                raise ValueError(f"neural effect: scale {key!r} must be > 0, got {value}")
        self._options = {"inputs": list(inputs), "latent_states": int(latent_states), "hidden": parse_hidden(hidden),
                         "activation": activation, "scales": {k: float(v) for k, v in scales.items()},
                         "conditions": {c: [float(m), float(sd)] for c, (m, sd) in (conditions or {}).items()},
                         "latent_form": latent_form}
        self.latent_form = latent_form
        self.inputs = tuple(inputs)
        self.state_dim = int(latent_states)  # per instance: the model lays out its states from it
        self.condition_names = tuple(conditions or {})
        s = {k: float(scales.get(k, 1.0)) for k in (*_INPUTS, "F")}
        self.register_buffer("input_scale", torch.tensor([s[k] for k in self.inputs], dtype=torch.float64))
        self.register_buffer("force_scale", torch.tensor(s["F"], dtype=torch.float64))
        self.register_buffer("rate_scale", torch.tensor(s["v"] / s["x"], dtype=torch.float64))
        cond = [tuple(map(float, (conditions or {})[c])) for c in self.condition_names]
        self.register_buffer("condition_mean", torch.tensor([c[0] for c in cond], dtype=torch.float64))
        self.register_buffer("condition_sd", torch.tensor([c[1] if c[1] > 0 else 1.0 for c in cond],
                                                          dtype=torch.float64))
        n_in = len(self.inputs) + self.state_dim + len(self.condition_names)
        self.net = build_net("mlp", n_in, 1 + self.state_dim, hidden, activation=activation, zero_last=True)
        self._last: tuple | None = None

    def options(self) -> dict:
        """The network's form; its weights are in the model's state dict (``model.pt``). Scales and condition
        normalisation are read from the buffers (a state dict loaded after construction sets them)."""
        options = {**self._options, "scales": dict(self._options["scales"])}
        scales = options["scales"]
        scales.update({k: float(v) for k, v in zip(self.inputs, self.input_scale.tolist())})
        scales["F"] = float(self.force_scale)
        rate = float(self.rate_scale)  # s_v / s_x: gives the one of x, v that is not an input from the other
        if "x" in self.inputs and "v" not in self.inputs:
            scales["v"] = rate * scales["x"]
        elif "v" in self.inputs and "x" not in self.inputs:
            scales["x"] = scales["v"] / rate
        options["conditions"] = {c: [float(m), float(sd)] for c, m, sd in
                                 zip(self.condition_names, self.condition_mean.tolist(), self.condition_sd.tolist())}
        return options

    def value_names(self, controls=()) -> list[str]:
        return [f"@{c}" for c in self.condition_names if c not in controls]

    # conditions reach the force and rate like parameter values: normalised, one (batch,) tensor each
    def evaluate(self, conditions, batch):
        if not self.condition_names:
            return {}
        missing = [c for c in self.condition_names if not conditions or c not in conditions]
        if missing:
            raise ValueError(f"the neural effect reads condition(s) {missing}; give them to simulate (conditions=)")
        follow = signals(conditions)  # a control signal is read at every instant (features)
        return {f"@{c}": (conditions[c] - self.condition_mean[j]) / self.condition_sd[j]
                for j, c in enumerate(self.condition_names) if c not in follow}

    def features(self, p, kin: Kinematics, state) -> list:
        """The network's inputs at one instant, normalised: ``(batch,)`` tensors, or sympy expressions when
        the compiled path builds the model's equations."""
        symbolic = not isinstance(kin.x, torch.Tensor)
        channels = {"x": kin.x, "v": kin.v, "u": kin.u, "du": kin.du}
        scale = self.input_scale.tolist() if symbolic else self.input_scale
        cols = [channels[k] / scale[j] for j, k in enumerate(self.inputs)]
        cols += [state[:, j] for j in range(self.state_dim)]
        for j, c in enumerate(self.condition_names):
            if c in kin.controls:
                mean, sd = (self.condition_mean.tolist()[j], self.condition_sd.tolist()[j]) if symbolic else \
                    (self.condition_mean[j], self.condition_sd[j])
                cols.append((kin.controls[c] - mean) / sd)
                continue
            if f"@{c}" not in p:
                raise ValueError(f"the neural effect reads condition {c!r}; simulate with conditions=, not values=")
            cols.append(p[f"@{c}"])
        return cols

    def travel_scale(self):
        """s_x from the buffers (a loaded state dict sets them): x's input scale, or v's over ω_s."""
        if "x" in self.inputs:
            return self.input_scale[self.inputs.index("x")]
        return self.input_scale[self.inputs.index("v")] / self.rate_scale

    def terms(self, outputs, kin: Kinematics) -> tuple:
        """(force, [latent rates]) from the network's output columns (tensors or symbols) at ``kin``."""
        if isinstance(outputs, torch.Tensor):
            rate = self.rate_scale if self.latent_form == "free" else (kin.v / self.travel_scale())[:, None]
            return self.force_scale * outputs[:, 0], rate * outputs[:, 1:]
        rate = float(self.rate_scale) if self.latent_form == "free" else kin.v / float(self.travel_scale())
        return float(self.force_scale) * outputs[0], [rate * o for o in outputs[1:]]

    def _outputs(self, p, kin: Kinematics, state):
        """Network outputs ``(batch, 1 + latent)`` at one instant (cached for the rate-then-force pair)."""
        last = self._last
        if last is not None and last[0] is kin and last[1] is state:
            return last[2]
        feats = torch.stack(self.features(p, kin, state), dim=1)
        out = self.net(feats.to(self.net.head.weight.dtype)).to(kin.x.dtype)
        self._last = (kin, state, out)
        return out

    def initial_state(self, p, batch, controls=None):
        ref = self.force_scale
        return torch.zeros(batch, self.state_dim, dtype=ref.dtype, device=ref.device)

    def rate(self, p, kin: Kinematics, state):
        return self.terms(self._outputs(p, kin, state), kin)[1]

    def force(self, p, kin: Kinematics, state):
        return self.terms(self._outputs(p, kin, state), kin)[0]

    def extra_repr(self) -> str:
        return (f"inputs={self.inputs}, latent_states={self.state_dim}, latent_form={self.latent_form}, "
                f"conditions={self.condition_names}")
