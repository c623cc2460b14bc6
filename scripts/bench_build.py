"""How long a model never run before waits for its compiled loops, and what that costs the main job.

1. Per model, in an empty cache: the seconds from ``simulate(..., backend="fast")`` being called on a model the
   machine has never built to its first values, then to its first forward sensitivities and its first gradient
   (equations, C source, the compiler, loading, the simulation itself; each loop is built when first needed), for
   every named composition, the two models holding every library effect (the largest loops the library builds),
   and an in-the-loop hybrid (a 2×32 network inside the Bouc–Wen benchmark oscillator). Then the loops a fit runs
   of all of them built side by side (``prebuild_models``) against one model after another.
2. ``--main-job``: the main job (``hybridhyst-discover`` on the bundled data) on an empty cache, then again warm,
   back to back, and their ratio.
3. ``--opt-levels``: the main job built at -O2 and at -O3 (``HYBRIDHYST_OPT``), side by side: for each level an
   empty cache, one cold run, then two warm runs, the levels alternating; the warm runs' ratio -O3 / -O2.
4. ``--workers``: the main job warm with a discovery step's candidates fitted in forked processes (the default)
   and in threads (``HYBRIDHYST_WORKERS=threads``), three runs each, the kinds alternating; the best runs' ratio.

    PYTHONPATH=. python scripts/bench_build.py --main-job --opt-levels --workers \
        --json experiments/performance/bench_build.json --write-readme

``--quick``: three models, no main job.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))  # bench_simulate


def every_effect(structure: str):
    """Every library effect but the delay and the network at non-neutral values, in one model."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_fast import _every_effect

    return _every_effect(structure)


def neural_hybrid():
    from hybridhyst.physics.compositions import boucwen_benchmark
    from hybridhyst.physics.effects import NeuralEffect

    net = NeuralEffect(latent_states=1, hidden="2x32", scales={"x": 1e-3, "v": 0.5, "F": 50.0})
    return boucwen_benchmark().augmented({"neural": net})


def models(quick: bool) -> dict:
    from hybridhyst.physics.compositions import COMPOSITIONS

    out = {name: make for name, make in sorted(COMPOSITIONS.items())}
    out["every effect (constitutive)"] = lambda: every_effect("constitutive")
    out["every effect (oscillator)"] = lambda: every_effect("oscillator")
    out["in-the-loop hybrid (Bouc–Wen + 2×32 network)"] = neural_hybrid
    if quick:
        out = dict(list(out.items())[:3])
    return out


def _fresh(cache: str):
    from hybridhyst.simulate.fast import build, function

    os.environ["HYBRIDHYST_CACHE"] = cache
    build._MODULES.clear()
    function._COMPILED.clear()


def _inputs():
    t = torch.arange(200, dtype=torch.float64) * 1e-3
    u = 0.5 * torch.sin(2 * math.pi * 5 * t)[None]
    return u, t


def first_call(make) -> dict:
    """Seconds to the first values, then the first forward sensitivities (a least-squares Jacobian, where they
    cover the model) and the first gradient of a model never built, in an empty cache (each loop is built when a
    call first needs it)."""
    from hybridhyst.simulate import jacobian_covers, simulate, simulate_jacobian
    from hybridhyst.simulate.fast.equations import build_equations

    model = make().double()
    u, t = _inputs()
    cond = {"pressure_mpa": torch.tensor([0.05])}
    with torch.no_grad():
        values = model.evaluate(cond, 1)
    with tempfile.TemporaryDirectory() as cache:
        _fresh(cache)
        t0 = time.perf_counter()
        y = simulate(model, u, t=t, conditions=cond, backend="fast")
        first = time.perf_counter() - t0
        jacobian = None
        if jacobian_covers(model):
            simulate_jacobian(model, u, t, values=values, conditions=cond)
            jacobian = time.perf_counter() - t0
        params = [p for p in model.parameters() if p.requires_grad]
        torch.autograd.grad(y.square().sum(), params, allow_unused=True)
        gradient = time.perf_counter() - t0
    eq = build_equations(model)
    return {"values_s": first, "jacobian_s": jacobian, "gradient_s": gradient, "states": len(eq.state),
            "parameters": len(eq.params), "networks": len(eq.networks)}


