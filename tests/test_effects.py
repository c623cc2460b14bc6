"""The effect library: registry, closed-form responses of the memoryless forces and state effects, and
validation of every effect's values; input operators: ``tests/test_effects_operators.py``; gradients and neutral
values: ``tests/test_effects_gradients.py``."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybridhyst.physics.effects import (
    EFFECTS,
    AsymmetricCoulomb,
    Attenuation,
    Clearance,
    Coulomb,
    CubicStiffness,
    Dahl,
    LinearStiffness,
    LuGre,
    Maxwell,
    Stribeck,
    TravelDamping,
    TravelDrift,
    TravelStiffness,
    Viscous,
)
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate

# every library effect that acts without a control channel and is not a network: registering an effect puts it in
# every test below that iterates this (a control's effects: tests/test_controls.py; networks: tests/test_neural.py)
CONTROL_EFFECTS = {"control_lag", "control_saturation", "spencer_mr"}
NEW_EFFECTS = tuple(cls for name, cls in EFFECTS.items() if name != "neural" and name not in CONTROL_EFFECTS)


pytestmark = pytest.mark.usefixtures("float64")  # conftest: float64 default dtype, restored afterwards


def ramps(velocities, duration: float, dt: float) -> dict:
    """Constant-velocity ramps x = v t with their exact rate: inputs ``(batch, time, 2)`` and t."""
    t = torch.arange(round(duration / dt) + 1) * dt
    v = torch.as_tensor(velocities, dtype=torch.float64)[:, None].expand(-1, t.shape[0])
    return {"inputs": torch.stack([v * t, v], dim=-1), "t": t}


def sine(amplitude: float, freq: float, periods: float, dt: float) -> tuple[torch.Tensor, torch.Tensor]:
    t = torch.arange(round(periods / freq / dt) + 1) * dt
    return t, amplitude * torch.sin(2 * math.pi * freq * t)


def respond(model, inputs=None, **kwargs) -> torch.Tensor:
    """Output channel 0, detached: ``(batch, time)``."""
    return simulate(model, inputs, **kwargs)[..., 0].detach()


# -- registry and validation ------------------------------------------------------------------------------
def test_every_effect_is_registered_with_documented_specs():
    assert set(NEW_EFFECTS) <= set(EFFECTS.values())
    for cls in EFFECTS.values():
        assert cls.equation and cls.source and cls.__doc__ and "Units" in cls.__doc__
        for pname, spec in cls.specs.items():
            assert spec.doc, f"{cls.name}.{pname} has no doc"
            if spec.neutral == 0.0 and spec.constraint == "bounded":
                # a sigmoid-bounded parameter reaches an interior 0 exactly, with a gradient (clearance.a)
                assert spec.bounds[0] < 0.0 < spec.bounds[1], f"{cls.name}.{pname}: neutral 0 on a bound"
                assert float(cls(**{pname: 0.0}).evaluate(None, 1)[pname].detach()) == 0.0, f"{cls.name}.{pname}"
            elif spec.neutral == 0.0 and spec.constraint != "real":
                assert spec.constraint == "nonnegative", f"{cls.name}.{pname}: neutral 0 needs 'nonnegative'"


@pytest.mark.parametrize("cls", NEW_EFFECTS, ids=lambda c: c.name)
def test_unknown_parameter_raises_with_its_name(cls):
    with pytest.raises(ValueError, match="not_a_parameter"):
        cls(not_a_parameter=1.0)


# -- memoryless forces ------------------------------------------------------------------------------------
def test_asymmetric_coulomb_levels():
    model = Constitutive([AsymmetricCoulomb(Fc=2.0, dF=0.5, v_s=1e-3)])
    F = respond(model, **ramps([1.0, -1.0], 0.1, 0.01))
    assert torch.allclose(F[0, 1:], torch.full_like(F[0, 1:], 2.5), atol=1e-12)  # Fc + dF
    assert torch.allclose(F[1, 1:], torch.full_like(F[1, 1:], -1.5), atol=1e-12)  # -(Fc - dF)


def test_cubic_stiffness_value():
    x = torch.tensor([[0.0, 1.0, -2.0, 3.0]])
    F = respond(Constitutive([CubicStiffness(k3=0.5)]), x, dt=0.1)
    assert torch.allclose(F, torch.tensor([[0.0, 0.5, -4.0, 13.5]]), atol=1e-12)


@pytest.mark.parametrize("effect, carrier", [
    (lambda: TravelStiffness(dk=-0.3), lambda x, v: -0.3 * x),
    (lambda: TravelDamping(dc=0.2), lambda x, v: 0.2 * v),
    (lambda: TravelDrift(dF=0.4, v_s=1e-4), lambda x, v: 0.4 * torch.sign(v)),
], ids=["stiffness", "damping", "friction"])
def test_a_travel_drift_adds_its_coefficient_times_the_travel_so_far(effect, carrier):
    # ramps out at +1 and −2: the travel is |v| t, so the force is (drift · |v| t) · (x, v or sgn v)
    r = ramps([1.0, -2.0], 2.0, 0.01)
    F = respond(Constitutive([effect()]), r["inputs"], t=r["t"])
    x, v = r["inputs"][..., 0], r["inputs"][..., 1]
    assert torch.allclose(F, v.abs() * r["t"] * carrier(x, v), atol=1e-9)


@pytest.mark.parametrize("backend", ["reference", "fast"])
def test_a_travel_drift_levels_off_over_the_inverse_of_lambda(backend):
    """ṡ = |v| (1 − λ s) is s = (1 − exp(−λ · travel)) / λ: on ramps the travel is |v| t, so the drift of the
    stiffness follows the exponential of the travel (RK4's error aside) and ends near dk / λ."""
    r = ramps([1.0, -2.0], 2.0, 0.01)
    model = Constitutive([TravelStiffness(dk=-0.3, lam=2.0)])
    F = respond(model, r["inputs"], t=r["t"], backend=backend)
    x, v = r["inputs"][..., 0], r["inputs"][..., 1]
    worked = 0.5 * (1 - torch.exp(-v.abs() * r["t"] / 0.5))
    assert torch.allclose(F, -0.3 * worked * x, atol=1e-8)
    assert float(worked[1, -1]) == pytest.approx(0.5, rel=1e-3)  # 4 units of travel: levelled off


@pytest.mark.parametrize("backend", ["reference", "fast"])
@pytest.mark.parametrize("lam", [0.0, 2.0])
def test_a_travel_drift_started_at_the_travel_before_the_record_continues_its_curve(backend, lam):
    """With ``s0``, the travel before the record, the worked travel starts where s0 of travel left it, so the
    record continues the curve of one long record: s = (1 − exp(−λ (s0 + travel))) / λ (s0 + travel at λ = 0);
    the compiled Jacobian w.r.t. s0 and λ equals central differences, at λ = 0 too (where the closed form has no
    derivative w.r.t. λ and the series gives it)."""
    from hybridhyst.simulate.api import simulate_jacobian

    r, s0 = ramps([1.0, -2.0], 2.0, 0.01), 0.7
    model = Constitutive([TravelStiffness(dk=-0.3, lam=lam, s0=s0)]).double()
    F = respond(model, r["inputs"], t=r["t"], backend=backend)
    x, v = r["inputs"][..., 0], r["inputs"][..., 1]
    travel = s0 + v.abs() * r["t"]
    worked = travel if lam == 0 else (1 - torch.exp(-lam * travel)) / lam
    assert torch.allclose(F, -0.3 * worked * x, atol=1e-8)
    if backend == "fast":
        values = {"travel_stiffness": {k: torch.tensor([v], dtype=torch.float64)
                                       for k, v in model.effects["travel_stiffness"].config().items() if k != "effect"}}
        inputs = r["inputs"][:1]
        _, dy, keys = simulate_jacobian(model, inputs, r["t"], values=values, substeps=1)
        h = 1e-6
        for name in ("s0", "lam"):
            up, down = ({"travel_stiffness": {**values["travel_stiffness"], name: values["travel_stiffness"][name] + d}}
                        for d in (h, -h))
            fd = (simulate(model, inputs, r["t"], values=up) - simulate(model, inputs, r["t"], values=down))[0, :, 0]
            np.testing.assert_allclose(dy[0, :, 0, keys.index(("travel_stiffness", name))].numpy(),
                                       (fd / (2 * h)).numpy(), atol=1e-6)


def test_attenuation_value_constitutive():
    x = torch.tensor([[0.0, 1.0, -2.0, 3.0]])
    F = respond(Constitutive([Attenuation(xi=0.3)]), x, dt=0.1)
    assert torch.allclose(F, torch.tensor([[0.0, 0.3, -1.2, 2.7]]), atol=1e-12)  # xi |x| u with u = x


def test_attenuation_equilibrium_matches_seed_003_drive():
    """m x'' + c x' + k x = (Kp/i)(d33 - xi_p |x|) u: with drive_gain = 1, k = 1, xi = 0.5, u = 2 the
    equilibrium solves x = 2 - x², i.e. x = 1 (a linear drive alone would give x = 2)."""
    u = torch.full((1, 401), 2.0)
    model = DrivenOscillator([LinearStiffness(k=1.0), Viscous(c=3.0), Attenuation(xi=0.5)], mass=1.0, drive_gain=1.0)
    x = respond(model, u, dt=0.05)
    assert abs(float(x[0, -1]) - 1.0) < 1e-6


def test_stribeck_curve_values():
    Fc, dFs, vs = 1.0, 0.5, 0.1
    v = torch.tensor([0.05, 0.1, 0.2, -0.1])
    model = Constitutive([Coulomb(Fc=Fc, v_s=1e-5), Stribeck(dFs=dFs, vs=vs, v_s=1e-5)])
    F = respond(model, **ramps(v, 0.02, 0.01))[:, -1]
    expected = torch.tensor([Fc + dFs * math.exp(-0.25), Fc + dFs / math.e, Fc + dFs * math.exp(-4.0),
                             -(Fc + dFs / math.e)])
    assert torch.allclose(F, expected, atol=1e-12)


# -- state effects ----------------------------------------------------------------------------------------
def test_dahl_ramp_closed_form_saturation_and_initial_slope():
    sigma0, Fc = 50.0, 2.0
    model = Constitutive([Dahl(sigma0=sigma0, Fc=Fc)])
    for ramp in (ramps([0.1], 5.0, 0.01), ramps([1.0], 0.5, 0.001)):  # same path x: 0 -> 0.5, 10x faster
        F = respond(model, **ramp)[0]
        x = ramp["inputs"][0, :, 0]
        assert torch.allclose(F, Fc * (1 - torch.exp(-sigma0 * x / Fc)), atol=1e-6)  # rate independent
        assert abs(float(F[-1]) - Fc) < 1e-4  # saturates at Fc
        slope = float((F[1] - F[0]) / (x[1] - x[0]))
        assert slope == pytest.approx(sigma0, rel=0.02)  # sigma0 (1 - O(sigma0 dx / Fc))


def test_lugre_steady_sliding_follows_stribeck_curve():
    p = {"sigma0": 1e3, "sigma1": 30.0, "sigma2": 0.4, "Fc": 1.0, "Fs": 1.5, "vs": 0.1}
    v = torch.tensor([0.03, 0.1, 0.3, -0.1])
    F = respond(Constitutive([LuGre(**p)]), **ramps(v, 0.6, 2e-3))[:, -1]
    g = p["Fc"] + (p["Fs"] - p["Fc"]) * torch.exp(-((v / p["vs"]) ** 2))
    assert torch.allclose(F, g * v.sign() + p["sigma2"] * v, atol=1e-6)
    assert float(F[1]) == pytest.approx(1.0 + 0.5 / math.e + 0.04, abs=1e-6)
    static = Constitutive([Coulomb(Fc=1.0, v_s=1e-6), Stribeck(dFs=0.5, vs=0.1, v_s=1e-6), Viscous(c=0.4)])
    assert torch.allclose(F, respond(static, **ramps(v, 0.02, 0.01))[:, -1], atol=1e-6)


def test_lugre_without_stribeck_and_damping_is_dahl():
    t, x = sine(0.02, 1.0, 1.5, 5e-3)
    lugre = Constitutive([LuGre(sigma0=200.0, sigma1=0.0, sigma2=0.0, Fc=1.0, Fs=1.0, vs=0.1)])
    dahl = Constitutive([Dahl(sigma0=200.0, Fc=1.0)])
    F_lugre, F_dahl = respond(lugre, x[None], t=t), respond(dahl, x[None], t=t)
    assert torch.allclose(F_lugre, F_dahl, atol=1e-12)
    assert float(F_dahl.abs().max()) > 0.9  # saturated, so the test covers the nonlinear part


def exact_clearance(x: np.ndarray, r: float, sigma0: float, Fc_pos: float, Fc_neg: float,
                    q0: float = 0.0) -> np.ndarray:
    """Force of a Dahl element behind a gap of half-width r along a path x (written independently): exact per
    increment. q = gap opening + bristle deflection, q(0) = q0; moving in direction s, the deflection
    z = q + s r (loaded against the motion) or q − s r (with it) relaxes in travel towards s L,
    L = Fc_s / σ0, as z ← s L + (z − s L) e^(−travel / L); in between (|q| ≤ r) q follows x. An increment
    that reaches a boundary (z = 0: the gap opens; |q| = r: it closes) is split there."""
    q = q0
    out = np.full_like(x, sigma0 * (q - min(max(q, -r), r)))
    for k in range(1, len(x)):
        left = abs(x[k] - x[k - 1])
        s = 1.0 if x[k] > x[k - 1] else -1.0
        L = (Fc_pos if s > 0 else Fc_neg) / sigma0
        while left > 0:
            if s * q < -r:  # still loaded the other way: unload until z = 0, where the gap opens
                z = q + s * r
                to_open = L * math.log((s * L - z) / (s * L))
                if to_open >= left:
                    q, left = s * L + (z - s * L) * math.exp(-left / L) - s * r, 0.0
                else:
                    q, left = -s * r, left - to_open
            elif s * q < r:  # crossing the gap: no force, q follows x
                to_close = r - s * q
                q, left = (q + s * left, 0.0) if to_close >= left else (s * r, left - to_close)
            else:  # gap closed in the direction of motion: Dahl
                z = q - s * r
                q, left = s * L + (z - s * L) * math.exp(-left / L) + s * r, 0.0
        out[k] = sigma0 * (q - min(max(q, -r), r))
    return out


def triangle(amplitude: float, dt: float):
    """x: 0 → A → −A → A at unit speed, the reversals on samples; inputs (x, v) with the central-difference
    velocity (0 on a reversal) and the path the library integrates along (the velocity is linear between
    samples, so the state follows x0 + ∫v: on each reversal the peak is cut by dt/2)."""
    t = np.arange(round(5 * amplitude / dt) + 1) * dt
    x = np.interp(t, [0.0, amplitude, 3 * amplitude, 5 * amplitude], [0.0, amplitude, -amplitude, amplitude])
    v = np.gradient(x, t)
    path = np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)]
    inputs = torch.stack([torch.as_tensor(x), torch.as_tensor(v)], dim=-1)[None]
    return torch.as_tensor(t), inputs, x, path


