"""Do the hybrids earn their physics? MR damper loops whose law the nominal lacks, trained as a new user would.

The data come from a generator written here with numpy and scipy only (no hybridhyst code): a magnetorheological
damper, Bouc–Wen with n = 2 (Spencer et al. 1997's phenomenological law without its filter), whose damping and
hysteretic level rise with the coil current and saturate::

    F = c(I) ẋ + α(I) z + k x,   ż = ẋ − β |ẋ| z |z| − γ ẋ z²,   s(I) = 1 − exp(−I / 0.5 A)
    c(I) = 0.8 + 2.0 s(I) [N s/mm],   α(I) = 20 + 60 s(I) [N/mm],   k = 0.5 N/mm,   β = 0.6, γ = 0.4 [1/mm²]

(z [mm]), integrated by scipy's LSODA (rtol 1e-9, steps of at most a twentieth of the sample interval), at seven
currents 0–1.5 A, each under three sine tests (1 Hz 10 mm, 2 Hz 6 mm, 4 Hz 3 mm; 3 s at 400 Hz), with AR(1) noise
(coefficient 0.6, 3 N standard deviation) on the force. The currents 0.5 and 1.25 A are held out.

Every model is trained by ``hybridhyst-train`` with its defaults and the own-data options of docs/own-data.md:
the nominal is ``model=mr_damper`` with constant parameters (it cannot follow the current), every network reads
the current (``datamodule.conditions=[current_a]``). The rows: the LSTM and MLP baselines, the hybrid with an
MLP residual at the output, and the hybrid with a network inside the dynamics (``baseline=hybrid_dynamics``);
each hybrid's run also reports its identified nominal. The LSTM and both hybrids run again with 200 epochs in
place of the default 60 (nothing else changed). Last, the law itself with its damping c(I) and hysteretic level
κ(I) small networks of the current (parameter functions of kind ``neural``), trained by ``baseline=physics``;
the two rows that end closest (the 200-epoch LSTM and that law with Levenberg–Marquardt steps) again with seeds
1 and 2.

    PYTHONPATH=. python scripts/mr_damper_hybrids.py --write-readme     # data, 15 runs, the block (~30 min)
    PYTHONPATH=. python scripts/mr_damper_hybrids.py --only "lstm"      # some rows again, the others kept
    PYTHONPATH=. python scripts/mr_damper_hybrids.py --render           # the block from the committed JSON

Writes ``experiments/mr_damper_hybrids/summary.json`` and the block between ``<!-- mr:start -->`` and
``<!-- mr:end -->`` of that folder's README.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "experiments" / "mr_damper_hybrids"
CURRENTS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5)
HELD_OUT = (0.5, 1.25)
TESTS = ((1.0, 10.0), (2.0, 6.0), (4.0, 3.0))  # (frequency [Hz], amplitude [mm])
FS, DURATION, NOISE_SD, NOISE_AR = 400.0, 3.0, 3.0, 0.6
K, BETA, GAMMA, I_SAT = 0.5, 0.6, 0.4, 0.5


def level(current: float) -> float:
    return 1.0 - np.exp(-current / I_SAT)


def damping(current: float) -> float:
    return 0.8 + 2.0 * level(current)


def hysteretic(current: float) -> float:
    return 20.0 + 60.0 * level(current)


def clean(current: float, freq: float, amp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, displacement x = amp sin(2π freq t) [mm] and the noise-free force [N] of one sine test (z(0) = 0)."""
    w = 2 * np.pi * freq
    t = np.arange(int(DURATION * FS) + 1) / FS

    def rate(s, z):
        v = amp * w * np.cos(w * s)
        return [v - BETA * abs(v) * z[0] * abs(z[0]) - GAMMA * v * z[0] ** 2]

    sol = solve_ivp(rate, (0.0, t[-1]), [0.0], method="LSODA", t_eval=t, max_step=1 / (20 * FS), rtol=1e-9,
                    atol=1e-12)
    x, v = amp * np.sin(w * t), amp * w * np.cos(w * t)
    return t, x, damping(current) * v + hysteretic(current) * sol.y[0] + K * x


