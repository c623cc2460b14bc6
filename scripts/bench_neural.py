"""Benchmark of a network inside the dynamics: cost per sample-step of a model with a ``NeuralEffect`` on the
compiled fast path (the network in the generated code, its weights in the exact adjoint) and on the batched
reference loop, next to the nominal alone on both — forward and gradient, over the batch size, on the CPU
and, where one is available, on a GPU (the reference loop; the compiled path runs on the CPU). All rows are
measured in one run, side by side.

The model is the Bouc–Wen benchmark's linear oscillator (m 2 kg, c 10 Ns/m, k 5e4 N/m, 750 Hz) driven by a
random force; the network is the in-the-loop hybrid's default (2x32 tanh, one latent state).

    PYTHONPATH=. python scripts/bench_neural.py --json /tmp/bench_neural.json --write-readme

``--quick`` runs a smoke version (batch 1 and 16, 200 steps). Timings are wall-clock medians; the first call
of each configuration (C build or disk-cache load, CUDA warm-up) is excluded.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "experiments" / "performance" / "README.md"
BEGIN, END = "<!-- bench_neural:begin -->", "<!-- bench_neural:end -->"


def models(device: str):
    from hybridhyst.physics.effects import EFFECTS, NeuralEffect
    from hybridhyst.physics.models import DrivenOscillator

    nominal = DrivenOscillator({"spring": EFFECTS["linear_stiffness"](k=5e4), "viscous": EFFECTS["viscous"](c=10.0)},
                               mass=2.0, units={"x": "m", "F": "N", "u": "N"}).double()
    net = NeuralEffect(latent_states=1, hidden="2x32", scales={"x": 1e-3, "v": 0.5, "F": 50.0}).double()
    torch.manual_seed(0)
    for p in net.net.parameters():  # a trained-looking network, not the zero start
        p.data.normal_(0.0, 0.2)
    return nominal.to(device), nominal.augmented({"neural": net}).to(device)


def call(model, u, backend: str, grad: bool):
    from hybridhyst.simulate import simulate

    if not grad:
        with torch.no_grad():
            return simulate(model, u, dt=1 / 750, backend=backend)
    y = simulate(model, u, dt=1 / 750, backend=backend)
    return torch.autograd.grad(y.square().sum(), [p for p in model.parameters() if p.requires_grad])


def timed(fn, repeats: int, sync) -> float:
    fn()  # first call excluded: compile, cache load, CUDA warm-up
    sync()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run(quick: bool) -> dict:
    torch.set_default_dtype(torch.float64)
    batches, length = ((1, 16), 200) if quick else ((1, 64, 512), 1000)
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    rows = []
    for device in devices:
        nominal, hybrid = models(device)
        sync = torch.cuda.synchronize if device == "cuda" else (lambda: None)
        cases = [("nominal", nominal, "reference"), ("neural", hybrid, "reference")]
        if device == "cpu":  # the compiled path runs on the CPU
            cases = [("nominal", nominal, "fast"), ("neural", hybrid, "fast"), *cases]
        for batch in batches:
            u = (50.0 * torch.randn(batch, length, generator=torch.Generator().manual_seed(1))).to(device)
            for name, model, backend in cases:
                for mode in ("forward", "gradient"):
                    secs = timed(lambda m=model, x=u, b=backend, g=mode == "gradient": call(m, x, b, g),
                                 1 if quick else 3, sync)
                    row = {"device": device, "model": name, "path": backend, "batch": batch, "length": length,
                           "mode": mode, "time_s": secs, "us_per_sample_step": secs / (batch * (length - 1)) * 1e6}
                    rows.append(row)
                    print(f"  {device:4s} {name:7s} {backend:9s} {mode:8s} B={batch:4d}: {secs * 1e3:9.1f} ms "
                          f"{row['us_per_sample_step']:9.3f} us/sample-step", flush=True)
    keyed = {(r["device"], r["model"], r["path"], r["batch"], r["mode"]): r for r in rows}
    ratios = []  # per batch and mode: the network's cost over the nominal's, and the compiled over the batched loop
    for (device, model, path, batch, mode), r in keyed.items():
        if model != "neural":
            continue
        nominal_fast = keyed[("cpu", "nominal", "fast", batch, mode)]
        ratio = {"device": device, "path": path, "batch": batch, "mode": mode,
                 "neural_over_nominal_fast": r["time_s"] / nominal_fast["time_s"]}
        if path == "fast":
            ratio["reference_over_fast"] = keyed[("cpu", "neural", "reference", batch, mode)]["time_s"] / r["time_s"]
        ratios.append(ratio)
    return {"command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "machine": {"platform": platform.platform(), "cpu_cores": os.cpu_count(), "torch": torch.__version__,
                        "torch_threads": torch.get_num_threads(),
                        "gpu": torch.cuda.get_device_name(0) if torch.cuda.is_available() else None},
            "rows": rows, "ratios": ratios}


def markdown(res: dict) -> str:
    m = res["machine"]
    lines = [BEGIN, f"Generated by `scripts/bench_neural.py` on {res['date']}: {m['cpu_cores']} CPU cores, torch "
             f"{m['torch']} ({m['torch_threads']} threads), GPU: {m['gpu'] or 'none'}. Linear oscillator of the "
             "Bouc–Wen benchmark, 2x32 tanh network with one latent state; µs per sample-step (batch × steps).", "",
             "| device | model | path | batch | forward [µs] | gradient [µs] |", "|---|---|---|---|---|---|"]
    keyed = {(r["device"], r["model"], r["path"], r["batch"], r["mode"]): r for r in res["rows"]}
    for (dev, model, path, batch, mode), r in keyed.items():
        if mode != "forward":
            continue
        g = keyed.get((dev, model, path, batch, "gradient"))
        lines.append(f"| {dev} | {model} | {path} | {batch} | {r['us_per_sample_step']:.3g} | "
                     f"{g['us_per_sample_step']:.3g} |" if g else "")
    compiled = [x for x in res["ratios"] if x["path"] == "fast"]
    lines += ["", "Network inside the loop, compiled, over the nominal alone on the compiled path (time ratio, same "
              "batch): " + ", ".join(f"B={x['batch']} {x['mode']} {x['neural_over_nominal_fast']:.0f}×"
                                      for x in compiled) + ".",
              "", "Batched reference loop over the compiled path, both with the network on the CPU (time ratio, same "
              "batch; above 1: the compiled path is faster): "
              + ", ".join(f"B={x['batch']} {x['mode']} {x['reference_over_fast']:.2g}" for x in compiled) + ".", END]
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--write-readme", action="store_true")
    args = ap.parse_args(argv)
    res = run(args.quick)
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    if args.write_readme:
        text = README.read_text()
        block = markdown(res)
        if BEGIN in text:
            text = text[:text.index(BEGIN)] + block + text[text.index(END) + len(END):]
        else:
            text += "\n## A network inside the dynamics (`scripts/bench_neural.py`)\n\n" + block + "\n"
        README.write_text(text)


if __name__ == "__main__":
    main()