@pytest.mark.parametrize("backend", ["reference", "fast"])
def test_clearance_without_gap_or_asymmetry_is_dahl(backend):
    t, x = sine(0.05, 1.0, 1.5, 5e-3)
    dahl = Constitutive([Dahl(sigma0=200.0, Fc=1.0)])
    clearance = Constitutive([Clearance(sigma0=200.0, Fc=1.0, a=0.0, r=0.0)])
    F_dahl = respond(dahl, x[None], t=t, backend=backend)
    F_clearance = respond(clearance, x[None], t=t, backend=backend)
    assert float((F_clearance - F_dahl).abs().max()) <= 1e-12  # the same equations (rounding aside)
    assert float(F_dahl.abs().max()) > 0.9  # saturated, so the test covers the nonlinear part
    # r and a at their neutral 0 still get a gradient (discovery grows the clearance from Dahl)
    effect = clearance.effects["clearance"]
    y = simulate(clearance, x[None], t=t, backend=backend)
    grads = torch.autograd.grad(y.square().sum(), [raw(effect, "r"), raw(effect, "a")])
    assert all(torch.isfinite(g) and g != 0 for g in grads), grads


@pytest.mark.parametrize("backend", ["reference", "fast"])
def test_clearance_force_is_zero_across_the_gap(backend):
    """Triangle input: the force saturates at Fc (1 + a) going up and −Fc (1 − a) going down; after each
    reversal it unloads along Dahl's curve, is exactly 0 while the input crosses the gap (a travel of 2r),
    then loads the other way. The whole response matches an exact path integration."""
    r, sigma0, Fc, a, A, dt = 0.1, 20.0, 0.5, 0.2, 0.5, 1e-3
    up, down = Fc * (1 + a), Fc * (1 - a)
    t, inputs, x, path = triangle(A, dt)
    F = respond(Constitutive([Clearance(sigma0=sigma0, Fc=Fc, a=a, r=r)]), inputs, t=t, backend=backend)[0].numpy()
    np.testing.assert_allclose(F, exact_clearance(path, r, sigma0, up, down), atol=1e-5 * Fc)
    assert F.max() == pytest.approx(up, rel=1e-9) and F.min() == pytest.approx(-down, rel=1e-9)
    assert np.all(F[: round(r / dt)] == 0.0)  # the gap starts centred: no force until x = r
    for k_rev, s, L_new in ((round(A / dt), -1.0, down / sigma0), (round(3 * A / dt), 1.0, up / sigma0)):
        level = F[k_rev]  # saturated: +up at the top, −down at the bottom
        # unloading: Dahl's exponential in travel towards the new direction's level (slope σ0 (1 + |F|/Fc_new))
        opens = L_new * math.log(1 + abs(level) / (sigma0 * L_new))  # travel until the force is 0
        travel = np.abs(x - x[k_rev])
        unloading = np.arange(k_rev + 1, k_rev + round(opens / dt) - 1)
        along = np.abs(path[unloading] - path[k_rev])  # the travel the library integrates (see ``triangle``)
        expected = sigma0 * (s * L_new + (level / sigma0 - s * L_new) * np.exp(-along / L_new))
        np.testing.assert_allclose(F[unloading], expected, atol=1e-5 * Fc)
        # then exactly zero over an input travel of 2r
        window = np.arange(k_rev, k_rev + round((opens + 2 * r + 0.05) / dt))
        zero = window[F[window] == 0.0]
        assert np.all(np.diff(zero) == 1)  # one plateau
        assert travel[zero[0]] == pytest.approx(opens, abs=2 * dt)
        assert travel[zero[-1]] - travel[zero[0]] == pytest.approx(2 * r, abs=2 * dt)
        beyond = window[travel[window] > opens + 2 * r + 2 * dt]
        assert np.all(s * F[beyond] > 0)  # loading the other way


