"""The neural effect and the in-the-loop hybrid: exactly the nominal at zero output, exact gradients, placement."""

import numpy as np
import pytest
import torch

from hybridhyst.data.datamodule import RecordDataModule
from hybridhyst.data.records import Record
from hybridhyst.physics.effects import EFFECTS, NeuralEffect
from hybridhyst.physics.models import Constitutive, DrivenOscillator
from hybridhyst.simulate import simulate
from hybridhyst.training.modules import HybridModule

pytestmark = pytest.mark.usefixtures("float64")


def _damper():
    return Constitutive({"spring": EFFECTS["linear_stiffness"](k=2.0), "dahl": EFFECTS["dahl"](sigma0=10.0, Fc=0.5),
                         "viscous": EFFECTS["viscous"](c=0.1)}).double()


def _oscillator():
    return DrivenOscillator({"spring": EFFECTS["linear_stiffness"](k=400.0),
                             "viscous": EFFECTS["viscous"](c=2.0)}, mass=1.0).double()


def _neural(latent=2, conditions=True):
    return NeuralEffect(latent_states=latent, hidden="2x8", scales={"x": 1.0, "v": 6.0, "F": 1.0},
                        conditions={"p": (0.05, 0.02)} if conditions else None).double()


def _inputs():
    """One cycle (two reversals: the play engages both ways) of three amplitudes, 151 samples."""
    t = torch.linspace(0.0, 1.0, 151)
    x = torch.stack([a * torch.sin(2 * torch.pi * t) for a in (0.5, 1.0, 1.5)])
    return t, x, {"p": torch.tensor([0.03, 0.05, 0.07])}


@pytest.mark.parametrize("make", [_damper, _oscillator])
def test_zero_network_gives_exactly_the_nominal(make):
    nominal = make()
    t, x, cond = _inputs()
    hybrid = nominal.augmented({"neural": _neural()})
    assert hybrid.state_dim == nominal.state_dim + 2
    y_nom = simulate(nominal, x, t=t, conditions=cond)
    y_hyb = simulate(hybrid, x, t=t, conditions=cond)
    assert torch.equal(y_nom, y_hyb)  # bit for bit: the network's last layer is zero
    # the same on the compiled path, which runs the network in its generated code
    assert torch.equal(simulate(hybrid, x, t=t, conditions=cond, backend="fast"),
                       simulate(nominal, x, t=t, conditions=cond, backend="fast"))


def _five_networks(structure):
    """One network per activation, with and without latent states (free and Duhem's form), reading x, v, u, du
    and a condition;
    behind a play (a bounded state) and beside a Dahl element: one compilation covers every code path."""
    torch.manual_seed(3)
    nets = {
        "n_tanh": NeuralEffect(latent_states=2, hidden="2x6", scales={"x": 0.5, "v": 3.0, "F": 0.4},
                               conditions={"p": (0.05, 0.02)}),
        "n_relu": NeuralEffect(inputs=("x", "v", "u", "du"), hidden=[5, 4], activation="relu",
                               scales={"x": 0.5, "v": 3.0, "u": 0.7, "du": 4.0, "F": 0.3}),
        "n_gelu": NeuralEffect(latent_states=1, hidden="1x5", activation="gelu", scales={"F": 0.2},
                               latent_form="duhem"),
        "n_silu": NeuralEffect(inputs=("v",), hidden="1x4", activation="silu", scales={"v": 3.0, "F": 0.2}),
        "n_elu": NeuralEffect(inputs=("x", "du"), hidden="1x4", activation="elu", scales={"x": 0.5, "F": 0.2}),
    }
    for net in nets.values():
        for p in net.net.parameters():
            p.data.normal_(0.0, 0.6)
    effects = {"backlash": EFFECTS["backlash"](r=0.05), "spring": EFFECTS["linear_stiffness"](k=2.0),
               "dahl": EFFECTS["dahl"](sigma0=10.0, Fc=0.5), **nets}
    if structure == "constitutive":
        return Constitutive(effects).double()
    return DrivenOscillator(effects, mass=0.3, excitation="base").double()


