"""Benchmark against what users would pick instead: the gradient of one model's simulation through hybridhyst's
compiled fast path, torchdiffeq (direct back-propagation and the adjoint method) and, where it is installed, JAX
(``jax.jit`` of ``jax.grad`` over ``lax.scan`` with the same classic RK4) — side by side in one run.

The model is the Bouc–Wen benchmark system (Noël & Schoukens 2016, ``physics.compositions.boucwen_benchmark``:
m ÿ + c ẏ + k y + z = u, ż = A ẏ − β|ẏ||z|^(ν−1) z − γ ẏ |z|^ν) driven by a multisine force at 750 Hz, one RK4
step per sample, the force linearly interpolated between samples. The cost is the sum of squared displacement
errors against a reference response; the gradient is taken w.r.t. the six values (m, c, k, A, β, γ). The JAX
model is written by hand here from those equations (JAX has no hybridhyst model); torchdiffeq integrates the
library model's own ``derivative`` (its ``rk4`` is the 3/8-rule variant: its values differ from classic RK4 by the
method's own error, reported below).

Reported per peer: the first call (hybridhyst: the C build of a model never built before, in an empty cache;
JAX: tracing and XLA compilation; torchdiffeq: nothing to build) and the median of later calls, each as a ratio
to hybridhyst's. ``--quick`` is a smoke version (short record, few repeats).

    PYTHONPATH=. python scripts/bench_peers.py --json experiments/performance/bench_peers.json --write-readme
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))  # bench_simulate
FS = 750.0
VALUES = ("m", "c", "k", "A", "beta", "gamma")  # the six values every peer differentiates


def multisine(T: int, B: int, seed: int = 0) -> torch.Tensor:
    """``(B, T)`` random-phase multisine force [N] (5–150 Hz, 50 N RMS per row), as the benchmark's test input."""
    g = np.random.default_rng(seed)
    t = np.arange(T) / FS
    freqs = np.arange(5.0, 150.0, FS / 1024)
    u = np.stack([np.sin(2 * np.pi * freqs[:, None] * t + g.uniform(0, 2 * np.pi, (len(freqs), 1))).sum(0)
                  for _ in range(B)])
    return torch.as_tensor(50.0 * u / u.std(axis=1, keepdims=True))


def true_values() -> dict:
    return {"m": 2.0, "c": 10.0, "k": 5e4, "A": 5e4, "beta": 800.0, "gamma": -1100.0}


def hybridhyst_values(model, B: int, theta: dict) -> dict:
    P = model.evaluate(None, B)
    P["structure"]["mass"] = theta["m"].expand(B)
    P["viscous"]["c"] = theta["c"].expand(B)
    P["stiffness"]["k"] = theta["k"].expand(B)
    for name in ("A", "beta", "gamma"):
        P["hysteresis"][name] = theta[name].expand(B)
    return P


def leaves(start: dict) -> dict:
    return {k: torch.tensor(v, dtype=torch.float64, requires_grad=True) for k, v in start.items()}


def start_values() -> dict:  # 5 % off the truth: a gradient step of a fit
    return {k: v * 1.05 for k, v in true_values().items()}


def hybridhyst_grad(model, u, t, y_ref):
    from hybridhyst.simulate import simulate

    theta = leaves(start_values())
    y = simulate(model, u, t=t, values=hybridhyst_values(model, u.shape[0], theta), backend="fast")[..., 0]
    loss = (y - y_ref).square().sum()
    return loss.detach(), torch.autograd.grad(loss, [theta[k] for k in VALUES]), y.detach()