def shared_sums(repeats: int = 2) -> dict:
    """The every-effect models' C source (the derivatives source) generated with equal sums sharing one
    ``gcd_terms`` result and each expression's free symbols kept (``codegen._shared_gcd_terms``,
    ``codegen._shared_free_symbols``), with the sums shared alone, and with sympy's own, alternating; seconds (best
    of ``repeats``) and whether the sources are the same."""
    import contextlib

    import sympy

    from hybridhyst.simulate.fast import codegen
    from hybridhyst.simulate.fast.equations import build_equations

    out = {}
    sums, free = codegen._shared_gcd_terms, codegen._shared_free_symbols
    off = contextlib.nullcontext
    ways = {"shared": (sums, free), "sums_only": (sums, off), "sympy": (off, off)}
    for structure in ("constitutive", "oscillator"):
        eq = build_equations(every_effect(structure).double())
        times, sources = {how: [] for how in ways}, {}
        try:
            for _ in range(repeats):
                for how, (a, b) in ways.items():
                    codegen._shared_gcd_terms, codegen._shared_free_symbols = a, b
                    sympy.core.cache.clear_cache()
                    t0 = time.perf_counter()
                    sources[how] = codegen.generate_source(eq)
                    times[how].append(time.perf_counter() - t0)
        finally:
            codegen._shared_gcd_terms, codegen._shared_free_symbols = sums, free
        out[f"every effect ({structure})"] = {
            "shared_s": min(times["shared"]), "sums_only_s": min(times["sums_only"]), "sympy_s": min(times["sympy"]),
            "same_source": sources["shared"] == sources["sums_only"] == sources["sympy"]}
    return out


def side_by_side(makers: dict) -> dict:
    """All models' loops that a fit runs (values and forward sensitivities) built at once (``prebuild_models``)
    against the same built one model after another, each in an empty cache."""
    from hybridhyst.simulate.fast import prebuild_models

    built = [make().double() for make in makers.values()]
    out = {"models": len(built)}
    with tempfile.TemporaryDirectory() as cache:
        _fresh(cache)
        t0 = time.perf_counter()
        prebuild_models(built)
        out["together_s"] = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as cache:
        _fresh(cache)
        t0 = time.perf_counter()
        for model in built:
            prebuild_models([model])
        out["one_after_another_s"] = time.perf_counter() - t0
    return out


def _main_job(env: dict, run_dir: str) -> float:
    t0 = time.perf_counter()
    subprocess.run(["hybridhyst-discover", f"hydra.run.dir={run_dir}", "progress=false"], env=env, check=True,
                   capture_output=True)
    return time.perf_counter() - t0


def run_main_job() -> dict:
    """``hybridhyst-discover`` on an empty cache, then warm, back to back."""
    out = {}
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as runs:
        env = {**os.environ, "HYBRIDHYST_CACHE": cache}
        for kind in ("cold", "warm"):
            out[f"{kind}_s"] = _main_job(env, f"{runs}/{kind}")
    out["ratio"] = out["cold_s"] / out["warm_s"]
    return out


def run_opt_levels(levels=("-O2", "-O3"), warm: int = 2) -> dict:
    """The main job built at each optimisation level: per level an empty cache and a cold run, then ``warm`` warm
    runs with the levels alternating (so a change in the machine's load falls on both)."""
    out = {level: {"cold_s": None, "warm_s": []} for level in levels}
    with tempfile.TemporaryDirectory() as root:
        envs = {level: {**os.environ, "HYBRIDHYST_CACHE": f"{root}/cache{i}", "HYBRIDHYST_OPT": level}
                for i, level in enumerate(levels)}
        for level in levels:
            out[level]["cold_s"] = _main_job(envs[level], f"{root}/{level}-cold")
        for k in range(warm):
            for level in (levels if k % 2 == 0 else levels[::-1]):
                out[level]["warm_s"].append(_main_job(envs[level], f"{root}/{level}-warm{k}"))
    base, other = levels[0], levels[-1]
    out["warm_ratio"] = min(out[other]["warm_s"]) / min(out[base]["warm_s"])
    return out


def run_workers(kinds=("processes", "threads"), runs: int = 3) -> dict:
    """The main job warm with the candidates' fits in processes and in threads (``HYBRIDHYST_WORKERS``), ``runs``
    each, the kinds alternating (a change in the machine's load falls on both); the cache warmed first."""
    out = {kind: [] for kind in kinds}
    with tempfile.TemporaryDirectory() as root:
        _main_job(dict(os.environ), f"{root}/warm-up")
        for k in range(runs):
            for kind in (kinds if k % 2 == 0 else kinds[::-1]):
                out[kind].append(_main_job({**os.environ, "HYBRIDHYST_WORKERS": kind}, f"{root}/{kind}{k}"))
    out["ratio"] = min(out[kinds[1]]) / min(out[kinds[0]])
    return out


