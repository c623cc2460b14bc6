"""Benchmark of ``simulate``: the compiled fast path against the eager PyTorch reference.

(1) gradient (forward + backward of a sum-of-squares loss w.r.t. every model parameter) of one seed 001
loop (modified Bouc–Wen, mixture 1:3, p = 0.05 MPa, 1711 samples): fast vs reference, side by side, and
their ratio; (2) forward and gradient throughput of the fast path over batch x sequence length (and the
reference at batch 1 and 16, length 1e3, for comparison).

    PYTHONPATH=. python scripts/bench_simulate.py --fresh-cache --json bench_simulate.json --write-readme

``--quick`` runs a small grid (a smoke run: a 400-sample loop, one reference repeat, length 500 only). Timings are wall
clock medians; the first fast call (C build, or load from the disk cache) is excluded from every
timing and reported separately. This is a script, not a timed test: numbers depend on the machine load.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "experiments" / "performance" / "README.md"
MEMORY_CAP_BYTES = 2e9  # skip grid points whose estimated peak memory exceeds this
TIME_CAP_S = 60.0  # ... or whose predicted time per call exceeds this
# Estimated peak bytes per sample-step of a gradient call (float64): inputs with rates (3), stored states,
# outputs, their gradients and the input-rate gradient (3), plus temporaries; rounded up generously.
BYTES_PER_SAMPLE_STEP = 160
MIXTURE, PRESSURE = "1:3", 0.05


def cpu_model() -> str:
    """The processor's name (``model name`` in /proc/cpuinfo), else what ``platform`` knows: the blocks come from
    more than one kind of 2-core machine."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cores(res: dict) -> str:
    """``2 CPU cores`` and, where the result recorded it, ``(the processor)``."""
    return f"{res['cpu_cores']} CPU cores" + (f" ({res['cpu_model']})" if res.get("cpu_model") else "")


def machine_brief() -> dict:
    """Cores, processor and load at the start: what every benchmark's block states about its machine."""
    return {"cpu_cores": os.cpu_count(), "cpu_model": cpu_model(),
            "load_average_at_start": [round(x, 2) for x in os.getloadavg()]}