@pytest.mark.parametrize("backend", ["reference", "fast"])
def test_a_start_state_starts_every_record_there_with_exact_derivatives(backend):
    """``Clearance(q0=...)`` (``Effect.start``): the state starts at q0 instead of 0 (here the gap closed on the
    negative side and the element fully deflected, as a move down to the first point leaves it), the response
    matches the exact path integration from q0, and the compiled Jacobian w.r.t. q0 equals a central difference."""
    from hybridhyst.physics.build import build_effect
    from hybridhyst.simulate.api import simulate_jacobian

    r, sigma0, Fc, a, A, dt = 0.1, 20.0, 0.5, 0.2, 0.5, 1e-3
    q0 = -(r + Fc * (1 - a) / sigma0)
    t, inputs, x, path = triangle(A, dt)
    model = Constitutive([Clearance(sigma0=sigma0, Fc=Fc, a=a, r=r, q0=q0)]).double()
    F = respond(model, inputs, t=t, backend=backend)[0].numpy()
    np.testing.assert_allclose(F, exact_clearance(path, r, sigma0, Fc * (1 + a), Fc * (1 - a), q0), atol=1e-5 * Fc)
    assert F[0] == pytest.approx(-Fc * (1 - a)) and np.all(F[1: round(2 * r / dt) - 5] <= 0)  # unloads, then the gap
    assert not np.allclose(F, respond(Constitutive([Clearance(sigma0=sigma0, Fc=Fc, a=a, r=r)]).double(), inputs,
                                      t=t, backend=backend)[0].numpy(), atol=0.1)
    config = model.effects["clearance"].config()
    assert config["q0"] == pytest.approx(q0) and build_effect("clearance", config).config() == config  # round trip
    if backend == "fast":
        values = {"clearance": {k: torch.tensor([v], dtype=torch.float64) for k, v in config.items() if k != "effect"}}
        _, dy, keys = simulate_jacobian(model, inputs, t, values=values, substeps=1)
        h = 1e-6
        up, down = ({**values, "clearance": {**values["clearance"], "q0": values["clearance"]["q0"] + d}}
                    for d in (h, -h))
        fd = (simulate(model, inputs, t, values=up, backend="fast")
              - simulate(model, inputs, t, values=down, backend="fast"))[0, :, 0] / (2 * h)
        np.testing.assert_allclose(dy[0, :, 0, keys.index(("clearance", "q0"))].numpy(), fd.numpy(), atol=1e-6)
    with pytest.raises(ValueError, match="start state"):
        Clearance(sigma0=sigma0, Fc=Fc, z0=0.1)  # the clearance's start is q0
    held = Clearance(sigma0=sigma0, Fc=Fc, fixed=["q0"])  # named in fixed without a value: held at rest
    assert float(held.params["q0"](None, 1)[0]) == 0.0 and not list(held.params["q0"].parameters())