def torchdiffeq_grad(model, u, t, y_ref, adjoint: bool):
    import torchdiffeq

    from hybridhyst.physics.models import InputSample
    from hybridhyst.simulate.inputs import with_rates

    U = with_rates(u[..., None], t)  # (B, T, 3)
    dt = float(t[1] - t[0])
    theta = leaves(start_values())

    class Field(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.theta = torch.nn.ParameterDict({k: torch.nn.Parameter(v.detach().clone()) for k, v in theta.items()})

        def forward(self, tt, s):
            k = min(int(float(tt) / dt), U.shape[1] - 2)
            fr = float(tt) / dt - k
            x = U[:, k] + (U[:, k + 1] - U[:, k]) * fr
            P = hybridhyst_values(model, s.shape[0], dict(self.theta))
            return model.derivative(s, InputSample(x[:, 0], x[:, 1], x[:, 2]), P)

    field = Field()
    s0 = torch.zeros(u.shape[0], model.state_dim, dtype=torch.float64)
    opts = {"step_size": dt}
    if adjoint:
        states = torchdiffeq.odeint_adjoint(field, s0, t, method="rk4", options=opts,
                                            adjoint_params=tuple(field.parameters()))
    else:
        states = torchdiffeq.odeint(field, s0, t, method="rk4", options=opts)
    y = states[..., 0].T
    loss = (y - y_ref).square().sum()
    return loss.detach(), torch.autograd.grad(loss, [field.theta[k] for k in VALUES]), y.detach()


def jax_program(u: np.ndarray, y_ref: np.ndarray):
    """The benchmark system in JAX: classic RK4 over ``lax.scan``, ``jit`` of ``value_and_grad``."""
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    h = 1.0 / FS

    def field(s, f, th):
        m, c, k, A, beta, gamma = th
        x, v, z = s[..., 0], s[..., 1], s[..., 2]
        zn = jnp.abs(z)  # |z|^ν at ν = 1
        dz = A * v - beta * jnp.abs(v) * zn * jnp.sign(z) - gamma * v * zn
        acc = (f - (c * v + k * x + z)) / m
        return jnp.stack([v, acc, dz], axis=-1)

    def simulate(th, u):
        def step(s, uu):
            u0, u1 = uu
            k1 = field(s, u0, th)
            k2 = field(s + 0.5 * h * k1, 0.5 * (u0 + u1), th)
            k3 = field(s + 0.5 * h * k2, 0.5 * (u0 + u1), th)
            k4 = field(s + h * k3, u1, th)
            s1 = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            return s1, s1[..., 0]

        s0 = jnp.zeros((u.shape[0], 3))
        _, xs = jax.lax.scan(step, s0, (u[:, :-1].T, u[:, 1:].T))
        return jnp.concatenate([jnp.zeros((1, u.shape[0])), xs], axis=0).T

    def loss(th, u, y_ref):
        return jnp.sum((simulate(th, u) - y_ref) ** 2)

    fn = jax.jit(jax.value_and_grad(loss))
    th0 = jnp.asarray([start_values()[k] for k in VALUES])
    uj, yj = jnp.asarray(u), jnp.asarray(y_ref)

    def call():
        value, grad = fn(th0, uj, yj)
        grad.block_until_ready()
        return value, grad

    return call, jax.__version__, lambda: np.asarray(jax.jit(simulate)(th0, uj))


def timed(fn, repeats: int) -> float:
    """Median seconds of ``repeats`` calls (``bench_simulate.timed``)."""
    from bench_simulate import timed as median_time

    return median_time(fn, repeats)[0]


def run(quick: bool) -> dict:
    from hybridhyst.physics.compositions import boucwen_benchmark

    torch.set_default_dtype(torch.float64)
    T, repeats, B_list = (128, 2, [1]) if quick else (8192, 5, [1, 16])
    from bench_simulate import machine_brief

    out = {"T": T, "fs_hz": FS, "rows": [], **machine_brief(), "torch": torch.__version__}
    model = boucwen_benchmark().double()
    out["rows"] = [_row(model, B, T, repeats) for B in B_list]
    return out


def _first_call_fresh(u, t, y_ref) -> float:
    """hybridhyst's first gradient of a model never built before: an empty cache, a fresh model."""
    from hybridhyst.physics.compositions import boucwen_benchmark
    from hybridhyst.simulate.fast import build, function

    old = os.environ.get("HYBRIDHYST_CACHE")
    with tempfile.TemporaryDirectory() as cache:
        os.environ["HYBRIDHYST_CACHE"] = cache
        build._MODULES.clear()
        function._COMPILED.clear()
        t0 = time.perf_counter()
        hybridhyst_grad(boucwen_benchmark().double(), u, t, y_ref)
        first = time.perf_counter() - t0
    if old is None:
        del os.environ["HYBRIDHYST_CACHE"]
    else:
        os.environ["HYBRIDHYST_CACHE"] = old
    return first


def _row(model, B: int, T: int, repeats: int) -> dict:
    from hybridhyst.simulate import simulate

    u = multisine(T, B)
    t = torch.arange(T, dtype=torch.float64) / FS
    with torch.no_grad():
        y_ref = simulate(model, u, t=t, backend="fast")[..., 0]  # the truth's response
    row = {"batch": B, "peers": {}}
    first = _first_call_fresh(u, t, y_ref)
    loss, grad, y = hybridhyst_grad(model, u, t, y_ref)
    ours = {"first_s": first, "call_s": timed(lambda: hybridhyst_grad(model, u, t, y_ref), repeats)}
    row["peers"]["hybridhyst (compiled C, discrete adjoint)"] = {**ours, "loss": float(loss),
                                                                 "max_rel_grad_diff": 0.0, "max_rel_y_diff": 0.0}

    def compare(g2, y2, l2):
        rel = max(float((a - b).abs() / b.abs().clamp_min(1e-300)) for a, b in zip(g2, grad))
        return {"loss": float(l2), "max_rel_grad_diff": rel,
                "max_rel_y_diff": float((torch.as_tensor(y2) - y).abs().max() / y.abs().max())}

    for name, adjoint in (("torchdiffeq (rk4, back-propagation)", False), ("torchdiffeq (rk4, adjoint)", True)):
        t0 = time.perf_counter()
        l2, g2, y2 = torchdiffeq_grad(model, u, t, y_ref, adjoint)
        first = time.perf_counter() - t0
        per_call = timed(lambda a=adjoint: torchdiffeq_grad(model, u, t, y_ref, a), 1)  # seconds per call
        row["peers"][name] = {"first_s": first, "call_s": per_call, **compare(g2, y2, l2)}
    try:
        t0 = time.perf_counter()
        call, version, forward = jax_program(u.numpy(), y_ref.numpy())
        l2, g2 = call()
        first = time.perf_counter() - t0
        g2 = [torch.as_tensor(float(x)) for x in np.asarray(g2)]
        row["peers"][f"JAX {version} (jit, lax.scan, classic RK4)"] = {
            "first_s": first, "call_s": timed(call, repeats), **compare(g2, forward(), float(l2))}
    except ImportError:
        row["peers"]["JAX (jit, lax.scan, classic RK4)"] = {"first_s": None, "call_s": None,
                                                           "note": "not installed here"}
    for v in row["peers"].values():
        if v.get("call_s"):
            v["call_ratio"] = v["call_s"] / ours["call_s"]
            v["first_ratio"] = v["first_s"] / ours["first_s"]
    return row


def markdown(res: dict) -> str:
    lines = [f"Gradient of the sum of squared displacement errors w.r.t. (m, c, k, A, β, γ), Bouc–Wen benchmark "
             f"system, {res['T']} samples at {res['fs_hz']:.0f} Hz, one RK4 step per sample; {res['cpu_cores']} CPU "
             f"cores, load average at the start {res['load_average_at_start']}; no GPU. Ratios are the peer's time "
             "over hybridhyst's (> 1: hybridhyst is faster).", ""]
    for row in res["rows"]:
        lines += [f"Batch {row['batch']}:", "",
                  "| | first call | ratio | per call (median) | ratio | max rel. gradient diff | max rel. y diff |",
                  "|---|---|---|---|---|---|---|"]
        for name, v in row["peers"].items():
            if v.get("call_s") is None:
                lines.append(f"| {name} | {v.get('note', '')} | | | | | |")
                continue
            lines.append(f"| {name} | {v['first_s']:.2f} s | {v.get('first_ratio', 1):.2g}× | "
                         f"{v['call_s'] * 1e3:.1f} ms | {v.get('call_ratio', 1):.3g}× | {v['max_rel_grad_diff']:.1e} | "
                         f"{v['max_rel_y_diff']:.1e} |")
        lines.append("")
    lines.append("torchdiffeq's `rk4` is the 3/8-rule Runge–Kutta: its responses and gradients differ from classic "
                 "RK4's by the method's own error (last two columns), not by a bug.")
    return "\n".join(lines)


def main(argv=None) -> dict:
    from bench_simulate import simple_main

    return simple_main(argv, __doc__, "bench_peers", run, markdown)


if __name__ == "__main__":
    main()
