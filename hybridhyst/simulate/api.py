"""``simulate``: the one entry point for integrating a nominal model over time."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

import numpy as np
import torch

from ..physics.effects.base import signals
from .adaptive import integrate_adaptive
from .fixed import integrate_fixed
from .inputs import delayed, input_sample, with_controls, with_rates
from .settings import SimulationSettings

__all__ = ["REFERENCE", "Prepared", "coarsest_substeps", "jacobian_covers", "resolved_substeps", "row_jacobian",
           "simulate", "simulate_jacobian", "simulate_resolved"]

# simulate()'s settings where none are given: the plain PyTorch loop (the oracle), the solver's default scheme
REFERENCE = SimulationSettings(method=None, backend="reference")

RESOLVED = 1e-3  # relative RMS change of the response under halved steps below which it counts as resolved
MAX_SUBSTEPS_SCORED = 64  # simulate_resolved's cap: scoring costs one simulation per doubling, a fit hundreds


def _model_dtype(model) -> torch.dtype:
    for p in model.parameters():
        return p.dtype
    for b in model.buffers():
        return b.dtype
    return torch.get_default_dtype()


def _as_conditions(conditions, batch: int, dtype, device, time: int | None = None) -> dict[str, torch.Tensor] | None:
    """Numeric conditions as tensors: ``(batch,)`` for one value per row, ``(batch, time)`` for a control channel
    (a signal sampled with the input)."""
    if conditions is None:
        return None
    out = {}
    for key, value in dict(conditions).items():
        if isinstance(value, str) or (isinstance(value, (list, tuple, np.ndarray)) and len(value)
                                      and isinstance(np.asarray(value).flat[0], str)):
            continue  # categorical conditions (e.g. kind) are not model inputs
        v = torch.as_tensor(np.asarray(value, dtype=np.float64) if not torch.is_tensor(value) else value,
                            dtype=dtype, device=device)
        if v.ndim == 0:
            v = v.expand(batch)
        if v.ndim == 2 and time is not None and v.shape[1] == time:
            v = v.expand(batch, -1)
            if not _all_finite(v):
                raise ValueError(f"control {key!r} contains NaN/inf; clean the control channel first")
        elif v.shape != (batch,):
            raise ValueError(
                f"condition {key!r} has shape {tuple(v.shape)}; give a scalar, one value per batch row ({batch}) or, "
                f"for a control channel, one value per row and sample ({batch}, {time})"
            )
        out[key] = v
    return out


def _check_values(model, values, batch: int, conditions=None):
    """Validate explicit per-row parameter values against the model's parameter names (a parameter that follows
    a control channel: its function's coordinates, ``Effect.value_names``); an effect without parameters (a
    network) evaluates its own inputs from the conditions."""
    out = {}
    expected = model.value_names(signals(conditions))
    for key in list(model.effects) + ["structure"]:
        if key != "structure" and not model.effects[key].params and key not in values:
            out[key] = model.effects[key].evaluate(conditions, batch)
            continue
        given = values.get(key, {})
        names = expected[key]
        missing = [n for n in names if n not in given]
        if missing:
            raise ValueError(f"values for {key!r} miss parameter(s) {missing}")
        out[key] = {}
        for n in names:
            v = torch.as_tensor(given[n])
            v = v.expand(batch) if v.ndim == 0 else v
            if v.shape != (batch,):
                raise ValueError(f"values[{key!r}][{n!r}] has shape {tuple(v.shape)}; expected ({batch},)")
            out[key][n] = v
    return out


def _simulate_records(model, records, input_channels, **kwargs) -> list[torch.Tensor]:
    """Records of one length as one batch each (every row on its own time grid); one ``(time, output_dim)``
    per record."""
    from ..data.batch import record_batches
    from ..data.records import Record, RecordSet

    if isinstance(records, Record):
        records = [records]
    records = list(records.records if isinstance(records, RecordSet) else records)
    out: list[torch.Tensor | None] = [None] * len(records)
    for batch in record_batches(records, input_channels, _model_dtype(model)):
        ys = simulate(model, batch.inputs, t=batch.t, conditions=batch.conditions, **kwargs)
        for j, i in enumerate(batch.index):
            out[i] = ys[j]
    return out


def simulate(model, inputs, t=None, *, dt: float | None = None, conditions=None, initial_state=None,
             settings: SimulationSettings | None = None, method: str | None = None, substeps: int | None = None,
             solver: str | None = None, rtol: float | None = None, atol: float | None = None,
             backend: str | None = None, adjoint: bool = False, options: dict | None = None,
             return_states: bool = False, input_channels: tuple[str, ...] = ("x",), values=None):
    """Integrate ``model`` along an input history.

    Parameters
    ----------
    model : ``Constitutive`` or ``DrivenOscillator`` (any ``NominalModel``).
    inputs : tensor/array ``(batch, time)`` or ``(batch, time, C)`` with C = 1 (u), 2 (u, u̇) or
        3 (u, u̇, ü); missing rates are finite differences. Or a ``Record``, a ``RecordSet`` or a list
        of records: then ``t`` and ``conditions`` come from the records, ``input_channels`` names the
        channels used (``"x"`` and extra channels such as ``"velocity"``), and the result is a list with
        one ``(time, output_dim)`` tensor per record.
    t : sample times [s], strictly increasing: ``(time,)`` shared by every row or ``(batch, time)``, one grid
        per row (records with their own timestamps); or give ``dt`` for a uniform grid from 0.
    conditions : {name: scalar or (batch,)} operating conditions for parameter functions, or ``(batch, time)`` for a
        control channel sampled with the input (``Record.controls``): it is interpolated inside the sample
        intervals like the input, and a parameter function of it is evaluated at every stage.
    initial_state : ``(batch, 2)`` initial [x, ẋ] of an oscillator, or the full ``(batch, state_dim)``.
    settings : how to integrate (``SimulationSettings``: scheme, sub-steps, backend, solver, tolerances, device);
        default ``REFERENCE`` (the plain PyTorch loop). The keyword arguments below, where given, override it.
    method, substeps : fixed-step explicit scheme ("euler", "heun", "midpoint", "rk4"; default "rk4") and
        sub-steps per sample interval (``solver="fixed"``); for ``solver="torchdiffeq"`` the torchdiffeq
        method (default "dopri5") with ``rtol``, ``atol``, ``options`` and ``adjoint``. The input is
        linearly interpolated inside each sample interval, so for a driven model the scheme is second
        order in the sample interval whatever its own order; sub-steps refine the state, not the input.
    return_states : also return the states ``(batch, time, state_dim)``, differentiable on both backends.
    backend : "reference" (the plain PyTorch loop) or "fast" (a C loop generated and built per model, with an exact
        discrete adjoint, same values and gradients, networks included; ``hybridhyst.simulate.fast``); only for
        ``solver="fixed"``.
    values : parameter values per batch row, ``{effect: {parameter: (batch,)}}`` as returned by
        ``model.evaluate`` (the structure's under ``"structure"``); replaces the model's own values, so a
        population of parameter sets (identification) or restarts run as one batch.

    Returns
    -------
    ``(batch, time, output_dim)`` tensor (and the states), differentiable w.r.t. every model parameter.
    """
    from ..data.records import Record, RecordSet

    if isinstance(inputs, (Record, RecordSet)) or (isinstance(inputs, (list, tuple)) and inputs
                                                    and isinstance(inputs[0], Record)):
        if return_states:
            raise ValueError("return_states is not available when simulating records; pass tensors instead")
        return _simulate_records(model, inputs, input_channels, initial_state=initial_state, settings=settings,
                                 method=method, substeps=substeps, solver=solver, rtol=rtol, atol=atol,
                                 adjoint=adjoint, options=options, backend=backend)

    sim = SimulationSettings.of(settings, REFERENCE, method=method, substeps=substeps, solver=solver, rtol=rtol,
                                atol=atol, backend=backend)
    return Prepared(model, inputs, t, dt=dt, conditions=conditions, settings=sim).simulate(
        values, initial_state=initial_state, adjoint=adjoint, options=options, return_states=return_states)


class Prepared:
    """What ``simulate`` and ``simulate_jacobian`` do before they read the parameter values -- the inputs checked,
    their rates, the conditions and control channels -- done once for the simulations of many parameter sets on
    the same inputs (identification: every iteration of a fit simulates the same records).

    ``Prepared(model, inputs, t, dt=, conditions=, settings=)`` takes ``simulate``'s arguments (``settings``
    resolved: a ``SimulationSettings``); ``simulate(values, ...)`` and ``jacobian(values, ...)`` are then
    ``simulate``'s and ``simulate_jacobian``'s results for those inputs. ``rows(n)``: the same for the first ``n``
    batch rows (views: a population of any size simulated on inputs prepared for the largest)."""

    def __init__(self, model, inputs, t=None, *, dt: float | None = None, conditions=None,
                 settings: SimulationSettings):
        self.model, self.sim = model, settings
        self.dtype = _model_dtype(model)
        u, self.t = _prepare(inputs, t, dt, self.dtype, settings.device)
        self.batch, self.device = u.shape[0], u.device
        self.cond = _as_conditions(conditions, self.batch, self.dtype, u.device, u.shape[1])
        self.rates = with_rates(u, self.t)
        self.U, self.controls = with_controls(self.rates, self.cond)

    def rows(self, n: int) -> Prepared:
        """The first ``n`` rows (views of these inputs; a grid per row stays one, even where those rows share
        it: identification's slices are whole populations, each on every record's grid)."""
        out = copy.copy(self)
        out.batch, out.rates, out.U = n, self.rates[:n], self.U[:n]
        out.t = self.t[:n] if self.t.ndim == 2 else self.t
        out.cond = None if self.cond is None else {k: v[:n] for k, v in self.cond.items()}
        return out

    def _values(self, values):
        """Each row's parameter values: the model's own (``model.evaluate``) or the given ones, checked."""
        return (self.model.evaluate(self.cond, self.batch) if values is None
                else _check_values(self.model, values, self.batch, self.cond))

    def simulate(self, values=None, *, initial_state=None, adjoint: bool = False, options: dict | None = None,
                 return_states: bool = False):
        """``simulate``'s result for these inputs with ``values`` (None: the model's own)."""
        model, sim, t, cond = self.model, self.sim, self.t, self.cond
        method, substeps, solver, backend = sim.method, sim.substeps, sim.solver, sim.backend
        B = self.batch
        P = self._values(values)
        U, controls = self.U, self.controls
        tau = model.input_delay(P)
        if tau is not None:
            U, controls = with_controls(delayed(self.rates, t, tau), cond)
        state0 = _initial_state(model, P, B, initial_state, self.dtype, self.device, _first(cond, controls))

        if backend == "fast":
            from .fast import simulate_fast

            return simulate_fast(model, U, t, P, state0, method=method or "rk4", substeps=substeps,
                                 return_states=return_states, controls=controls)
        if solver == "fixed":
            states = integrate_fixed(model, U, t, P, state0, method=method or "rk4", substeps=substeps,
                                     controls=controls)
        elif solver == "torchdiffeq":
            if t.ndim != 1:
                raise ValueError("solver='torchdiffeq' integrates every row on one time grid; give t as (time,) or "
                                 "simulate records with different grids separately")
            if model.state_bounds(P) is not None:
                raise ValueError("solver='torchdiffeq' cannot project bounded states (the play operator of "
                                 "backlash); use solver='fixed'")
            if values is not None:
                raise ValueError("solver='torchdiffeq' evaluates the model's own parameters; values= needs "
                                 "solver='fixed'")
            states = integrate_adaptive(model, U, t, cond, state0, method=method or "dopri5", rtol=sim.rtol,
                                        atol=sim.atol, adjoint=adjoint, options=options, controls=controls)
        y = _outputs(model, states, U, P, controls)
        return (y, states) if return_states else y

    def jacobian(self, values: dict, *, initial_state=None, weights: bool = False, needed=None):
        """``simulate_jacobian``'s result for these inputs with ``values``. ``needed``: the parameters ``(effect,
        name)`` whose derivatives are wanted (None: every one); the others' columns are 0, and the loop does not
        carry them (identification asks for those of its free coordinates)."""
        from .fast.function import compiled, tangent_fast

        model, t, controls, dtype = self.model, self.t, self.controls, self.dtype
        B, device = self.batch, self.device
        P = self._values(values)
        eq = compiled(model, controls)[0]
        keys = list(eq.param_keys)
        first = _first(self.cond, controls)
        s0 = _initial_state(model, P, B, initial_state, dtype, device, first)
        start = None if initial_state is None else torch.as_tensor(initial_state, dtype=dtype, device=device)
        given = start is not None and _whole_state(model, start)  # held fixed; otherwise [x, v] under the effects'
        base = None if start is None or given else start.expand(B, -1)
        n = len(keys) + sum(net.n_weights for net in eq.networks)
        unknown = set() if needed is None else set(needed) - set(keys)
        if unknown:
            raise ValueError(f"jacobian(needed=...): no parameter {sorted(unknown)} in this model; "
                             f"its parameters are {keys}")
        asked = [needed is None or key in needed for key in keys]
        want = torch.tensor(asked + [weights] * (n - len(keys)), dtype=torch.float64)
        ds0 = s0.new_zeros(B, s0.shape[1], n)

        def reverse(cols: list[int], fn: Callable[[dict], list[torch.Tensor]]) -> torch.Tensor:
            """``(B, outputs, len(cols))``: the derivatives of ``fn(values)`` (a list of ``(B,)`` tensors, each row
            reading its own values) w.r.t. the parameter values ``keys[cols]``, by reverse mode (``row_jacobian``)."""
            def of(x: torch.Tensor) -> list[torch.Tensor]:
                rows = {k: dict(P[k]) for k in {keys[j][0] for j in cols}}
                for i, j in enumerate(cols):
                    rows[keys[j][0]][keys[j][1]] = x[:, i]
                return fn({**P, **rows})

            return row_jacobian(of, torch.stack([P[keys[j][0]][keys[j][1]].expand(B) for j in cols], dim=1))[1]

        def of_effects(has: Callable) -> list[int]:
            """The columns asked for of the parameters of the effects for which ``has(effect)``."""
            return [j for j, (k, _) in enumerate(keys) if asked[j] and k in model.effects and has(model.effects[k])]

        # the initial state's derivatives w.r.t. the parameters of the effects with a state (``Model.initial_state``
        # reads no other): reverse mode, one pass per state component, where the start depends on them at all
        stateful = of_effects(lambda e: e.state_dim)
        if stateful and s0.shape[1] and not given:
            def start_state(Q: dict) -> list[torch.Tensor]:
                s = model.initial_state(Q, B, controls=first, base=base)
                return list(s.unbind(1)) if s.requires_grad else []

            jac = reverse(stateful, start_state)
            if jac.shape[1]:
                ds0[..., stateful] = jac
        U, dU, dth = self.U, None, None
        tau = model.input_delay(P)
        if tau is not None:  # the input read late, and its derivatives w.r.t. the delay's parameters asked for
            rates, drates = delayed(self.rates, t, tau, derivative=True)
            U, _ = with_controls(rates, self.cond)
            moved = of_effects(lambda e: e.delays_input)
            if moved:  # the control channels are not delayed: their derivatives are 0
                dU = torch.cat([drates, drates.new_zeros(*drates.shape[:2], U.shape[2] - drates.shape[2])], dim=2)
                dth = U.new_zeros(B, n)
                dth[:, moved] = reverse(moved, lambda Q: [model.input_delay(Q).expand(B)])[:, 0].to(dtype)
        y, dy = tangent_fast(model, U, t, P, s0, ds0, method=self.sim.method or "rk4",
                             substeps=self.sim.substeps, controls=controls, want=want, dU=dU, dth=dth)
        return y, (dy if weights else dy[..., : len(keys)]), keys


def jacobian_covers(model) -> bool:
    """Whether identification's exact Jacobians (``simulate_jacobian`` w.r.t. the parameter values alone) cover
    ``model``: no effect is a network (whose weights and condition inputs are no coordinates of identification: it
    takes differences there)."""
    from ..physics.effects.neural import NeuralEffect

    return not any(isinstance(e, NeuralEffect) for e in model.effects.values())


def row_jacobian(fn: Callable[[torch.Tensor], list[torch.Tensor]], x: torch.Tensor,
                 columns: list[list[int]] | None = None) -> tuple[list, torch.Tensor]:
    """``fn(x)`` (a list of ``(rows,)`` tensors) and its derivatives ``(rows, outputs, D)`` w.r.t. ``x (rows, D)``,
    for a function whose row b reads row b of ``x`` alone (parameter values, start states): one reverse-mode pass
    per output (of its sum) gives every row's; with ``columns`` (the columns of ``x`` each output reads, no column
    read by two) one pass of their sum gives all. Zero where an output does not depend on ``x``. Forward-mode AD,
    the natural tool, runs its dual tensors through Python reference implementations in torch 2.13 (hundreds of µs
    per elementwise operation): ``scripts/bench_jacobian.py``."""
    with torch.enable_grad():
        leaf = x.detach().requires_grad_(True)
        outputs = fn(leaf)
        jac = x.new_zeros(x.shape[0], len(outputs), x.shape[1])
        if columns is not None:
            live = [y for y in outputs if y.requires_grad]
            g = torch.autograd.grad(sum(y.sum() for y in live), leaf, allow_unused=True)[0] if live else None
            for i, cols in enumerate(columns):
                if g is not None and outputs[i].requires_grad:
                    jac[:, i, cols] = g[:, cols]
        else:
            for i, y in enumerate(outputs):
                if y.requires_grad:
                    (g,) = torch.autograd.grad(y.sum(), leaf, retain_graph=i < len(outputs) - 1, allow_unused=True)
                    if g is not None:
                        jac[:, i] = g
    return [y.detach() for y in outputs], jac


def simulate_jacobian(model, inputs, t=None, *, values: dict, dt: float | None = None, conditions=None,
                      settings: SimulationSettings | None = None, method: str | None = None,
                      substeps: int | None = None, initial_state=None, weights: bool = False):
    """Responses and their derivatives w.r.t. every parameter value in one compiled pass (forward
    sensitivities).

    The Jacobian of ``simulate(model, inputs, t, values=values, backend="fast")`` w.r.t. each row's parameter
    values: what a Gauss–Newton or Levenberg–Marquardt fit needs, at the cost of a few simulations where
    finite differences take one per parameter. Exact for the discrete map (the same numbers as the adjoint); an
    input delay's column too: the input read late is the linear interpolation of the samples, differentiated with
    them (their slope; 0 where the input is held before t0; on a whole sample, the slope a longer delay reads).

    ``weights``: with networks inside the model (``NeuralEffect``), ``dy`` goes on past the parameter values with
    the derivatives w.r.t. every network weight, in the order of ``fast.function.weight_columns`` (what a
    Levenberg–Marquardt stage of training needs). ``initial_state``: as ``simulate``'s; a whole state
    ``(batch, state_dim)`` is held fixed (its derivatives are zero), otherwise the effects' start states and
    their derivatives w.r.t. the parameters are the model's own.

    Returns ``(y (batch, time, output_dim), dy (batch, time, output_dim, n), keys)``: ``keys`` lists the
    parameters as ``(effect, name)`` (the structure's under ``"structure"``) in the order of ``dy``'s last axis
    (the weights' columns follow them).
    """
    sim = SimulationSettings.of(settings, method=method, substeps=substeps)
    return Prepared(model, inputs, t, dt=dt, conditions=conditions, settings=sim).jacobian(
        values, initial_state=initial_state, weights=weights)


def _all_finite(x: torch.Tensor) -> bool:
    """Whether every element of ``x`` is finite: a finite sum says so in one pass (a NaN or inf makes it
    non-finite); only where it is not (a sum of finite values can overflow) element by element."""
    return bool(torch.isfinite(x.detach().sum())) or bool(torch.isfinite(x).all())


def _prepare(inputs, t, dt, dtype, device=None):
    """Validated input ``(batch, time, C)`` and time grid ``(time,)`` or ``(batch, time)`` (on ``device``
    where given)."""
    u = torch.as_tensor(inputs, dtype=dtype, device=device)
    if u.ndim == 2:
        u = u[..., None]
    if u.ndim != 3:
        raise ValueError(f"inputs must be (batch, time) or (batch, time, channels), got shape {tuple(u.shape)}")
    T = u.shape[1]
    if T < 2:
        raise ValueError(f"inputs have {T} time sample(s); simulation needs at least 2")
    if not _all_finite(u):
        bad = (~torch.isfinite(u)).nonzero()[0].tolist()
        raise ValueError(f"inputs contain NaN/inf (first at batch {bad[0]}, sample {bad[1]}); clean the input first")
    if t is None:
        if dt is None:
            raise ValueError("give the sample times t or a sample interval dt")
        t = torch.arange(T, dtype=dtype) * float(dt)
    t = torch.as_tensor(t, dtype=dtype, device=u.device)
    if t.shape not in ((T,), (u.shape[0], T)):
        raise ValueError(f"t has shape {tuple(t.shape)} but inputs have {T} samples in {u.shape[0]} rows; give "
                         f"({T},) for one grid or ({u.shape[0]}, {T}) for one grid per row")
    if not bool((t[..., 1:] > t[..., :-1]).all()):
        raise ValueError("t must be strictly increasing")
    if t.ndim == 2 and bool((t == t[:1]).all()):
        t = t[0]  # one grid after all
    return u, t


def _first(cond, controls) -> dict | None:
    """The control channels' first values ``{name: (batch,)}`` (where a lag starts), or None without controls."""
    return {c: cond[c][:, 0] for c in controls} if controls else None


def _whole_state(model, start: torch.Tensor) -> bool:
    """Whether a given start is the whole state (else the structure's [x, v], the effects' states their own)."""
    return start.shape[-1] == model.state_dim and model.state_dim != model.base_state_dim


def _initial_state(model, P, batch, initial_state, dtype, device, controls=None):
    if initial_state is None:
        return model.initial_state(P, batch, controls=controls)
    s0 = torch.as_tensor(initial_state, dtype=dtype, device=device)
    if s0.ndim == 1:
        s0 = s0.expand(batch, -1)
    if _whole_state(model, s0):
        return s0
    if s0.shape[1] == model.base_state_dim:
        return model.initial_state(P, batch, base=s0, controls=controls)
    raise ValueError(
        f"initial_state has {s0.shape[1]} columns; give {model.base_state_dim} "
        f"(the structure's [x, v]) or {model.state_dim} (the full state)"
    )


def _outputs(model, states, U, P, controls=()):
    """Outputs for all samples in one vectorised call: (batch, time) flattened into rows."""
    B, T, S = states.shape
    Uf = U.reshape(B * T, U.shape[-1])
    Pf = {k: {n: v.repeat_interleave(T) for n, v in d.items()} for k, d in P.items()}
    y = model.output(states.reshape(B * T, S), input_sample(Uf, controls), Pf)
    return y.reshape(B, T, -1)


def resolved_substeps(model, records, *, substeps: int | None = None, max_substeps: int = 16, tol: float = RESOLVED,
                      refit: Callable[[int], None] | None = None, outputs: dict | None = None,
                      **kwargs) -> tuple[int, float]:
    """Step doubling: the fewest sub-steps per sample, from ``substeps`` up to ``max_substeps``, at which halving
    the step changes the simulated response of ``records`` by at most ``tol`` (RMS of the change over RMS of
    the response). A stiff state (a sharp Bouc–Wen loop, a presliding friction bristle) on a coarse sample grid
    otherwise diverges or is shaped by the integrator's error; the data set decides, not the user.

    ``refit(s)``, where given, fits ``model`` on at ``s`` sub-steps (in place): it is called whenever a fitted
    model needs finer steps than it was fitted with, and the check repeated, since the refitted loops may be
    sharper still. ``outputs``, where given, receives ``{sub-steps: simulate's outputs}`` of the last
    simulation at each sub-step count (``simulate_resolved`` keeps the one it returns). ``kwargs`` go to
    ``simulate`` (settings, method, backend, input_channels); ``substeps`` defaults to ``settings.substeps``.
    Returns ``(substeps, change)``: the change at the returned
    sub-steps (``inf`` where even ``max_substeps`` diverges; the caller says so).
    """
    def doubled(s: int) -> tuple[int, float]:
        coarse = _response(model, records, s, kwargs, outputs)
        while True:
            fine = _response(model, records, 2 * s, kwargs, outputs)
            change = _change(coarse, fine)
            if change <= tol or 2 * s > max_substeps:
                return s, change
            s, coarse = 2 * s, fine

    if substeps is None:
        substeps = kwargs["settings"].substeps if kwargs.get("settings") is not None else 1
    at = max(int(substeps), 1)
    s, change = doubled(at)
    while refit is not None and s != at:
        refit(s)
        at = s
        s, change = doubled(at)
    return s, change


def coarsest_substeps(model, records, substeps: int, *, tol: float = RESOLVED, **kwargs) -> int:
    """Step doubling downwards: the fewest sub-steps per sample, halving from ``substeps``, at which every halving
    changed the simulated response of ``records`` by at most ``tol`` (as ``resolved_substeps`` judges a
    doubling). A model fitted at fine steps may no longer need them after a change (a stiff element removed or
    given up): sub-steps found by doubling only ever rise. An odd count is returned as it is. ``kwargs`` go to
    ``simulate``. Costs one simulation at ``substeps`` and one per halving tried (no gradients)."""
    s = max(int(substeps), 1)
    if s % 2:
        return s  # 1, or an odd count: halving it is not a sub-step count the doubling would reach
    fine = _response(model, records, s, kwargs)
    while s % 2 == 0:
        coarse = _response(model, records, s // 2, kwargs)
        if not _change(coarse, fine) <= tol:
            break
        s, fine = s // 2, coarse
    return s


def _response(model, records, substeps: int, kwargs: dict, outputs: dict | None = None) -> torch.Tensor:
    """The simulated response of ``records`` at ``substeps``, flattened (no gradients); ``outputs[substeps]``
    receives ``simulate``'s outputs where given."""
    with torch.no_grad():
        out = simulate(model, records, substeps=substeps, **kwargs)
    if outputs is not None:
        outputs[substeps] = out
    return torch.cat([y.reshape(-1) for y in out])


def _change(coarse: torch.Tensor, fine: torch.Tensor) -> float:
    """The relative RMS change between two responses (``inf`` where either is not finite)."""
    scale = float(fine.pow(2).mean().sqrt())
    change = float((coarse - fine).pow(2).mean().sqrt()) / max(scale, 1e-300)
    return change if math.isfinite(change) and math.isfinite(scale) else math.inf


def simulate_resolved(model, records, *, substeps: int | None = None, max_substeps: int = MAX_SUBSTEPS_SCORED,
                      tol: float = RESOLVED, **kwargs) -> tuple[list[torch.Tensor], int, float]:
    """``records`` simulated at the sub-steps *they* need: step doubling (``resolved_substeps``) from
    ``substeps``, usually the ones the model was fitted and resolved with, up to ``max_substeps``.

    A model resolved on its training records may need finer steps on others: a held-out operating condition
    that makes a state stiffer (a friction level that falls, a faster excitation), a coarser sample grid.
    Simulated at the fit's sub-steps such a record can diverge where the model itself does not; scoring it
    there would judge the integrator, not the model. Costs one simulation at each sub-step count tried and one at
    twice the returned count (no gradients): twice the plain simulation's where ``substeps`` already resolve
    the records, up to about 4 × ``max_substeps`` / ``substeps`` times it for a model that diverges at every
    step size. ``kwargs`` go to ``simulate``. Returns ``(outputs, substeps,
    change)``: ``simulate``'s outputs at the returned sub-steps and the change there (above ``tol`` where
    ``max_substeps`` did not resolve it, ``inf`` where it diverged).
    """
    outputs: dict = {}
    s, change = resolved_substeps(model, records, substeps=substeps, max_substeps=max(int(max_substeps), 1),
                                  tol=tol, outputs=outputs, **kwargs)
    return outputs[s], s, change