def run(quick: bool, main_job: bool = False, opt_levels: bool = False, workers: bool = False) -> dict:
    torch.set_default_dtype(torch.float64)
    makers = models(quick)
    old = os.environ.get("HYBRIDHYST_CACHE")
    from bench_simulate import machine_brief

    res = {**machine_brief(), "models": {name: first_call(make) for name, make in makers.items()}}
    res["side_by_side"] = side_by_side(makers)
    if not quick:
        res["shared_sums"] = shared_sums()
    if old is None:
        os.environ.pop("HYBRIDHYST_CACHE", None)
    else:
        os.environ["HYBRIDHYST_CACHE"] = old
    if main_job:
        res["main_job"] = run_main_job()
    if opt_levels:
        res["opt_levels"] = run_opt_levels()
    if workers:
        res["workers"] = run_workers()
    return res


def markdown(res: dict) -> str:
    from bench_simulate import cores

    lines = [f"A model never built before, in an empty cache ({cores(res)}, load average at the start "
             f"{res['load_average_at_start']}): seconds from the first `simulate(..., backend=\"fast\")` call to its "
             "values (equations, C source, compiler, load, a 200-step simulation), then to its first forward "
             "sensitivities (`simulate_jacobian`, what least squares needs; — where they do not cover the model) and "
             "to its first gradient (each loop is built when a call first needs it).", "",
             "| model | states | parameters | first values [s] | + Jacobian [s] | + gradient [s] |",
             "|---|---|---|---|---|---|"]
    for name, m in res["models"].items():
        jac = "—" if m.get("jacobian_s") is None else f"{m['jacobian_s']:.2f}"
        lines.append(f"| {name} | {m['states']} | {m['parameters']} | {m['values_s']:.2f} | {jac} | "
                     f"{m['gradient_s']:.2f} |")
    s = res["side_by_side"]
    lines += ["", f"All {s['models']} with the loops a fit runs (values and forward sensitivities) built side by "
                  f"side (`prebuild_models`, one compiler process per core): {s['together_s']:.1f} s, against "
                  f"{s['one_after_another_s']:.1f} s one after another."]
    for name, g in res.get("shared_sums", {}).items():
        ratio = g["sympy_s"] / g["shared_s"]
        lines += ["", f"{name}: its derivatives source generated in {g['shared_s']:.2f} s with equal sums sharing one "
                      f"`gcd_terms` result and each expression's free symbols kept, {g['sums_only_s']:.2f} s with the "
                      f"sums shared alone ({g['sums_only_s'] / g['shared_s']:.2f}×), {g['sympy_s']:.2f} s with "
                      f"sympy's own ({ratio:.2f}×; the same source: {'yes' if g['same_source'] else '**no**'})."]
    if "main_job" in res:
        m = res["main_job"]
        lines += ["", f"The main job (`hybridhyst-discover`, bundled BRFD data) on an empty cache: "
                      f"{m['cold_s']:.0f} s; then warm: {m['warm_s']:.0f} s; cold / warm = {m['ratio']:.2f}."]
    if "opt_levels" in res:
        o = res["opt_levels"]
        levels = [k for k in o if k.startswith("-O")]
        runs = "; ".join(f"{lv}: cold {o[lv]['cold_s']:.0f} s, warm {', '.join(f'{w:.1f}' for w in o[lv]['warm_s'])} s"
                         for lv in levels)
        lines += ["", f"The main job built at each optimisation level (`HYBRIDHYST_OPT`, side by side, levels "
                      f"alternating): {runs}. Best warm {levels[-1]} / {levels[0]} = {o['warm_ratio']:.2f}."]
    if "workers" in res:
        w = res["workers"]
        runs = "; ".join(f"{kind}: {', '.join(f'{t:.1f}' for t in w[kind])} s" for kind in ("processes", "threads"))
        lines += ["", f"The main job warm with each discovery step's candidates fitted in forked processes (the "
                      f"default) and in threads (`HYBRIDHYST_WORKERS=threads`), kinds alternating: {runs}. Best "
                      f"threads / processes = {w['ratio']:.2f}."]
    return "\n".join(lines)


def main(argv=None) -> dict:
    from bench_simulate import simple_main

    return simple_main(argv, __doc__, "bench_build", run, markdown, flags=("main_job", "opt_levels", "workers"))


if __name__ == "__main__":
    main()