def test_maxwell_storage_stiffness_and_loss_under_a_sine():
    """Steady state under x = A sin ωt: F = k' x + c' ẋ with the storage stiffness k' = k_m (ωτ)² / (1 + (ωτ)²)
    and the loss coefficient c' = c_m / (1 + (ωτ)²), c_m = k_m τ (fitted on the last cycle, below, near and
    above the corner frequency 1/τ)."""
    k_m, tau, A, dt = 2.0, 0.1, 0.3, 1e-3
    freqs = torch.tensor([0.5, 1.6, 5.0])
    t = torch.arange(round(3.0 / dt) + 1) * dt  # 30 τ: the start-up transient (e^(−t/τ)) is gone
    w = 2 * math.pi * freqs[:, None]
    inputs = torch.stack([A * torch.sin(w * t), A * w * torch.cos(w * t)], dim=-1)
    F = respond(Constitutive([Maxwell(k_m=k_m, tau=tau)]), inputs, t=t)
    for i, f in enumerate(freqs.tolist()):
        last = t > t[-1] - 1.0 / f
        basis = inputs[i, last]  # columns x, ẋ
        (k_fit, c_fit), *_ = np.linalg.lstsq(basis.numpy(), F[i, last].numpy(), rcond=None)
        wt2 = (2 * math.pi * f * tau) ** 2
        assert k_fit == pytest.approx(k_m * wt2 / (1 + wt2), rel=0.01), f
        assert c_fit == pytest.approx(k_m * tau / (1 + wt2), rel=0.01), f


