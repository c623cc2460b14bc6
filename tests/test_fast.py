"""The compiled fast path equals the reference loop: values and gradients, every effect and composition."""

import math

import pytest
import torch

from hybridhyst.physics.compositions import COMPOSITIONS
from hybridhyst.physics.effects import EFFECTS
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import jacobian_covers, simulate, simulate_jacobian

RTOL = 1e-8


def _grads(model, y, w):
    params = list(model.parameters())
    grads = torch.autograd.grad((y * w).sum(), params, allow_unused=True)
    return [torch.zeros_like(p) if g is None else g for g, p in zip(grads, params)]


def _assert_agree(model, u, t, **kw):
    ref = simulate(model, u, t=t, **kw)
    fast = simulate(model, u, t=t, backend="fast", **kw)
    scale = ref.abs().max().clamp_min(1e-300)
    assert ((fast - ref).abs().max() / scale).item() < RTOL
    w = torch.randn_like(ref, generator=torch.Generator().manual_seed(0))
    for gr, gf in zip(_grads(model, ref, w), _grads(model, fast, w)):
        assert ((gf - gr).abs().max() / gr.abs().max().clamp_min(1e-300)).item() < RTOL


# short inputs in each composition's own units (stable on this grid)
CASES = {
    "vpptd_algebraic": (10.0, 1e-3), "modified_bouc_wen": (10.0, 1e-3), "vpptd_rig": (10.0, 1e-3),
    "bouc_wen_p": (0.01, 1e-3), "bouc_wen_classic": (1.0, 1e-3), "piezo_attenuation": (50.0, 2e-5),
    "dahl_friction": (1.0, 1e-3), "lugre_friction": (1.0, 1e-3), "boucwen_benchmark": (50.0, 1e-3),
}


@pytest.mark.parametrize("name", sorted(COMPOSITIONS))
def test_fast_path_equals_reference_for_every_composition(name, float64):
    amp, dt = CASES[name]
    model = COMPOSITIONS[name]().double()
    t = torch.arange(150) * dt
    u = amp * torch.sin(2 * math.pi * 5 * t + 0.3).expand(2, -1)
    _assert_agree(model, u, t, conditions={"pressure_mpa": torch.tensor([0.03, 0.07])}, substeps=2)


# every library effect at its own non-neutral example values (Effect.example_values), alone in both structures
# (with a spring for stability); what acts on a control channel and Spencer's MR damper need a control: their
# cases are in tests/test_controls.py, networks' in tests/test_neural.py
CONTROL_EFFECTS = {"control_lag", "control_saturation", "spencer_mr"}
EFFECT_VALUES = {name: dict(cls.example_values) for name, cls in EFFECTS.items()
                 if name != "neural" and name not in CONTROL_EFFECTS}


def test_every_library_effect_declares_example_values():
    missing = sorted(name for name, cls in EFFECTS.items() if name != "neural" and not cls.example_values)
    assert not missing, f"declare example_values on {missing} (the values the compiled-vs-reference tests use)"
    for name, cls in EFFECTS.items():
        assert set(cls.example_values) <= set(cls.specs) | set(cls.start), name


def _every_effect(structure: str):
    """Every library effect but the delay at non-neutral values in one model (one compilation per structure,
    shared by the adjoint and the Jacobian tests); the delay is tested alone below."""
    order = ["backlash"] + [n for n in sorted(EFFECT_VALUES) if n not in ("backlash", "time_delay")]
    effects = {name: EFFECTS[name](**EFFECT_VALUES[name]) for name in order}
    if structure == "constitutive":
        return Constitutive(effects).double()
    return DrivenOscillator(effects, mass=1.0).double()


# The all-effects models compile the largest loops of the suite (on a fresh machine about 45 s for the forward and
# adjoint loops and 20 s for the sensitivities, per structure): the default run checks the constitutive structure,
# the driven oscillator runs with -m slow. By default the oscillator's own equations are checked with the compositions
# built on it and with the newest effects alone, its sensitivities with a clearance and a spring; an effect's force
# is generated the same way in both structures.
EVERY_EFFECT_STRUCTURES = ["constitutive", pytest.param("oscillator", marks=pytest.mark.slow)]


def _every_effect_input():
    t = torch.arange(300) * 5e-3
    return torch.sin(2 * math.pi * 1.3 * t) + 0.3 * torch.sin(2 * math.pi * 3.1 * t + 1.0), t


@pytest.mark.parametrize("structure", EVERY_EFFECT_STRUCTURES)
def test_fast_path_equals_reference_for_every_effect(structure, float64):
    """All library effects at non-neutral values in one model per structure (one compilation each);
    every parameter's gradient is compared individually."""
    u, t = _every_effect_input()
    _assert_agree(_every_effect(structure), u[None], t, substeps=2)


# the newest effects and the delay alone (with a spring), at values that exercise every branch: the clearance's gap
# opens and closes on each reversal and its bristle saturates both ways; the Maxwell element runs near its corner 1/τ;
# the relaxing play at λ = 0, where it is the plain play (tests/test_effects_operators.py, on the compiled path)
ALONE = {
    "clearance": {"sigma0": 20.0, "Fc": 0.5, "a": -0.3, "r": 0.1},
    "maxwell": {"k_m": 2.0, "tau": 0.1},
    "relaxing_backlash": {"r": 0.1, "lam": 0.0},
    "time_delay": {"tau": 0.013},
}