def machine_info() -> dict:
    import subprocess

    from hybridhyst.simulate.fast.build import compiler, row_threads

    cc = subprocess.run([compiler(), "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    gpu = torch.cuda.get_device_name(0) if torch.cuda.is_available() else "not measured (no GPU in this session)"
    return {
        "platform": platform.platform(), "processor": platform.processor() or platform.machine(),
        **machine_brief(), "torch": torch.__version__, "compiler": cc,
        "numpy": np.__version__, "python": platform.python_version(), "torch_threads": torch.get_num_threads(),
        "fast_threads": row_threads(), "gpu": gpu,
    }


def seed001_loop(n: int | None = None):
    """The 1:3, p = 0.05 loop of the bundled VPPTD data: (u (1, T), t (T,), y (T,)) as float64 tensors."""
    from hybridhyst.data import load_builtin

    rec = load_builtin("vpptd", mixtures=[MIXTURE], pressures=[PRESSURE], noise_sd=0.2, seed=0).records[0]
    n = len(rec) if n is None else n
    u = torch.as_tensor(np.asarray(rec.x[:n]), dtype=torch.float64)[None]
    return u, torch.as_tensor(np.asarray(rec.t[:n]), dtype=torch.float64), torch.as_tensor(np.asarray(rec.y[:n]))


def make_model():
    from hybridhyst.physics.compositions import modified_bouc_wen

    return modified_bouc_wen(MIXTURE).double()


def call(model, u, t, pressures, backend: str, grad: bool, y=None):
    """One forward (no graph) or one gradient (forward + backward of Σ (ŷ − y)²) call."""
    from hybridhyst.simulate import simulate

    cond = {"pressure_mpa": pressures}
    if not grad:
        with torch.no_grad():
            return simulate(model, u, t=t, conditions=cond, backend=backend)
    out = simulate(model, u, t=t, conditions=cond, backend=backend)[..., 0]
    loss = ((out - (0.0 if y is None else y)) ** 2).sum()
    return torch.autograd.grad(loss, list(model.parameters()))


def timed(fn, repeats: int, budget_s: float | None = None) -> tuple[float, int]:
    """Median wall time of ``repeats`` calls (fewer, at least one, when ``budget_s`` is spent)."""
    times = []
    start = time.perf_counter()
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if budget_s is not None and time.perf_counter() - start > budget_s:
            break
    return statistics.median(times), len(times)


def bench_gradient_ratio(model, quick: bool) -> dict:
    """(1) gradient of one seed 001 loop: fast vs eager reference, measured in the same run."""
    u, t, y = seed001_loop(400 if quick else None)
    p = torch.tensor([PRESSURE], dtype=torch.float64)
    t0 = time.perf_counter()
    call(model, u, t, p, "fast", True, y)  # first call: compile (or load from the disk cache)
    compile_s = time.perf_counter() - t0
    fast_s, n_fast = timed(lambda: call(model, u, t, p, "fast", True, y), 5 if quick else 30)
    last = {}
    ref_s, n_ref = timed(lambda: last.update(g=call(model, u, t, p, "reference", True, y)), 1 if quick else 3)
    g_fast, g_ref = call(model, u, t, p, "fast", True, y), last["g"]
    rel = max(float((a - b).abs().max() / b.abs().max().clamp_min(1e-300)) for a, b in zip(g_fast, g_ref))
    return {
        "length": int(u.shape[1]), "mixture": MIXTURE, "pressure_mpa": PRESSURE,
        "n_parameters": sum(q.numel() for q in model.parameters()),
        "fast_s": fast_s, "fast_repeats": n_fast, "reference_s": ref_s, "reference_repeats": n_ref,
        "ratio": ref_s / fast_s, "first_fast_call_s": compile_s, "max_rel_grad_difference": rel,
    }


def sine_input(batch: int, length: int, dt: float = 1 / 450.0):
    """±10° sine at 0.79 Hz on the seed 001 grid; pressures spread over 0.01 ... 0.09 MPa along the batch."""
    t = torch.arange(length, dtype=torch.float64) * dt
    phase = torch.linspace(0.0, 1.0, batch, dtype=torch.float64)[:, None]
    u = 10.0 * torch.sin(2 * math.pi * 0.79 * t[None, :] + phase)
    p = torch.linspace(0.01, 0.09, batch, dtype=torch.float64) if batch > 1 else torch.tensor([PRESSURE])
    return u.contiguous(), t, p


def _skip_reason(batch: int, length: int, cost_us: float | None) -> str | None:
    mem = batch * length * BYTES_PER_SAMPLE_STEP
    if mem > MEMORY_CAP_BYTES:
        return f"estimated memory {mem / 1e9:.1f} GB > {MEMORY_CAP_BYTES / 1e9:.0f} GB"
    if cost_us is not None and batch * length * cost_us * 1e-6 > TIME_CAP_S:
        return f"predicted {batch * length * cost_us * 1e-6:.0f} s per call > {TIME_CAP_S:.0f} s"
    return None


def _point(model, backend: str, batch: int, length: int, mode: str, repeats: int, budget_s: float) -> dict:
    u, t, p = sine_input(batch, length)
    secs, n = timed(lambda: call(model, u, t, p, backend, mode == "gradient"), repeats, budget_s)
    return {"backend": backend, "batch": batch, "length": length, "mode": mode, "time_s": secs, "repeats": n,
            "us_per_sample_step": secs / (batch * (length - 1)) * 1e6}


def bench_throughput(model, batches, lengths, ref_batches, ref_length) -> tuple[list[dict], list[dict]]:
    """(2) forward and gradient time of the fast path over the grid (+ the reference at small sizes)."""
    rows, skipped = [], []
    cost = {}  # µs per sample-step of the same batch and mode at the previous length: the time predictor
    for length in lengths:
        for batch in batches:
            for mode in ("forward", "gradient"):
                reason = _skip_reason(batch, length, cost.get((batch, mode)))
                if reason:
                    skipped.append({"backend": "fast", "batch": batch, "length": length, "mode": mode,
                                    "reason": reason})
                    continue
                row = _point(model, "fast", batch, length, mode, repeats=7, budget_s=2.0)
                cost[(batch, mode)] = row["us_per_sample_step"]
                rows.append(row)
                print(f"  fast {mode:8s} B={batch:5d} T={length:7d}: {row['time_s'] * 1e3:9.2f} ms/call "
                      f"{row['us_per_sample_step']:8.4f} us/sample-step", flush=True)
    for batch in ref_batches:
        for mode in ("forward", "gradient"):
            row = _point(model, "reference", batch, ref_length, mode, repeats=1, budget_s=0.0)
            rows.append(row)
            print(f"  reference {mode:8s} B={batch:5d} T={ref_length:7d}: {row['time_s']:7.2f} s/call", flush=True)
    return rows, skipped


def scaling_summary(rows: list[dict]) -> dict:
    """Cost growth: time(T_max)/time(T_min) at batch 1 vs T_max/T_min, and per-sample cost vs batch."""
    fast = [r for r in rows if r["backend"] == "fast"]
    out = {}
    for mode in ("forward", "gradient"):
        b1 = sorted((r for r in fast if r["mode"] == mode and r["batch"] == 1), key=lambda r: r["length"])
        if len(b1) >= 2:
            out[f"{mode}_length_growth"] = {"lengths": [b1[0]["length"], b1[-1]["length"]],
                                            "time_ratio": b1[-1]["time_s"] / b1[0]["time_s"],
                                            "length_ratio": b1[-1]["length"] / b1[0]["length"]}
        lmin = min((r["length"] for r in fast), default=None)
        per = {r["batch"]: r["us_per_sample_step"] for r in fast if r["mode"] == mode and r["length"] == lmin}
        if len(per) >= 2:
            out[f"{mode}_per_sample_vs_batch"] = {"length": lmin, "us_per_sample_step": per}
    return out


def _fmt_len(n: int) -> str:
    e = round(math.log10(n))
    return f"1e{e}" if 10**e == n else str(n)


def _fmt_time(s: float) -> str:
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def machine_markdown(m: dict) -> str:
    return (f"Machine: {m['cpu_cores']} CPU cores ({m['processor']}, {m['platform']}); Python {m['python']}, "
            f"torch {m['torch']} ({m['torch_threads']} threads), C compiler {m['compiler']} "
            f"(loops on {m['fast_threads']} threads), "
            f"numpy {m['numpy']}. Load average (1, 5, 15 min) at start: {m.get('load_average_at_start')} "
            f"(other jobs shared the machine). GPU: {m['gpu']}.")


def ratio_markdown(g: dict) -> list[str]:
    return [
        f"**(1) Gradient of one seed 001 loop** (modified Bouc–Wen {g['mixture']}, p = {g['pressure_mpa']} MPa, "
        f"{g['length']} samples, RK4, {g['n_parameters']} parameters; forward + backward of a sum of squares):",
        "",
        "| path | time per gradient | repeats (median) | GPU |",
        "|---|---|---|---|",
        f"| fast (generated C, discrete adjoint) | {_fmt_time(g['fast_s'])} | {g['fast_repeats']} | not measured |",
        f"| reference (eager PyTorch) | {_fmt_time(g['reference_s'])} | {g['reference_repeats']} | not measured |",
        f"| **ratio** | **{g['ratio']:.0f}×** (target ≥ 300×) | | |",
        "",
        f"First fast call (C build or disk-cache load, excluded above): {g['first_fast_call_s']:.2f} s. "
        f"Largest relative difference between the two gradients: {g['max_rel_grad_difference']:.1e}.",
    ]


def throughput_markdown(rows: list[dict], skipped: list[dict]) -> list[str]:
    lines = ["**(2) Throughput** (±10° sine at 0.79 Hz, dt = 1/450 s, pressures spread over the batch; "
             "time per call and µs per sample-step = time / (batch × (length − 1))):", "",
             "| path | batch | length | forward / call | forward µs/sample-step | gradient / call "
             "| gradient µs/sample-step | GPU |", "|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["backend"] != "fast", r["length"], r["batch"]) for r in rows})
    for ref, length, batch in keys:
        cells = []
        for mode in ("forward", "gradient"):
            hit = [r for r in rows if (r["backend"] != "fast") == ref and r["length"] == length
                   and r["batch"] == batch and r["mode"] == mode]
            cells += [_fmt_time(hit[0]["time_s"]), f"{hit[0]['us_per_sample_step']:.3g}"] if hit else ["—", "—"]
        lines.append(f"| {'reference' if ref else 'fast'} | {batch} | {_fmt_len(length)} | " + " | ".join(cells)
                     + " | not measured |")
    if skipped:
        lines += ["", "Skipped (fast path): " + "; ".join(
            f"batch {s['batch']} × length {_fmt_len(s['length'])} {s['mode']} ({s['reason']})" for s in skipped) + "."]
    return lines


def scaling_markdown(summary: dict) -> list[str]:
    lines = []
    for mode in ("forward", "gradient"):
        g = summary.get(f"{mode}_length_growth")
        if g:
            lines.append(f"- {mode}, batch 1: length × {g['length_ratio']:.0f} → time × {g['time_ratio']:.1f}.")
        b = summary.get(f"{mode}_per_sample_vs_batch")
        if b:
            per = ", ".join(f"batch {k}: {v:.3g}" for k, v in sorted(b["us_per_sample_step"].items()))
            lines.append(f"- {mode}, length {_fmt_len(b['length'])}, µs per sample-step: {per}.")
    return lines


def write_readme_section(name: str, body: str, path: Path = README) -> None:
    """Replace the text between ``<!-- {name}:start -->`` and ``<!-- {name}:end -->`` (appended if absent)."""
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    text = path.read_text() if path.exists() else "# Performance\n"
    block = f"{start}\n{body.rstrip()}\n{end}"
    if start in text and end in text:
        head, rest = text.split(start, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def command_line() -> str:
    return "PYTHONPATH=. python scripts/" + " ".join([Path(sys.argv[0]).name] + sys.argv[1:])


def write_json(path: str, result: dict) -> None:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(json.dumps(result, indent=2))
    os.replace(tmp, out)


def report_markdown(result: dict) -> str:
    when = result["finished_utc"]
    lines = [f"Generated by `{result['command']}` ({'quick' if result['quick'] else 'full'} run, finished {when}).",
             "", machine_markdown(result["machine"]), "", *ratio_markdown(result["gradient_ratio"]), "",
             *throughput_markdown(result["throughput"], result["skipped"]), "",
             "Scaling:", "", *scaling_markdown(result["scaling"])]
    return "\n".join(lines)


def bench_parser(doc: str, section: str, quick: str) -> argparse.ArgumentParser:
    """The arguments every benchmark script takes: ``--quick`` (what it does: ``quick``), ``--json``,
    ``--write-readme`` (the ``section`` of the performance README)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=quick)
    ap.add_argument("--json", metavar="PATH", help="write the results as JSON")
    ap.add_argument("--write-readme", action="store_true", help=f"regenerate the {section} section of {README}")
    return ap


def parse_args(argv=None) -> argparse.Namespace:
    ap = bench_parser(__doc__, "bench_simulate", "small grid (smoke run)")
    ap.add_argument("--fresh-cache", action="store_true",
                    help="compile into an empty cache directory, so the first call measures a real compile")
    return ap.parse_args(argv)


def run(args: argparse.Namespace) -> dict:
    if args.fresh_cache:
        os.environ["HYBRIDHYST_CACHE"] = tempfile.mkdtemp(prefix="hh-bench-cache-")
    torch.manual_seed(0)
    model = make_model()
    print("(1) gradient of one seed 001 loop: fast vs reference", flush=True)
    ratio = bench_gradient_ratio(model, args.quick)
    print(f"  fast {ratio['fast_s'] * 1e3:.2f} ms, reference {ratio['reference_s']:.2f} s, ratio "
          f"{ratio['ratio']:.0f}x (first fast call {ratio['first_fast_call_s']:.2f} s)", flush=True)
    print("(2) throughput", flush=True)
    if args.quick:
        rows, skipped = bench_throughput(model, [1, 16], [500], [1], 500)
    else:
        rows, skipped = bench_throughput(model, [1, 16, 256, 1024], [1000, 10_000, 100_000], [1, 16], 1000)
    return {"command": command_line(), "quick": bool(args.quick), "fresh_cache": bool(args.fresh_cache),
            "machine": machine_info(), "gradient_ratio": ratio, "throughput": rows, "skipped": skipped,
            "scaling": scaling_summary(rows), "finished_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}


def simple_main(argv, doc: str, section: str, run, markdown, flags: tuple[str, ...] = ()) -> dict:
    """The whole ``main`` of a benchmark whose ``run`` takes ``--quick`` (and each of ``flags``, a store-true option
    named like the keyword it sets) and whose ``markdown`` renders its result."""
    ap = bench_parser(doc, section, "a smoke version")
    for flag in flags:
        ap.add_argument(f"--{flag.replace('_', '-')}", action="store_true")
    args = ap.parse_args(argv)
    result = run(args.quick, **{flag: getattr(args, flag) for flag in flags})
    return emit(args, section, result, markdown(result))


def emit(args, section: str, result: dict, markdown: str) -> dict:
    """Write ``--json`` and the ``--write-readme`` section as asked, print the Markdown; shared by the benches."""
    if args.json:
        write_json(args.json, result)
    if args.write_readme:
        write_readme_section(section, markdown)
    print(markdown)
    return result


def main(argv=None) -> dict:
    args = parse_args(argv)
    result = run(args)
    return emit(args, "bench_simulate", result, report_markdown(result))


if __name__ == "__main__":
    main()