@pytest.mark.parametrize("structure", ["constitutive", "oscillator"])
def test_compiled_path_equals_the_reference_with_networks(structure):
    """Values and gradients (every weight, the physical parameters, the input and the initial state) of the
    compiled path with networks in its generated code against autograd through the reference loop."""
    model = _five_networks(structure)
    t, x, cond = _inputs()
    x = x.clone().requires_grad_(True)
    s0 = (0.1 * torch.randn(3, model.state_dim, generator=torch.Generator().manual_seed(1))).requires_grad_(True)
    kw = {"t": t, "conditions": cond, "initial_state": s0, "substeps": 2}
    ref = simulate(model, x, **kw)
    fast = simulate(model, x, backend="fast", **kw)
    assert ((fast - ref).abs().max() / ref.abs().max()).item() < 1e-10
    w = torch.randn_like(ref, generator=torch.Generator().manual_seed(2))
    wrt = [*model.parameters(), x, s0]
    g_ref = torch.autograd.grad((ref * w).sum(), wrt)
    g_fast = torch.autograd.grad((fast * w).sum(), wrt)
    for gr, gf in zip(g_ref, g_fast):
        assert gr.abs().max() > 0  # every weight and input reaches the output
        assert ((gf - gr).abs().max() / gr.abs().max()).item() < 1e-8


def _output_network():
    """A network at the output only (no latent state) beside a Dahl element: the state tangent carries Dahl's
    two parameters, and none of the spring's, the viscous term's or the network's weights."""
    torch.manual_seed(4)
    net = NeuralEffect(inputs=("x", "v"), hidden="1x6", scales={"x": 1.0, "v": 6.0, "F": 0.5}).double()
    for p in net.net.parameters():
        p.data.normal_(0.0, 0.6)
    return _damper().augmented({"neural": net})