@pytest.mark.parametrize("structure", ["constitutive", "oscillator"])
@pytest.mark.parametrize("name", sorted(ALONE))
def test_fast_path_equals_reference_for_the_newest_effects_alone(name, structure, float64):
    effects = {name: EFFECTS[name](**ALONE[name]), "spring": EFFECTS["linear_stiffness"](k=2.0)}
    if structure == "constitutive":
        model = Constitutive(effects).double()
        amp = 0.6
    else:
        model = DrivenOscillator(effects, mass=0.05).double()
        amp = 1.5  # drive [F], near resonance (1 Hz): displacements of ±1.5 to ±2.7
    t = torch.arange(400) * 5e-3
    u = amp * (torch.sin(2 * math.pi * 1.1 * t) + 0.2 * torch.sin(2 * math.pi * 3.7 * t + 0.5))
    _assert_agree(model, torch.stack([u, 0.7 * u]), t, substeps=2)


@pytest.mark.parametrize("method", ["euler", "heun", "midpoint", "rk4"])
def test_fast_path_every_scheme_and_initial_state_gradient(method, float64):
    model = COMPOSITIONS["vpptd_rig"]().double()
    t = torch.arange(200) * 2e-3
    x0 = torch.tensor([[10.0, 40.0], [5.0, -20.0]], requires_grad=True)
    cond = {"pressure_mpa": torch.tensor([0.02, 0.08])}
    ref = simulate(model, torch.zeros(2, 200), t=t, conditions=cond, initial_state=x0, method=method)
    fast = simulate(model, torch.zeros(2, 200), t=t, conditions=cond, initial_state=x0, method=method,
                    backend="fast")
    assert torch.allclose(fast, ref, rtol=RTOL, atol=1e-12)
    (g_ref,) = torch.autograd.grad(ref.sum(), x0)
    (g_fast,) = torch.autograd.grad(fast.sum(), x0)
    assert torch.allclose(g_fast, g_ref, rtol=1e-7, atol=1e-10)


def test_fast_path_in_float32_returns_float32_close_to_float64():
    model = COMPOSITIONS["dahl_friction"]()
    t = torch.arange(300, dtype=torch.float32) * 5e-3
    u = torch.sin(2 * math.pi * t)[None]
    y32 = simulate(model, u, t=t, backend="fast")
    assert y32.dtype == torch.float32
    y64 = simulate(model.double(), u.double(), t=t.double(), backend="fast")
    assert torch.allclose(y32.double(), y64, atol=1e-4 * y64.abs().max().item())


def test_population_as_batch_with_explicit_values(float64):
    """Identification's use: one batched simulation for many parameter sets."""
    model = COMPOSITIONS["dahl_friction"]().double()
    P = model.evaluate(None, 3)
    P["dahl"]["Fc"] = torch.tensor([1.0, 2.0, 3.0])
    t = torch.arange(400) * 5e-3
    u = torch.sin(2 * math.pi * t).expand(3, -1)
    fast = simulate(model, u, t=t, values=P, backend="fast")
    ref = simulate(model, u, t=t, values=P)
    assert torch.allclose(fast, ref, rtol=RTOL, atol=1e-12)
    assert fast[2, -1, 0] > fast[1, -1, 0] > fast[0, -1, 0]


@pytest.mark.parametrize("name", ["modified_bouc_wen", "boucwen_benchmark"])
def test_fast_path_returns_the_reference_states(name, float64):
    amp, dt = CASES[name]
    model = COMPOSITIONS[name]().double()
    t = torch.arange(120) * dt
    u = amp * torch.sin(2 * math.pi * 5 * t + 0.3).expand(2, -1)
    cond = {"pressure_mpa": torch.tensor([0.03, 0.07])}
    y_ref, s_ref = simulate(model, u, t=t, conditions=cond, return_states=True)
    y_fast, s_fast = simulate(model, u, t=t, conditions=cond, return_states=True, backend="fast")
    assert s_fast.shape == s_ref.shape and s_fast.requires_grad == s_ref.requires_grad  # both differentiable
    assert ((s_fast - s_ref).abs().max() / s_ref.abs().max()).item() < RTOL
    assert ((y_fast - y_ref).abs().max() / y_ref.abs().max()).item() < RTOL


@pytest.mark.parametrize("structure", EVERY_EFFECT_STRUCTURES)
def test_jacobian_equals_the_adjoint_for_every_effect(structure, float64):
    """``simulate_jacobian`` (forward sensitivities w.r.t. every parameter in one pass) against the exact
    adjoint of the reference loop: per row and parameter, w · dy equals the gradient of w · y, with the play's
    projection (backlash, clearance) and sub-steps in the loop."""
    u, t = _every_effect_input()
    _assert_jacobian(_every_effect(structure), torch.stack([u, 0.8 * u]), t)