def record(current: float, freq: float, amp: float, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``clean`` with AR(1) noise on the force."""
    t, x, force = clean(current, freq, amp)
    noise = np.empty(len(t))
    noise[0] = rng.normal(0.0, NOISE_SD)
    innovations = rng.normal(0.0, NOISE_SD * np.sqrt(1 - NOISE_AR**2), len(t))
    for i in range(1, len(t)):
        noise[i] = NOISE_AR * noise[i - 1] + innovations[i]
    return t, x, force + noise


def write_data(path: Path) -> Path:
    rng = np.random.default_rng(37)
    lines = ["record,t,x_mm,force_n,current_a"]
    for current in CURRENTS:
        for freq, amp in TESTS:
            t, x, f = record(current, freq, amp, rng)
            name = f"I{current:g}_f{freq:g}"
            lines += [f"{name},{a:.5f},{b:.6f},{c:.4f},{current:g}" for a, b, c in zip(t, x, f)]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def data_options(path: Path) -> list[str]:
    held = ", ".join(f"{c:g}" for c in HELD_OUT)
    return ["data=table", f"data.path={path}", "data.record=record", "data.input=x_mm", "data.output=force_n",
            "data.conditions=[current_a]", "data.units={t: s, x: mm, y: N}", "model=mr_damper",
            f"split.held_out=[{{current_a: [{held}]}}]", "datamodule.conditions=[current_a]"]


NEURAL = ["model.effects.viscous.c={kind: neural, base: 1.0, condition: current_a}",
          "model.effects.hysteresis.kappa={kind: neural, base: 50.0, condition: current_a}"]
RUNS = {  # row name -> (run folder, the options after the data options)
    "lstm": ("lstm", ["baseline=lstm"]),
    "mlp": ("mlp", ["baseline=mlp"]),
    "hybrid (output MLP)": ("hybrid_output", ["baseline=hybrid_mlp"]),
    "hybrid (network in the dynamics)": ("hybrid_dynamics", ["baseline=hybrid_dynamics"]),
    # the same with 200 epochs in place of the default 60: is a gap the epoch budget?
    "lstm, 200 epochs": ("lstm_200", ["baseline=lstm", "trainer.max_epochs=200"]),
    "hybrid (output MLP), 200 epochs": ("hybrid_output_200", ["baseline=hybrid_mlp", "trainer.max_epochs=200"]),
    "hybrid (network in the dynamics), 200 epochs": ("hybrid_dynamics_200",
                                                     ["baseline=hybrid_dynamics", "trainer.max_epochs=200"]),
    # the default 60 Adam epochs, then Levenberg-Marquardt on the whole training records (trainer.lm; one setting,
    # the first tried: 20 steps)
    "hybrid (network in the dynamics), then 20 Levenberg–Marquardt steps": ("hybrid_dynamics_lm", [
        "baseline=hybrid_dynamics", "trainer.lm.steps=20"]),
    # the networks inside the law's parameters: c(I) and κ(I) small MLPs of the current (the law's structure kept)
    "law with c(I), κ(I) as networks of the current": ("law_neural", ["baseline=physics", *NEURAL]),
    "law with c(I), κ(I) as networks of the current, 200 epochs": ("law_neural_200", [
        "baseline=physics", *NEURAL, "trainer.max_epochs=200"]),
    "law with c(I), κ(I) as networks of the current, then 20 Levenberg–Marquardt steps": ("law_neural_lm", [
        "baseline=physics", *NEURAL, "trainer.lm.steps=20"]),
    # the two closest rows with two more seeds each (the seed sets the networks' initial weights and the batches):
    # is the gap between them larger than a seed's spread?
    **{f"{name}, seed {seed}": (f"{folder}_seed{seed}", [*options, f"seed={seed}"])
       for name, folder, options in (
           ("lstm, 200 epochs", "lstm_200", ["baseline=lstm", "trainer.max_epochs=200"]),
           ("law with c(I), κ(I) as networks of the current, then 20 Levenberg–Marquardt steps", "law_neural_lm",
            ["baseline=physics", *NEURAL, "trainer.lm.steps=20"]))
       for seed in (1, 2)},
}


def run(name: str, data: Path, scratch: Path) -> dict:
    folder, options = RUNS[name]
    run_dir = scratch / folder
    args = [sys.executable, "-m", "hybridhyst.cli.train", *data_options(data), *options, "progress=false",
            f"hydra.run.dir={run_dir}"]
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    start = time.perf_counter()
    proc = subprocess.run(args, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{name} failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    metrics = json.loads((run_dir / "metrics.json").read_text())
    shown = ["hybridhyst-train", *[o for o in args[3:] if not o.startswith(("hydra.run.dir", "progress="))]]
    code = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True).stdout
    return {"name": name, "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), "code": code.strip(),
            "command": " ".join(shlex.quote(a).replace(str(data), "mr_damper_current.csv")
                                               for a in shown),
            "wall_s": wall, "metrics": metrics}


def _per(part: dict) -> str:
    return " / ".join(f"{part['per_condition'][k]['rmse']:#.3g}" for k in sorted(part["per_condition"]))


def _provenance(summary: dict) -> str:
    """"<date>; commit <c>", or per commit the dates of the rows run there (``--only`` keeps older rows)."""
    runs = [(r.get("code") or summary.get("code") or "unknown", r.get("date") or summary.get("date") or "")
            for r in summary["runs"]]
    codes = list(dict.fromkeys(c for c, _ in runs))
    if len(codes) == 1:
        return f"{max(d for _, d in runs)}; commit {codes[0]}"
    return "; ".join(f"rows of commit {c}: {max(d for cc, d in runs if cc == c)}" for c in codes)


def _curves(summary: dict) -> list[str]:
    """The last row with network parameters (of seed 0): its c(I) and hysteretic level at the training currents
    against the generator's. The level compared is the force the hysteretic element saturates at, κ (β + γ)^(−1/n)
    (fitted n, β, γ; the generator's α / √(β + γ)), since κ alone trades off against the scale of z."""
    rows = [r for r in summary["runs"] if any(k.startswith("viscous.c@") for k in r["metrics"].get("physics", {}))
            and ", seed " not in r["name"]]  # a row of the protocol, not a repeat with another seed
    if not rows:
        return []
    r = rows[-1]
    ph = r["metrics"]["physics"]
    scale = (ph["hysteresis.beta"]["value"] + ph["hysteresis.gamma"]["value"]) ** (-1 / ph["hysteresis.n"]["value"])
    out = ["", f"The fitted curves of \"{r['name']}\" at the training currents (n = {ph['hysteresis.n']['value']:.3g}, "
           f"β = {ph['hysteresis.beta']['value']:.3g}, γ = {ph['hysteresis.gamma']['value']:.3g} 1/mm^n against the "
           f"generator's 2, {BETA:g}, {GAMMA:g}):", "",
           "| current [A] | c fitted [N·s/mm] | c generator | saturated hysteretic force fitted [N] | generator |",
           "|---|---|---|---|---|"]
    for key in sorted((k for k in ph if k.startswith("viscous.c@")), key=lambda k: float(k.split("=")[1])):
        current = float(key.split("=")[1])
        kappa = ph[f"hysteresis.kappa@current_a={key.split('=')[1]}"]["value"]
        out.append(f"| {current:g} | {ph[key]['value']:#.3g} | {damping(current):#.3g} | {kappa * scale:#.3g} | "
                   f"{hysteretic(current) / np.sqrt(BETA + GAMMA):#.3g} |")
    return out


def _seeds(summary: dict) -> list[str]:
    """One line per row that ran with more seeds: its held-out RMSE for each seed, their mean and range."""
    runs = {r["name"]: r["metrics"]["test"]["rmse"] for r in summary["runs"]}
    out = []
    for base in (n for n in runs if f"{n}, seed 1" in runs):
        errs = [runs[base]] + [runs[n] for n in runs if n.startswith(f"{base}, seed ")]
        out.append(f"- {base}: held out {' / '.join(f'{e:#.3g}' for e in errs)} N over seeds 0–{len(errs) - 1} "
                   f"(mean {np.mean(errs):#.3g}, range {min(errs):#.3g}–{max(errs):#.3g})")
    return ["", "Over seeds (the initial weights and the batches):", "", *out] if out else []


def render(summary: dict) -> str:
    rows = ["| model | train RMSE [N] | held-out RMSE [N] (0.5 A / 1.25 A) | training [s] | wall [s] |",
            "|---|---|---|---|---|"]
    nominal = next((r["metrics"]["nominal"] for r in summary["runs"] if r["metrics"].get("nominal")), None)
    if nominal:  # every hybrid identifies the same nominal on the same records first
        rows.append(f"| `mr_damper` alone, identified on the training records | {nominal['train']['rmse']:#.3g} | "
                    f"{nominal['test']['rmse']:#.3g} ({_per(nominal['test'])}) | | |")
    for r in summary["runs"]:
        m = r["metrics"]
        rows.append(f"| {r['name']} | {m['train']['rmse']:#.3g} | {m['test']['rmse']:#.3g} ({_per(m['test'])}) | "
                    f"{m['info']['train_time_s']:.0f} | {r['wall_s']:.0f} |")
    best = min(summary["runs"], key=lambda r: r["metrics"]["test"]["rmse"])
    curves = _curves(summary)
    return "\n".join([
        f"Generated by `{summary['command']}` ({_provenance(summary)}; {summary['machine']}). Force noise: "
        f"AR(1), {NOISE_SD:g} N standard deviation. Training time without the nominal's identification; wall time of "
        "the whole command.", "", *rows, "",
        f"Best held out: {best['name']} ({best['metrics']['test']['rmse']:#.3g} N).", *_seeds(summary), *curves])


def write_readme(summary: dict) -> None:
    path = FOLDER / "README.md"
    text = path.read_text()
    start, end = "<!-- mr:start -->", "<!-- mr:end -->"
    head, rest = text.split(start)
    _, tail = rest.split(end)
    path.write_text(f"{head}{start}\n{render(summary)}\n{end}{tail}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scratch", type=Path, default=ROOT / "outputs" / "mr_damper_hybrids")
    ap.add_argument("--only", nargs="*", help="row names to run (default: all)")
    ap.add_argument("--write-readme", action="store_true")
    ap.add_argument("--render", action="store_true", help="only render the block from the committed summary.json")
    args = ap.parse_args()
    if args.render:
        write_readme(json.loads((FOLDER / "summary.json").read_text()))
        return
    data = write_data(args.scratch / "mr_damper_current.csv")
    unknown = [n for n in args.only or [] if n not in RUNS]
    if unknown:
        raise SystemExit(f"--only: no row {unknown}; the rows: {list(RUNS)}")
    kept = {}  # --only: the other rows from the committed summary
    if args.only and (FOLDER / "summary.json").exists():
        old = json.loads((FOLDER / "summary.json").read_text())
        kept = {r["name"]: {"code": old.get("code"), "date": old.get("date"), **r} for r in old["runs"]}
    runs = [run(name, data, args.scratch) if not args.only or name in args.only else kept[name]
            for name in RUNS if not args.only or name in args.only or name in kept]
    summary = {"command": "PYTHONPATH=. python scripts/mr_damper_hybrids.py --write-readme",
               "machine": f"{os.cpu_count()} cores, {platform.machine()}, load {os.getloadavg()[0]:.2f} at the end",
               "runs": runs}
    FOLDER.mkdir(parents=True, exist_ok=True)
    (FOLDER / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(render(summary))
    if args.write_readme:
        write_readme(summary)


if __name__ == "__main__":
    main()