@pytest.mark.parametrize("case", ["constitutive", "oscillator", "output network"])
def test_forward_sensitivities_with_networks_equal_the_adjoint(case):
    """``simulate_jacobian(..., weights=True)``: the derivatives of every output sample w.r.t. every parameter
    value and every network weight in one forward pass, against autograd through the reference loop: per row,
    w · dy equals the gradient of w · y (weights: summed over the rows, which share them); every network,
    activation, Duhem's form, a play and sub-steps in the loop; a given initial state is held fixed. And where
    only some columns reach the state (a network at the output, a spring, a viscous term), the loop's state
    tangent leaves the others out with the same derivatives."""
    from hybridhyst.simulate import simulate_jacobian
    from hybridhyst.simulate.fast.codegen import _state_columns
    from hybridhyst.simulate.fast.function import compiled, weight_columns

    model = _output_network() if case == "output network" else _five_networks(case)
    if case == "output network":
        eq, _ = compiled(model)
        live, rhs_nets = _state_columns(eq)
        assert not rhs_nets
        assert [key for key, flag in zip(eq.param_keys, live) if flag] == [("dahl", "sigma0"), ("dahl", "Fc")]
    t, x, cond = _inputs()
    with torch.no_grad():
        P = model.evaluate(cond, 3)
    values = {k: {n: v.detach().clone().requires_grad_(True) for n, v in d.items()} for k, d in P.items()}
    s0 = 0.1 * torch.randn(3, model.state_dim, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    y, dy, keys = simulate_jacobian(model, x, t, values=values, conditions=cond, substeps=2, initial_state=s0,
                                    weights=True)
    ref = simulate(model, x, t=t, values=values, conditions=cond, substeps=2, initial_state=s0, backend="reference")
    assert ((y - ref.detach()).abs().max() / ref.abs().max()).item() < 1e-10
    columns = [w for _, ws in weight_columns(model) for w in ws]
    assert dy.shape[-1] == len(keys) + sum(w.numel() for w in columns)
    w = torch.randn(ref.shape, generator=torch.Generator().manual_seed(2), dtype=torch.float64)
    grads = torch.autograd.grad((ref * w).sum(), [values[k][n] for k, n in keys] + columns, allow_unused=True)
    got = (w[..., None] * dy).sum(dim=(1, 2))  # (rows, columns)
    expected = [torch.zeros(3, dtype=torch.float64) if g is None else g for g in grads[: len(keys)]]
    expected = torch.cat([torch.stack(expected, dim=1), torch.cat([g.reshape(-1) for g in grads[len(keys):]])
                          .expand(3, -1)], dim=1)
    got[:, len(keys):] = got[:, len(keys):].sum(0)  # the weights are shared by the rows
    assert float((expected[0, len(keys):] != 0).double().mean()) > 0.9  # (a relu unit may be off throughout)
    assert ((got - expected).abs().max() / expected.abs().max()).item() < 1e-8


def test_compiled_network_follows_new_scales():
    """The scales are constants of the generated code: a state dict that changes them recompiles."""
    model = _damper().augmented({"neural": _neural(conditions=False)})
    for p in model.effects["neural"].net.parameters():
        p.data.normal_(0.0, 0.3, generator=torch.Generator().manual_seed(0))
    t, x, _ = _inputs()
    simulate(model, x, t=t, backend="fast")
    state = model.state_dict()
    state["effects.neural.input_scale"] = torch.tensor([0.3, 2.0])
    state["effects.neural.force_scale"] = torch.tensor(2.5)
    model.load_state_dict(state)
    ref = simulate(model, x, t=t)
    assert torch.allclose(simulate(model, x, t=t, backend="fast"), ref, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("inputs", [("x", "v"), ("v", "u")])
def test_duhem_latent_states_change_with_travel_not_time(inputs):
    """latent_form="duhem": dz/dt = (v / s_x) N_z. A dwell (the input held) leaves the latent states where they
    are whatever the network, and over a stroke z changes by N_z per s_x of travel (checked on the reference
    loop against the network's own rate; s_x given, or read from v's scale over ω_s)."""
    torch.manual_seed(4)
    net = NeuralEffect(inputs, latent_states=2, hidden="1x6", scales={"x": 0.5, "v": 3.0, "F": 0.2},
                       latent_form="duhem").double()
    for p in net.net.parameters():
        p.data.normal_(0.0, 0.5)
    assert float(net.travel_scale()) == pytest.approx(0.5)
    model = Constitutive({"spring": EFFECTS["linear_stiffness"](k=2.0), "neural": net}).double()
    t = torch.linspace(0.0, 2.0, 401)
    x = torch.where(t < 1.0, torch.sin(torch.pi * t / 2.0), torch.ones_like(t))[None]  # a stroke, then a dwell
    for backend in ("reference", "fast"):
        _, states = simulate(model, x, t=t, return_states=True, backend=backend, substeps=4)
        dwell = states[0, t > 1.05]
        assert (dwell - dwell[0]).abs().max() < 1e-12  # standing still: no motion, no change
        assert (states[0, 200] - states[0, 0]).abs().max() > 1e-2  # moved: it changed
    free = NeuralEffect(inputs, latent_states=2, hidden="1x6", scales={"x": 0.5, "v": 3.0, "F": 0.2}).double()
    free.load_state_dict(net.state_dict())
    _, states = simulate(Constitutive({"spring": EFFECTS["linear_stiffness"](k=2.0), "neural": free}).double(),
                         x, t=t, return_states=True, substeps=4, backend="fast")
    assert (states[0, -1] - states[0, 220]).abs().max() > 1e-3  # the free form drifts during the dwell


def test_augmented_model_shares_the_nominal_parameters():
    nominal = _damper()
    hybrid = nominal.augmented({"neural": _neural()})
    assert hybrid.effects["dahl"] is nominal.effects["dahl"]
    assert "neural" not in nominal.effects  # the nominal itself is unchanged
    with pytest.raises(ValueError, match="already has effect"):
        nominal.augmented({"dahl": _neural()})


@pytest.mark.parametrize("make", [_damper, _oscillator])
def test_gradients_are_exact(make):
    """Autograd through the batched loop against central differences, for a network weight, a latent-rate
    weight and a nominal parameter (non-zero network)."""
    torch.manual_seed(0)
    nominal = make()
    net = _neural()
    for p in net.net.parameters():
        p.data.normal_(0.0, 0.3)
    hybrid = nominal.augmented({"neural": net})
    t, x, cond = _inputs()
    if isinstance(nominal, DrivenOscillator):
        x = 100.0 * x  # a force [N] that moves the 400 N/m oscillator by ~0.1-0.4 m

    def loss():
        return simulate(hybrid, x, t=t, conditions=cond).square().mean()

    L0 = loss()
    params = [net.net.head.weight, net.net.body[0].weight, next(iter(nominal.effects["viscous"].parameters()))]
    grads = torch.autograd.grad(L0, params)
    for p, g in zip(params, grads):
        idx = (0,) * p.ndim if p.ndim else ()
        if p.ndim == 2 and p.shape[0] > 1:
            idx = (1, 0)  # a latent state's rate
        h = 1e-6 * max(1.0, abs(float(p.data[idx])))
        with torch.no_grad():
            p.data[idx] += h
            up = float(loss())
            p.data[idx] -= 2 * h
            down = float(loss())
            p.data[idx] += h
        fd = (up - down) / (2 * h)
        assert float(g[idx]) == pytest.approx(fd, rel=1e-5, abs=1e-10)


def test_bad_input_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown input"):
        NeuralEffect(inputs=("x", "acceleration"))
    with pytest.raises(ValueError, match="scale 'F' must be > 0"):
        NeuralEffect(scales={"F": 0.0})
    with pytest.raises(ValueError, match="unknown latent_form"):
        NeuralEffect(latent_states=1, latent_form="rate")
    with pytest.raises(ValueError, match="travel in the scale of x"):
        NeuralEffect(inputs=("u",), latent_states=1, latent_form="duhem")
    hybrid = _damper().augmented({"neural": _neural()})
    t, x, _ = _inputs()
    with pytest.raises(ValueError, match="reads condition"):
        simulate(hybrid, x, t=t)


def _records():
    """A linear oscillator with a saturating (Dahl-type) hysteretic force, integrated by an explicit
    midpoint scheme on a 10x finer grid — none of the library's code."""
    out = []
    for i, amp in enumerate((20.0, 30.0, 40.0)):
        rng = np.random.default_rng(i)
        fs, n, sub = 200.0, 600, 10
        t = np.arange(n) / fs
        u = amp * np.sin(2 * np.pi * 1.5 * t) + 0.3 * amp * np.sin(2 * np.pi * 4.1 * t + 1.0)
        x = v = z = 0.0
        y = np.empty(n)
        h = 1.0 / fs / sub
        for k in range(n):
            y[k] = x
            for j in range(sub):
                uu = np.interp(t[k] + j * h, t, u)

                def f(x, v, z, uu=uu):
                    return v, uu - 2.0 * v - 400.0 * x - 40.0 * z, 50.0 * v - 40.0 * abs(v) * z

                a = f(x, v, z)
                b = f(x + h / 2 * a[0], v + h / 2 * a[1], z + h / 2 * a[2])
                x, v, z = x + h * b[0], v + h * b[1], z + h * b[2]
        out.append(Record(f"r{i}", t, u, y + rng.normal(0, 1e-4, n), conditions={"amp": amp},
                          units={"x": "N", "y": "m"}))
    return out


def test_dynamics_hybrid_starts_at_the_nominal_and_learns_the_missing_force():
    import lightning as L

    torch.manual_seed(0)
    dm = RecordDataModule(_records(), held_out=None, val=[{"amp": [30.0]}], window=96, warmup=16, batch_size=4)
    dm.setup("fit")
    module = HybridModule(_oscillator(), dm.normaliser.to_dict(), hidden="2x16", placement="dynamics",
                          latent_states=1, lr=1e-2, lambda_phys=1e-3)
    batch = next(iter(dm.val_dataloader()))
    module.eval()
    with torch.no_grad():
        out = module(batch)
        assert torch.equal(out["y"], out["nominal"])
    module.train()
    trainer = L.Trainer(max_epochs=6, logger=False, enable_checkpointing=False, enable_progress_bar=False,
                        enable_model_summary=False)
    trainer.validate(module, dm, verbose=False)
    before = float(trainer.callback_metrics["val/rmse"])
    trainer.fit(module, dm)
    after = float(trainer.callback_metrics["val/rmse"])
    assert after < 0.6 * before
    assert "train/phys_loss" in trainer.callback_metrics  # λ_phys weighs the network's force


def test_placement_options_are_checked():
    dm = RecordDataModule(_records()[:2], held_out=None, val=None, window=96, warmup=16)
    dm.setup("fit")
    norm = dm.normaliser.to_dict()
    with pytest.raises(ValueError, match="unknown placement"):
        HybridModule(_oscillator(), norm, placement="inside")
    with pytest.raises(ValueError, match="residual=mlp"):
        HybridModule(_oscillator(), norm, residual="lstm", hidden="1x8", placement="dynamics")
    with pytest.raises(ValueError, match="latent_states belong"):
        HybridModule(_oscillator(), norm, latent_states=2)


def test_identification_fits_the_physical_part_of_a_hybrid_with_its_network_held():
    """identify searches the nominal's coordinates of an augmented model; the network (no physical
    parameters) keeps its weights and still reads its conditions on the batched path."""
    from hybridhyst.identify import identify

    torch.manual_seed(1)
    net = _neural(latent=1)
    for p in net.net.parameters():
        p.data.normal_(0.0, 0.2)
    truth = _damper().augmented({"neural": net})
    t, x, cond = _inputs()
    with torch.no_grad():
        y = simulate(truth, x, t=t, conditions=cond)[..., 0].numpy()
    records = [Record(f"r{i}", t.numpy(), x[i].numpy(), y[i], conditions={"p": float(cond["p"][i])})
               for i in range(3)]
    start = _damper()
    start.effects["viscous"].params["c"].value.data.fill_(0.3)  # truth 0.1
    model = start.augmented({"neural": net})
    res = identify(model, records, search="cma", pop=8, generations=4, fisher=False, progress=False)
    assert res.rmse < 1e-4
    assert float(start.effects["viscous"].params["c"](None, 1)[0]) == pytest.approx(0.1, rel=1e-3)


def test_returned_states_carry_gradients_on_both_backends():
    """The in-the-loop hybrid's physics term reads the simulated states: their gradient must be the same on
    the compiled path as through the reference loop."""
    model = _five_networks("oscillator")
    t, x, cond = _inputs()
    wrt = list(model.parameters())

    def grads(backend):
        y, states = simulate(model, x, t=t, conditions=cond, return_states=True, backend=backend)
        both = torch.autograd.grad(y.square().mean() + states.square().mean(), wrt, retain_graph=True)
        states_only = torch.autograd.grad(states.square().mean(), wrt)
        assert all(s.abs().max() > 0 for s in states_only), backend
        return both

    for gr, gf in zip(grads("reference"), grads("fast")):
        assert ((gf - gr).abs().max() / gr.abs().max()).item() < 1e-8


def test_every_network_activation_has_a_compiled_kernel():
    """An activation added to the networks must be added to the generated code's kernels too."""
    from hybridhyst.nets.blocks import _ACTIVATIONS as NETWORK_ACTIVATIONS
    from hybridhyst.simulate.fast.codegen import _ACTIVATIONS as KERNELS

    assert set(KERNELS) == set(NETWORK_ACTIVATIONS)