def test_jacobian_equals_the_adjoint_on_the_driven_oscillator(float64):
    """The same on the oscillator's own equations (by default; its all-effects case runs with -m slow): a
    clearance (a projected state) and a spring on a mass driven near resonance."""
    model = DrivenOscillator({"clearance": EFFECTS["clearance"](**ALONE["clearance"]),
                              "spring": EFFECTS["linear_stiffness"](k=2.0)}, mass=0.05).double()
    t = torch.arange(400) * 5e-3
    u = 1.5 * (torch.sin(2 * math.pi * 1.1 * t) + 0.2 * torch.sin(2 * math.pi * 3.7 * t + 0.5))
    _assert_jacobian(model, torch.stack([u, 0.7 * u]), t)


def test_jacobian_of_a_parameter_that_reaches_the_state_only_through_its_bound(float64):
    """A play's half-width r enters the equations only as the bound of its state (the right-hand side is u̇): the
    forward sensitivities must carry its column through the state all the same (``codegen._state_columns``), asked
    for alone or with the others."""
    model = Constitutive({"backlash": EFFECTS["backlash"](r=0.2), "spring": EFFECTS["linear_stiffness"](k=2.0)})
    u, t = _every_effect_input()
    _assert_jacobian(model.double(), torch.stack([u, 0.8 * u]), t)
    with torch.no_grad():
        P = model.evaluate(None, 2)
    full = simulate_jacobian(model, torch.stack([u, 0.8 * u]), t, values=P, substeps=2)
    from hybridhyst.simulate import Prepared, SimulationSettings

    prepared = Prepared(model, torch.stack([u, 0.8 * u]), t, settings=SimulationSettings(backend="fast", substeps=2))
    alone = prepared.jacobian(P, needed={("backlash", "r")})
    j = full[2].index(("backlash", "r"))
    assert bool(full[1][..., j].abs().max() > 0.1) and torch.equal(alone[1][..., j], full[1][..., j])
    with pytest.raises(ValueError, match="no parameter"):
        prepared.jacobian(P, needed={("backlash", "gap")})