def raw(effect, pname: str) -> torch.Tensor:
    """The stored (unconstrained) leaf tensor of a constant parameter."""
    (leaf,) = effect.params[pname].parameters()
    return leaf


# -- values outside a parameter's domain are refused where the effect is built, naming it ---------------------------
@pytest.mark.parametrize("key,cfg,expected", [
    ("viscous", {"effect": "viscous", "c": -6.7}, "effect 'viscous' (viscous): parameter c (viscous coefficient) "
     "needs a value >= 0, got -6.7"),
    ("friction", {"effect": "coulomb", "Fc": 1.0, "v_s": -0.05}, "effect 'friction' (coulomb): parameter v_s"),
    # a fixed value is a value too: a negative smoothing width flips the friction's sign
    ("coulomb", {"effect": "coulomb", "v_s": -0.05, "fixed": ["v_s"]}, "needs a value > 0, got -0.05"),
    ("spring", {"effect": "linear_stiffness", "k": -1.0}, "parameter k (linear stiffness) needs a value >= 0"),
    ("hysteresis", {"effect": "bouc_wen", "k": -4.0}, "parameter k (stiffness"),
    ("hysteresis", {"effect": "bouc_wen", "A": -1.0}, "parameter A (hysteretic gain) needs a value >= 0"),
    ("dahl", {"effect": "dahl", "sigma0": 0.0}, "parameter sigma0 (presliding (bristle) stiffness) needs a value > 0"),
    ("lugre", {"effect": "lugre", "Fs": -2.0}, "parameter Fs"),
    ("viscous", {"effect": "viscous", "c": {"kind": "per_condition", "levels": [1, 2], "values": [0.1, -0.2],
                                            "condition": "p"}}, "got -0.2"),
    ("viscous", {"effect": "viscous", "c": "abc"}, "parameter c needs a number or a parameter function"),
    ("viscous", {"effect": "viscous", "cc": 1.0}, "has no parameter(s) ['cc'] (did you mean c for cc?)"),
])
def test_a_value_outside_the_parameters_domain_is_refused_naming_effect_and_parameter(key, cfg, expected):
    from hybridhyst.physics import build_model

    with pytest.raises(ValueError) as err:
        build_model(effects={key: cfg})
    assert expected in str(err.value), err.value