def _assert_jacobian(model, u, t):
    with torch.no_grad():
        P = model.evaluate(None, 2)
    values = {k: {n: v.detach().clone().requires_grad_(True) for n, v in d.items()} for k, d in P.items()}
    y, dy, keys = simulate_jacobian(model, u, t, values=values, substeps=2)
    ref = simulate(model, u, t=t, values=values, substeps=2)
    assert ((y - ref.detach()).abs().max() / ref.abs().max()).item() < RTOL
    assert sorted(keys) == sorted((k, n) for k, d in P.items() for n in d)
    w = torch.randn(ref.shape, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    grads = torch.autograd.grad((ref * w).sum(), [values[k][n] for k, n in keys], allow_unused=True)
    got = (w[..., None] * dy).sum(dim=(1, 2))  # (rows, parameters)
    for j, g in enumerate(grads):
        expected = torch.zeros(2, dtype=torch.float64) if g is None else g
        assert torch.allclose(got[:, j], expected, rtol=10 * RTOL, atol=10 * RTOL * float(got.abs().max())), keys[j]


def test_prepared_inputs_give_simulate_and_its_jacobian_for_any_leading_rows(float64):
    """``simulate.Prepared`` (the inputs checked and their rates taken once, identification's populations on the
    same records): its simulations and Jacobians are ``simulate``'s and ``simulate_jacobian``'s to the last bit, for
    every row and for the first rows alone (``rows``), with a start state whose derivatives come from reverse mode;
    a simulation nothing differentiates (no gradient asked) gives the differentiable one's numbers."""
    from hybridhyst.simulate import Prepared, SimulationSettings

    model = Constitutive({"spring": EFFECTS["linear_stiffness"](k=2.0),
                          "dahl": EFFECTS["dahl"](sigma0=30.0, Fc=1.0, z0=0.1)}).double()
    t = torch.arange(300) * 2e-3
    u = torch.stack([a * torch.sin(2 * math.pi * 2.0 * t) for a in (0.5, 0.8, 1.1)])
    with torch.no_grad():
        P = model.evaluate(None, 3)
    P["dahl"]["z0"] = torch.tensor([0.2, -0.3, 0.5], dtype=torch.float64)
    sim = SimulationSettings(backend="fast", substeps=2)
    prepared = Prepared(model, u, t, settings=sim)
    for n in (3, 2):
        rows = prepared.rows(n) if n < 3 else prepared
        values = {k: {name: v[:n] for name, v in d.items()} for k, d in P.items()}
        assert torch.equal(rows.simulate(values), simulate(model, u[:n], t, values=values, settings=sim))
        got, want = rows.jacobian(values), simulate_jacobian(model, u[:n], t, values=values, settings=sim)
        assert torch.equal(got[0], want[0]) and torch.equal(got[1], want[1]) and got[2] == want[2]
        assert bool(got[1][..., want[2].index(("dahl", "z0"))].abs().sum() > 0)  # the start state's derivative
    grad = {k: {name: v.clone().requires_grad_(True) for name, v in d.items()} for k, d in P.items()}
    assert torch.equal(prepared.simulate(grad).detach(), prepared.simulate(P))
    # derivatives asked for only: the same columns to the last bit (one reaching the state, one at the output only,
    # one through the start state alone), the others 0
    y, dy, keys = prepared.jacobian(P)
    for needed in ({("dahl", "Fc"), ("spring", "k"), ("dahl", "z0")}, {("spring", "k")}, set()):
        y2, dy2, _ = prepared.jacobian(P, needed=needed)
        asked = torch.tensor([key in needed for key in keys])
        assert torch.equal(y2, y) and torch.equal(dy2[..., asked], dy[..., asked])
        assert not bool(dy2[..., ~asked].any())


@pytest.mark.parametrize("structure", ["constitutive", "oscillator"])
def test_jacobian_of_an_input_delay(structure, float64):
    """A delay moves the input itself: its column is the derivative through the linearly interpolated input (every
    channel held before t0), carried through a state and into the output like any other column; against
    the reference loop's adjoint, which differentiates the same interpolation. Two delays add (both columns)."""
    effects = {"delay": EFFECTS["time_delay"](tau=0.013), "dahl": EFFECTS["dahl"](sigma0=30.0, Fc=1.0),
               "viscous": EFFECTS["viscous"](c=0.4), "late": EFFECTS["time_delay"](tau=0.004),
               "spring": EFFECTS["linear_stiffness"](k=2.0)}
    model = Constitutive(effects) if structure == "constitutive" else DrivenOscillator(effects, mass=0.05)
    assert jacobian_covers(model)
    u, t = _every_effect_input()
    _assert_jacobian(model.double(), torch.stack([u, 0.8 * u]), t)


@pytest.mark.parametrize("samples", [0, 3])
def test_a_delay_on_a_whole_sample_takes_the_slope_a_longer_delay_reads(samples, float64):
    """On a whole number of samples (τ = 0 is the delay candidate's neutral start) the interpolated input has a
    kink: the column is the derivative for τ growing (the interval before each sample, 0 where the held start is
    read), the direction a fit from there can move, not the other side's."""
    dt = 2.0**-8  # whole samples exact in binary: t − τ lands on a sample, not an ulp beside it
    t = torch.arange(300) * dt
    u = torch.sin(2 * math.pi * 1.3 * t) + 0.3 * torch.sin(2 * math.pi * 3.1 * t + 1.0)
    U = torch.stack([u, 0.8 * u])

    def model(tau):
        return Constitutive({"delay": EFFECTS["time_delay"](tau=tau), "viscous": EFFECTS["viscous"](c=0.4),
                             "spring": EFFECTS["linear_stiffness"](k=2.0)}).double()

    m = model(samples * dt)
    with torch.no_grad():
        values = m.evaluate(None, 2)
    _, dy, keys = simulate_jacobian(m, U, t, values=values)
    column = dy[..., 0, keys.index(("delay", "tau"))]
    h = 1e-7 * dt
    y0, longer, shorter = (simulate(model(max(samples * dt + e, 0.0)), U, t=t)[..., 0].detach() for e in (0.0, h, -h))
    right = (longer - y0) / h
    assert float((column - right).abs().max()) < 1e-4 * float(right.abs().max())
    if samples:  # the other side differs: the kink is real
        assert float((column - (y0 - shorter) / h).abs().max()) > 1e-2 * float(right.abs().max())


def test_jacobian_of_a_delay_with_a_control_channel(float64):
    """The delay reads the input late, not the control channels (they are not delayed): the column of a delay in
    a model whose parameter follows a control is still the reference's."""
    from hybridhyst.physics.parameters import Linear

    model = Constitutive({"delay": EFFECTS["time_delay"](tau=0.009),
                          "viscous": EFFECTS["viscous"](c=Linear(0.5, 0.3, condition="volts"))}).double()
    u, t = _every_effect_input()
    volts = (1.0 + 0.5 * torch.sin(2 * math.pi * 0.7 * t)).expand(2, -1)
    with torch.no_grad():
        P = model.evaluate({"volts": volts}, 2)
    values = {k: {n: v.detach().clone().requires_grad_(True) for n, v in d.items()} for k, d in P.items()}
    U = torch.stack([u, 0.8 * u])
    y, dy, keys = simulate_jacobian(model, U, t, values=values, conditions={"volts": volts}, substeps=2)
    ref = simulate(model, U, t=t, values=values, conditions={"volts": volts}, substeps=2)
    assert ((y - ref.detach()).abs().max() / ref.abs().max()).item() < RTOL
    w = torch.randn(ref.shape, generator=torch.Generator().manual_seed(2), dtype=torch.float64)
    (g,) = torch.autograd.grad((ref * w).sum(), [values["delay"]["tau"]])
    got = (w[..., None] * dy).sum(dim=(1, 2))[:, keys.index(("delay", "tau"))]
    assert torch.allclose(got, g, rtol=10 * RTOL, atol=1e-12)


# -- the C build: errors, cache, threads -------------------------------------------------------------------------


def test_tanh_in_the_equations_is_real_by_declaration_and_printed_as_c_tanh():
    """``symbolic.Tanh``: sympy's ``tanh`` cannot say whether tanh of a function it does not know is real (and, on a
    long argument, spent tens of seconds per model trying); the equations' tanh says yes at once, differentiates as
    tanh does and is printed as C's ``tanh``."""
    import sympy as sp

    from hybridhyst.physics.symbolic import Step, Tanh
    from hybridhyst.simulate.fast.codegen import _Printer

    x = sp.Symbol("x", real=True)
    arg = Step(x) * x + sp.Function("f")(x)
    assert sp.tanh(arg).is_real is None and Tanh(arg).is_real is True
    assert sp.simplify(sp.diff(Tanh(3 * x), x) - sp.diff(sp.tanh(3 * x), x).rewrite(sp.tanh)) == 0
    assert _Printer().doprint(Tanh(x / 2)) == "tanh((1.0/2.0)*x)"


def test_shared_sums_and_skipped_zero_derivatives_leave_the_source_as_sympy_writes_it(monkeypatch):
    """Source generation shares ``gcd_terms`` results between equal sums (``codegen._shared_gcd_terms``), keeps each
    expression's free symbols (``codegen._shared_free_symbols``) and writes a Jacobian entry whose symbol the
    expression lacks as 0 without asking sympy: the C source must be the one sympy's own functions give, sympy asked
    once per distinct sum, and its module left as it was (also when the generation fails)."""
    import contextlib

    import sympy as sp
    from sympy.core import exprtools
    from sympy.core.basic import Basic

    free_symbols = Basic.__dict__["free_symbols"]

    from hybridhyst.simulate.fast import codegen
    from hybridhyst.simulate.fast.equations import build_equations

    names = ["backlash", "bouc_wen", "lugre", "stribeck", "travel_drift"]  # a play, hysteresis, friction, a drift
    eq = build_equations(Constitutive({n: EFFECTS[n](**EFFECT_VALUES[n]) for n in names}).double())
    original = exprtools.gcd_terms

    def generate(shared: bool) -> tuple[str, list]:
        calls = []

        def counting(terms, *args, **kwargs):
            calls.append(terms)
            return original(terms, *args, **kwargs)

        with monkeypatch.context() as m:
            m.setattr(exprtools, "gcd_terms", counting)
            if not shared:
                m.setattr(codegen, "_shared_gcd_terms", contextlib.nullcontext)
                m.setattr(codegen, "_shared_free_symbols", contextlib.nullcontext)
                m.setattr(codegen, "_jac", lambda exprs, wrt, name: [
                    (f"{name}[{i * len(wrt) + j}]", sp.diff(e, w))
                    for i, e in enumerate(exprs) for j, w in enumerate(wrt)])
            source = codegen.generate_source(eq)
            assert exprtools.gcd_terms is counting  # put back as it was found
        return source, calls

    ours, asked = generate(shared=True)
    theirs, asked_by_sympy = generate(shared=False)
    assert ours == theirs
    assert asked and len(asked) == len(set(asked)) < len(asked_by_sympy)
    assert exprtools.gcd_terms is original and Basic.__dict__["free_symbols"] is free_symbols

    # the free symbols kept: the same answer, a set of its own at each call (sympy's callers change theirs)
    x, y, z = sp.symbols("x y z")
    expr = sp.exp(x * y) + z
    with codegen._shared_free_symbols():
        first = expr.free_symbols
        first.add(sp.Symbol("w"))
        assert expr.free_symbols == {x, y, z} and (x * z).free_symbols == {x, z}
    assert Basic.__dict__["free_symbols"] is free_symbols

    # two generations at once (as prebuild runs them in threads): the second waits while the first holds the swap,
    # and sympy's own function is back after both (the second must not take the first's for sympy's)
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    inside, source = threading.Event(), codegen._source

    def slow(eq, kind):
        inside.set()
        time.sleep(0.3)
        return source(eq, kind)

    monkeypatch.setattr(codegen, "_source", slow)
    with ThreadPoolExecutor(2) as pool:
        first = pool.submit(codegen.generate_source, eq)
        inside.wait(10)
        second = pool.submit(codegen.generate_source, eq)
        assert first.result() == second.result() == ours
    assert exprtools.gcd_terms is original

    # inside the swap, every call answers as sympy's own: other flags, a list of terms, sympy's evaluate switch
    x, y, z = sp.symbols("x y z")
    terms = 2 * x * y + 2 * x * z + 4 * x
    with codegen._shared_gcd_terms():
        shared = exprtools.gcd_terms
        for flags in [(True, False, False), (False, True, True), (False, False, True)]:
            assert shared(terms, *flags) == original(terms, *flags)
        assert shared([x * y, x * z]) == original([x * y, x * z])
        with sp.evaluate(False):
            unevaluated = shared(terms, True, False, False)
        assert shared(terms, True, False, False) == original(terms, True, False, False) != unevaluated

    def boom(eq, kind):
        raise RuntimeError("generation failed")

    monkeypatch.setattr(codegen, "_source", boom)
    with pytest.raises(RuntimeError, match="generation failed"):
        codegen.generate_source(eq)
    assert exprtools.gcd_terms is original and Basic.__dict__["free_symbols"] is free_symbols


def test_no_c_compiler_is_one_clear_error(monkeypatch):
    from hybridhyst.simulate.fast import build

    monkeypatch.setattr(build.shutil, "which", lambda name: None)
    with pytest.raises(RuntimeError, match="C compiler.*backend='reference'"):
        build.compiler()


def test_a_compiler_that_does_not_know_a_flag_builds_without_it(tmp_path, monkeypatch):
    """The loops are built without inlining a function called once whatever its size (``build._ONCE``), where the
    compiler takes the flag; one that rejects it, or warns about it, builds without it."""
    import subprocess

    from hybridhyst.simulate.fast import build

    fussy = tmp_path / "fussy-cc"
    fussy.write_text('#!/bin/sh\nfor a in "$@"; do [ "$a" = "-fno-inline-functions-called-once" ] && '
                     'echo "unknown argument: $a" >&2; done\nexec cc "$@"\n')
    fussy.chmod(0o755)
    build._flags.cache_clear()
    try:
        version = subprocess.run([build.compiler(), "--version"], capture_output=True, text=True).stdout
        if "Free Software Foundation" in version:  # gcc takes it
            assert build._ONCE in build._flags()
        build._flags.cache_clear()
        monkeypatch.setenv("CC", str(fussy))
        assert build._ONCE not in build._flags() and build.OPT in build._flags()
    finally:
        build._flags.cache_clear()


def test_a_failing_build_names_the_command_and_the_compiler_message(tmp_path, monkeypatch):
    from hybridhyst.simulate.fast import build

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path))
    with pytest.raises(RuntimeError, match="(?s)building the model.s compiled loops failed.*error"):
        build._build("this is not C;\n", "broken")
    assert not list((tmp_path / "fast").glob("*.so"))  # nothing half-built is left to be loaded later


def test_a_model_is_built_once_and_found_again_in_the_disk_cache(tmp_path, monkeypatch, float64):
    from hybridhyst.simulate.fast import build, function

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path))
    monkeypatch.setattr(build, "_MODULES", {})
    monkeypatch.setattr(function, "_COMPILED", {})
    model = DrivenOscillator({"spring": EFFECTS["linear_stiffness"](k=3.0), "coulomb": EFFECTS["coulomb"](Fc=0.2)})
    u = torch.sin(torch.linspace(0, 6, 80)).double()[None]
    t = torch.linspace(0, 6, 80).double()
    first = simulate(model.double(), u, t=t, backend="fast")
    libs = list((tmp_path / "fast").glob("hh_*.so"))
    assert len(libs) == 1
    built = libs[0].stat().st_mtime_ns
    build._MODULES.clear()  # a new process: the library is loaded, not built again
    function._COMPILED.clear()
    again = simulate(model, u, t=t, backend="fast")
    assert torch.equal(first, again) and libs[0].stat().st_mtime_ns == built


def test_each_loop_is_built_when_a_call_first_needs_it(tmp_path, monkeypatch, float64):
    """Values build the forward loop alone (their source has no Jacobian kernel); a gradient adds the adjoint, a
    Jacobian the forward sensitivities, both from one generated derivatives source; a new process finds all three
    in the disk cache without generating anything."""
    from hybridhyst.simulate.fast import build, codegen, function

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path))
    monkeypatch.setattr(build, "_MODULES", {})
    monkeypatch.setattr(function, "_COMPILED", {})
    generated = []
    monkeypatch.setattr(build, "generate_source", lambda eq, kind: generated.append(kind) or
                        codegen.generate_source(eq, kind))
    model = Constitutive({"viscous": EFFECTS["viscous"](c=0.3), "dahl": EFFECTS["dahl"](**EFFECT_VALUES["dahl"])})
    u, t = _every_effect_input()
    y = simulate(model, u[None], t=t, backend="fast")
    assert generated == ["values"] and len(list((tmp_path / "fast").glob("hh_*.so"))) == 1
    (module,) = build._MODULES.values()
    assert set(module._fns) == {"forward"}
    params = [p for p in model.parameters() if p.requires_grad]
    torch.autograd.grad(simulate(model, u[None], t=t, backend="fast").square().sum(), params)
    with torch.no_grad():
        values = model.evaluate(None, 1)
    simulate_jacobian(model, u[None], t, values=values)
    assert generated == ["values", "derivatives"] and set(module._fns) == {"forward", "backward", "tangent"}
    assert len(list((tmp_path / "fast").glob("hh_*.so"))) == 3  # the derivatives source generated once, read back
    with pytest.raises(ValueError, match="unknown source"):
        codegen.generate_source(module.eq, "everything")

    build._MODULES.clear()  # a new process
    function._COMPILED.clear()
    again = simulate(model, u[None], t=t, backend="fast")
    torch.autograd.grad(simulate(model, u[None], t=t, backend="fast").square().sum(), params)
    simulate_jacobian(model, u[None], t, values=values)
    assert torch.equal(y, again) and generated == ["values", "derivatives"]

    # another optimisation level finds its own libraries, not those built at this one
    build._MODULES.clear()
    function._COMPILED.clear()
    monkeypatch.setattr(build, "OPT", "-O2")
    build._flags.cache_clear()
    build._settings_key.cache_clear()
    try:
        assert torch.equal(simulate(model, u[None], t=t, backend="fast"), y)
        assert len(list((tmp_path / "fast").glob("hh_*.so"))) == 4
    finally:
        build._flags.cache_clear()
        build._settings_key.cache_clear()