def test_a_negative_levelling_rate_is_refused_with_what_zero_means():
    """The generic hint for an amplitude, "0 turns the term off", is wrong for a drift's levelling rate λ: 0 keeps
    the drift linear, which its own description says."""
    from hybridhyst.physics import build_model

    with pytest.raises(ValueError) as err:
        build_model(effects={"drift": {"effect": "travel_drift", "dF": 0.1, "lam": -0.5}})
    assert "parameter lam" in str(err.value) and "(0: linear in the travel)" in str(err.value)
    assert "turns the term off" not in str(err.value)
    with pytest.raises(ValueError, match=r"\(0 turns the term off\)"):
        build_model(effects={"spring": {"effect": "linear_stiffness", "k": -1.0}})


def test_signed_values_the_physics_allows_are_accepted():
    """A softening cubic stiffness, Bouc–Wen shape parameters, an asymmetry and a trend with a negative slope whose
    value stays positive over the data: the check is on a parameter's value, not on every coefficient."""
    from hybridhyst.physics import build_model
    from hybridhyst.physics.compositions import boucwen_benchmark

    model = build_model(effects={
        "cubic": {"effect": "cubic_stiffness", "k3": -0.5},
        "hysteresis": {"effect": "bouc_wen", "beta": -1.0, "gamma": -2.5},
        "friction": {"effect": "asymmetric_coulomb", "Fc": 1.0, "dF": -0.3},
        "viscous": {"effect": "viscous", "c": {"kind": "linear", "slope": -1.0, "intercept": 0.2,
                                               "condition": "pressure_mpa"}},
    })
    values = model.effects["viscous"].evaluate({"pressure_mpa": torch.tensor([0.05, 0.09])}, 2)["c"]
    assert torch.all(values > 0)
    assert float(boucwen_benchmark(delta=-1.1).effects["hysteresis"].params["gamma"].value.detach()) < 0
    with pytest.raises(ValueError, match=r"parameter 'mass or inertia' needs a value > 0, got -2"):
        boucwen_benchmark(m=-2.0)