def test_values_hoisted_out_of_the_kernels_leave_every_number_as_it_was(tmp_path, monkeypatch, float64):
    """Powers and functions of the parameters alone are evaluated once per row (``codegen._Printer``'s hoisting, the
    loops' ``with_hoisted``) instead of at every stage: values, adjoint gradients and forward sensitivities are the
    same to the last bit as from kernels that evaluate them in place (LuGre's 1/vs² and vs³, Bouc–Wen's exponent
    and levels, a play's bound in an oscillator: the kernels of every loop)."""
    from hybridhyst.simulate.fast import build, codegen, function

    model = DrivenOscillator({"backlash": EFFECTS["backlash"](r=0.05), "spring": EFFECTS["linear_stiffness"](k=2.0),
                              "lugre": EFFECTS["lugre"](**EFFECT_VALUES["lugre"]),
                              "bouc_wen": EFFECTS["bouc_wen"](**EFFECT_VALUES["bouc_wen"])}, mass=0.5).double()
    u, t = _every_effect_input()
    u = torch.stack([u, 0.7 * u])
    with torch.no_grad():
        P = model.evaluate(None, 2)

    def numbers():
        monkeypatch.setattr(build, "_MODULES", {})
        monkeypatch.setattr(function, "_COMPILED", {})
        values = {k: {n: v.detach().clone().requires_grad_(True) for n, v in d.items()} for k, d in P.items()}
        y = simulate(model, u, t=t, values=values, substeps=2, backend="fast")
        leaves = [v for d in values.values() for v in d.values()]
        grads = torch.autograd.grad((y * torch.cos(torch.arange(y.numel()).reshape(y.shape))).sum(), leaves,
                                    allow_unused=True)
        return [y.detach(), *[g for g in grads if g is not None], *simulate_jacobian(model, u, t, values=P,
                                                                                      substeps=2)[:2]]

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path / "hoisted"))
    hoisted = numbers()

    def rhs_source() -> str:
        source = codegen.generate_source(function.compiled(model)[0])
        return source.split("static inline void rhs(")[1].split("}")[0]

    assert "pow(th" not in rhs_source()  # read, not evaluated

    class InPlace(codegen._Printer):
        def __init__(self, params=(), first=0):
            super().__init__()

    monkeypatch.setattr(codegen, "_Printer", InPlace)
    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path / "in_place"))
    in_place = numbers()
    assert "pow(th" in rhs_source()
    assert len(hoisted) == len(in_place) > 3
    for a, b in zip(hoisted, in_place):
        assert torch.equal(a, b)


def test_rows_spread_over_threads_give_the_same_numbers_as_one_thread(monkeypatch, float64):
    from hybridhyst.simulate.fast import build

    model = COMPOSITIONS["bouc_wen_classic"]().double()
    t = torch.arange(300) * 1e-3
    u = torch.sin(2 * math.pi * 5 * t[None] + torch.linspace(0, 3, 7)[:, None])
    monkeypatch.setattr(build, "_MIN_ROW_WORK", 1)

    def run(threads):
        monkeypatch.setenv("HYBRIDHYST_FAST_THREADS", str(threads))
        p = [q for q in model.parameters() if q.requires_grad]
        y = simulate(model, u, t=t, backend="fast", substeps=2)
        return (y, *torch.autograd.grad(y.square().sum(), p))

    for a, b in zip(run(1), run(3)):
        assert torch.equal(a, b)


def test_threads_asking_for_a_new_loop_at_once_build_it_once(tmp_path, monkeypatch, float64):
    """The rows' threads, prebuild's and discovery's worker threads may ask for a loop of the same model at once: one
    builds it (its source generated once), the others wait for it and get the same function."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from hybridhyst.simulate.fast import build, codegen
    from hybridhyst.simulate.fast.equations import build_equations

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path))
    monkeypatch.setattr(build, "_MODULES", {})
    generated, lock = [], threading.Lock()

    def slow(eq, kind):
        with lock:
            generated.append(kind)
        time.sleep(0.2)  # long enough for every thread to ask while the first generates
        return codegen.generate_source(eq, kind)

    monkeypatch.setattr(build, "generate_source", slow)
    eq = build_equations(Constitutive({"dahl": EFFECTS["dahl"](**EFFECT_VALUES["dahl"])}).double())
    module = build._compiled(eq)
    with ThreadPoolExecutor(4) as pool:
        fns = list(pool.map(lambda _: module.load("tangent"), range(4)))
    assert generated == ["derivatives"] and all(f is fns[0] for f in fns)
    assert len(list((tmp_path / "fast").glob("hh_*.so"))) == 1


def test_prebuild_builds_several_models_side_by_side(tmp_path, monkeypatch, float64):
    from hybridhyst.simulate.fast import build, function, prebuild_models

    monkeypatch.setenv("HYBRIDHYST_CACHE", str(tmp_path))
    monkeypatch.setattr(build, "_MODULES", {})
    monkeypatch.setattr(function, "_COMPILED", {})
    models = [Constitutive({"viscous": EFFECTS["viscous"](c=0.3), name: EFFECTS[name](**EFFECT_VALUES[name])})
              for name in ("dahl", "coulomb", "stribeck", "time_delay")]
    prebuild_models(models)
    # the loops a candidate's fit runs: the values and the forward sensitivities (no adjoint), a delay's too
    assert len(list((tmp_path / "fast").glob("hh_*.so"))) == 8
    assert len(build._MODULES) == 4
    assert sorted(tuple(sorted(m._fns)) for m in build._MODULES.values()) == [("forward", "tangent")] * 4


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here (the GPU machine runs it)")
def test_fast_path_takes_and_returns_cuda_tensors_with_the_cpu_numbers(float64):
    model = COMPOSITIONS["bouc_wen_classic"]().double()
    t = torch.arange(200) * 1e-3
    u = torch.sin(2 * math.pi * 5 * t).expand(3, -1)
    cpu = simulate(model, u, t=t, backend="fast")
    g_cpu = torch.autograd.grad(cpu.square().sum(), [p for p in model.parameters() if p.requires_grad])
    model.cuda()
    gpu = simulate(model, u.cuda(), t=t.cuda(), backend="fast")
    g_gpu = torch.autograd.grad(gpu.square().sum(), [p for p in model.parameters() if p.requires_grad])
    assert gpu.device.type == "cuda" and torch.allclose(gpu.cpu(), cpu, rtol=1e-12, atol=0)
    for a, b in zip(g_cpu, g_gpu):
        assert torch.allclose(b.cpu(), a, rtol=1e-10, atol=0)


def test_the_compiled_loops_refuse_arrays_of_another_shape_or_type(float64):
    """The C loops index raw memory: a wrong shape or dtype is a ValueError before any memory is touched."""
    import numpy as np

    from hybridhyst.simulate.fast.function import _tableau, compiled

    model = COMPOSITIONS["bouc_wen_classic"]().double()
    eq, module = compiled(model)
    B, T, S, P = 2, 10, len(eq.state), len(eq.params)
    c, A, bw = _tableau("rk4")
    ok = dict(U=np.zeros((B, T, 3)), h=np.full((B, T - 1), 1e-3), th=np.ones((B, P)), s0=np.zeros((B, S)),
              states=np.empty((B, T, S)), y=np.empty((B, T, 1)))
    module.forward(ok["U"], ok["h"], ok["th"], ok["s0"], c, A, bw, 1, ok["states"], ok["y"])
    for key, bad in (("h", np.zeros((B, T))), ("th", np.ones((B, P - 1))), ("y", np.empty((B, T, 2))),
                     ("U", np.zeros((B, T, 3), dtype=np.float32)), ("U", np.zeros((B, 3, T)).transpose(0, 2, 1))):
        args = {**ok, key: bad}
        with pytest.raises(ValueError, match=f"{key} must be|th has"):
            module.forward(args["U"], args["h"], args["th"], args["s0"], c, A, bw, 1, args["states"], args["y"])


def test_jacobian_from_a_given_start(float64):
    """``simulate_jacobian(initial_state=...)``: a given [x, v] leaves the effects' start states (and their
    derivatives w.r.t. the parameters) the model's own; a whole state is held fixed. Both against the adjoint."""
    model = DrivenOscillator({"dahl": EFFECTS["dahl"](sigma0=10.0, Fc=0.5),
                              "spring": EFFECTS["linear_stiffness"](k=4.0)}, mass=0.3).double()
    t = torch.linspace(0.0, 2.0, 301)
    u = torch.stack([torch.sin(3.0 * t), 0.5 * torch.sin(5.0 * t)])
    with torch.no_grad():
        P = model.evaluate(None, 2)
    for start in (torch.tensor([[0.1, -0.2], [0.0, 0.3]]), torch.tensor([[0.1, -0.2, 0.05], [0.0, 0.3, -0.1]])):
        values = {k: {n: v.detach().clone().requires_grad_(True) for n, v in d.items()} for k, d in P.items()}
        y, dy, keys = simulate_jacobian(model, u, t, values=values, initial_state=start)
        ref = simulate(model, u, t=t, values=values, initial_state=start)
        assert ((y - ref.detach()).abs().max() / ref.abs().max()).item() < RTOL
        w = torch.randn(ref.shape, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
        grads = torch.autograd.grad((ref * w).sum(), [values[k][n] for k, n in keys], allow_unused=True)
        got = (w[..., None] * dy).sum(dim=(1, 2))
        for j, g in enumerate(grads):
            expected = torch.zeros(2, dtype=torch.float64) if g is None else g
            assert torch.allclose(got[:, j], expected, rtol=10 * RTOL, atol=10 * RTOL * float(got.abs().max())), keys[j]
