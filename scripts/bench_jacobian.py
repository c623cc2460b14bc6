"""Benchmark of Levenberg–Marquardt's Jacobians: exact forward sensitivities against finite differences.

(6) For two least-squares problems, the Jacobian of K = 3 rows (a population, as discovery's converged LM holds)
w.r.t. every coordinate, the two ways ``identify.refine.levenberg_marquardt`` can take it, measured side by side
in one run at 1 and 4 sub-steps per sample:

* **exact**: ``RecordsProblem.jacobian_rows``, the compiled loop's forward sensitivities w.r.t. every parameter
  in one pass (``simulate.simulate_jacobian``) chained through the parameter functions;
* **finite differences**: forward differences of the residuals, one simulated row per coordinate and row.

Each is given as a multiple of one simulation of the K rows (the residuals alone), with the column-wise relative
difference between the two Jacobians. Then Levenberg–Marquardt itself, 25 iterations from the same perturbed
starts, with each Jacobian: wall time, final cost, simulated rows.

The parameter functions' derivatives w.r.t. the coordinates (the factor the sensitivities are chained with;
``RecordsProblem._value_jacobian``) are taken by reverse mode (``simulate.row_jacobian``); forward-mode AD, the
obvious tool, runs its dual tensors through torch's Python reference implementations in torch 2.13. Both are timed
side by side on the first time-grid group, with their largest relative difference.

Problems: ``seed001``, the modified Bouc–Wen + viscous + Coulomb law of seed 001 with its parameters linear in
the pressure (21 coordinates) on the bundled 1:3 loops at 0.02, 0.05 and 0.08 MPa (0.2 Nm noise); ``brfd``, the
structure discovery names for the measured BRFD damper (built from ``experiments/brfd_discovery/discovery.json``:
today clearance + LuGre, 10 coordinates) on its seven 36 lb training tests (thinned as discovery
thins them); ``delay``, seed 001's law read 4 ms late (a ``time_delay``: 22 coordinates, the input itself moves
with one) on seed 001's loops.

    PYTHONPATH=. python scripts/bench_jacobian.py --json bench_jacobian.json --write-readme

Jacobian timings are wall-clock medians of 5 calls after a first call of each kind (C build or cache load,
excluded); the LM runs are timed once each. A script, not a timed test: numbers depend on the machine load.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_simulate import bench_parser, command_line, emit, machine_info, machine_markdown  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ROWS, LM_ITERS, H = 3, 25, 1e-6  # H: levenberg_marquardt's default forward-difference step (on the logits)


def seed001_problem():
    """(model, records): seed 001's 1:3 law at its published values, three loops with 0.2 Nm noise."""
    from hybridhyst.data import load_builtin
    from hybridhyst.physics.compositions import modified_bouc_wen

    records = load_builtin("vpptd", mixtures=["1:3"], pressures=[0.02, 0.05, 0.08], noise_sd=0.2, seed=0)
    return modified_bouc_wen("1:3").double(), list(records)


def brfd_problem():
    """(model, records): the discovered BRFD structure at its reported values, the 36 lb training tests."""
    import brfd_tension

    cfg, _, split = brfd_tension.load(36)
    from hybridhyst.cli.common import instantiate

    nominal = instantiate(cfg.model, _convert_="all").double()
    report = json.loads((ROOT / "experiments/brfd_discovery/discovery.json").read_text())
    return brfd_tension.build_structure(report, nominal), list(split.train)


def delay_problem():
    """(model, records): seed 001's law read 4 ms late (a ``time_delay`` added), on seed 001's three loops: the
    input moves with a coordinate (exact sensitivities since the delay's column was added to the compiled loop;
    differences before)."""
    from hybridhyst.physics.effects import EFFECTS

    model, records = seed001_problem()
    return model.with_effects({**model.effects, "delay": EFFECTS["time_delay"](tau=0.004)}).double(), records


PROBLEMS = {"seed001": seed001_problem, "brfd": brfd_problem, "delay": delay_problem}


def timed(fn, repeats: int) -> float:
    fn()  # first call: compile or load from the disk cache, excluded
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def starts(space, rows: int, seed: int = 0) -> torch.Tensor:
    """``rows`` points around the model's values: each coordinate moved by up to ±20 % of its box's log-width."""
    g = torch.Generator().manual_seed(seed)
    W0 = torch.logit(space.to_unit(space.initial()[None].clamp(space.lower, space.upper)).clamp(1e-6, 1 - 1e-6))
    W = W0 + 0.4 * (torch.rand(rows, space.dim, generator=g, dtype=torch.float64) - 0.5)
    return space.from_unit(torch.sigmoid(W))


def column_differences(J_exact: torch.Tensor, J_fd: torch.Tensor) -> list[float | None]:
    """Per coordinate: ‖J_exact − J_fd‖ / ‖J_exact‖ over every row and sample; None for a column below 1e-6 of the
    largest (a coordinate the response does not feel, such as a level fitted to 1e-130)."""
    num = (J_exact - J_fd).square().sum(dim=(0, 1)).sqrt()
    den = J_exact.square().sum(dim=(0, 1)).sqrt()
    floor = 1e-6 * float(den.max())
    return [float(n / d) if float(d) >= floor else None for n, d in zip(num, den)]


def forward_mode_values(space, X: torch.Tensor, idx: list[int], cond, R: int) -> dict:
    """The parameter values' derivatives ``{effect: {parameter: (N·R, F)}}`` w.r.t. the coordinates ``idx`` by
    forward-mode AD (coordinate j's direction in its own block of rows): what ``_value_jacobian`` computes."""
    import torch.autograd.forward_ad as fwAD

    N, F = X.shape[0], len(idx)
    E = X.new_zeros(N, F, X.shape[1])
    E[:, torch.arange(F), idx] = 1.0
    with fwAD.dual_level():
        values = space.values(fwAD.make_dual(X.repeat_interleave(F, 0), E.reshape(N * F, -1)), cond, R)
        tangents = {k: {n: fwAD.unpack_dual(v).tangent for n, v in d.items()} for k, d in values.items()}
    return {k: {n: X.new_zeros(N * R, F) if v is None else v.reshape(N, F, R).transpose(1, 2).reshape(N * R, F)
                for n, v in d.items()} for k, d in tangents.items()}


def value_derivatives(problem, X: torch.Tensor, repeats: int) -> dict:
    """Forward-mode AD against ``_value_jacobian`` (reverse mode, constants as unit columns): times, ratio, largest
    relative difference."""
    space, (_, _, U, _, cond) = problem.space, problem.groups[0]
    idx, R = list(range(space.dim)), U.shape[0]
    forward_s = timed(lambda: forward_mode_values(space, X, idx, cond, R), repeats)
    reverse_s = timed(lambda: problem._value_jacobian(X, idx, cond, R), repeats)
    fwd, rev = forward_mode_values(space, X, idx, cond, R), problem._value_jacobian(X, idx, cond, R)
    diff = max(float(((rev[k][n] - v).abs() / v.abs().clamp_min(1e-300)).max()) for k, d in fwd.items()
               for n, v in d.items())
    return {"forward_mode_s": forward_s, "reverse_mode_s": reverse_s, "forward_over_reverse": forward_s / reverse_s,
            "max_relative_difference": diff}


def bench_problem(name: str, substeps: int, repeats: int) -> dict:
    from hybridhyst.identify.identify import RecordsProblem
    from hybridhyst.identify.refine import _lm_exact, _lm_jacobian, _lm_residuals, levenberg_marquardt
    from hybridhyst.identify.space import SearchSpace, condition_ranges

    model, records = PROBLEMS[name]()
    space = SearchSpace(model, condition_ranges=condition_ranges(records), factor=10.0)
    problem = RecordsProblem(space, records, method="rk4", substeps=substeps, backend="fast")
    if problem.jacobian_rows is None:
        raise RuntimeError(f"{name}: the exact Jacobian does not cover this model")
    X = starts(space, ROWS)
    W = torch.logit(space.to_unit(X).clamp(1e-6, 1 - 1e-6))
    free = torch.ones(space.dim, dtype=torch.bool)
    r0 = _lm_residuals(problem.residuals, space, W)  # at the logits' point, as LM takes its differences
    sim_s = timed(lambda: problem.residuals(X), repeats)
    exact_s = timed(lambda: _lm_exact(problem.jacobian_rows, space, W, free), repeats)
    fd_s = timed(lambda: _lm_jacobian(problem.residuals, space, W, r0, H, free), repeats)
    _, J_exact = _lm_exact(problem.jacobian_rows, space, W, free)
    J_fd = _lm_jacobian(problem.residuals, space, W, r0, H, free)
    diffs = column_differences(J_exact, J_fd)
    felt = [d for d in diffs if d is not None]
    lm = {}
    for label, jac in (("exact", problem.jacobian_rows), ("finite_differences", None)):
        t0 = time.perf_counter()
        res = levenberg_marquardt(problem.residuals, space, X, iters=LM_ITERS, progress=False, jacobian_rows=jac)
        lm[label] = {"wall_s": time.perf_counter() - t0, "cost": res.cost, "evaluations": res.evaluations}
    row = {"problem": name, "substeps": substeps, "rows": ROWS, "coordinates": space.dim,
           "samples": problem.n_samples, "simulation_s": sim_s, "exact_s": exact_s, "finite_differences_s": fd_s,
           "exact_over_simulation": exact_s / sim_s, "fd_over_simulation": fd_s / sim_s,
           "fd_over_exact": fd_s / exact_s,
           "column_difference": dict(zip(space.names, diffs)),
           "column_difference_median": statistics.median(felt), "column_difference_max": max(felt),
           "columns_below_floor": len(diffs) - len(felt), "lm": lm,
           "value_derivatives": value_derivatives(problem, X, repeats)}
    print(f"  {name} substeps={substeps}: simulation {sim_s * 1e3:.1f} ms, exact {exact_s * 1e3:.1f} ms "
          f"({row['exact_over_simulation']:.1f}x), finite differences {fd_s * 1e3:.1f} ms "
          f"({row['fd_over_simulation']:.1f}x); LM exact {lm['exact']['wall_s']:.2f} s "
          f"cost {lm['exact']['cost']:.5g}, LM fd {lm['finite_differences']['wall_s']:.2f} s "
          f"cost {lm['finite_differences']['cost']:.5g}", flush=True)
    return row


def report_markdown(result: dict) -> str:
    lines = [f"Generated by `{result['command']}` (finished {result['finished_utc']}).", "",
             machine_markdown(result["machine"]), "",
             f"**(6) Jacobians of {ROWS} rows w.r.t. every coordinate**, as multiples of one simulation of the same "
             "rows (the residuals alone); column difference: ‖J_exact − J_fd‖ / ‖J_exact‖ per coordinate, "
             "median (max) over the coordinates whose column is at least 1e-6 of the largest (forward differences, "
             "step 1e-6 on the logits; coordinates below that: the last column):", "",
             "| problem | coordinates | samples | sub-steps | simulation | exact | finite differences "
             "| finite differences / exact | column difference | below |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['problem']} | {r['coordinates']} | {r['samples']} | {r['substeps']} "
                     f"| {r['simulation_s'] * 1e3:.3g} ms | {r['exact_s'] * 1e3:.3g} ms "
                     f"({r['exact_over_simulation']:.1f}×) | {r['finite_differences_s'] * 1e3:.3g} ms "
                     f"({r['fd_over_simulation']:.1f}×) | **{r['fd_over_exact']:.1f}×** "
                     f"| {r['column_difference_median']:.1e} ({r['column_difference_max']:.1e}) "
                     f"| {r['columns_below_floor']} |")
    lines += ["", f"Levenberg–Marquardt, {LM_ITERS} iterations from the same {ROWS} perturbed starts (final cost: the "
              "best row's mean squared residual; simulated rows: a Jacobian pass counts as one):", "",
              "| problem | sub-steps | exact: wall | cost | simulated rows | finite differences: wall | cost "
              "| simulated rows | wall ratio |", "|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        e, f = r["lm"]["exact"], r["lm"]["finite_differences"]
        lines.append(f"| {r['problem']} | {r['substeps']} | {e['wall_s']:.2f} s | {e['cost']:.5g} | {e['evaluations']} "
                     f"| {f['wall_s']:.2f} s | {f['cost']:.5g} | {f['evaluations']} "
                     f"| **{f['wall_s'] / e['wall_s']:.1f}×** |")
    lines += ["", f"The parameter values' derivatives w.r.t. every coordinate ({ROWS} rows, the first time-grid "
              "group): forward-mode AD against reverse mode (`row_jacobian`, constants written as unit columns), "
              "with the largest relative difference between the two:", "",
              "| problem | sub-steps | forward mode | reverse mode | forward / reverse | largest difference |",
              "|---|---|---|---|---|---|"]
    for r in result["rows"]:
        v = r["value_derivatives"]
        lines.append(f"| {r['problem']} | {r['substeps']} | {v['forward_mode_s'] * 1e3:.3g} ms "
                     f"| {v['reverse_mode_s'] * 1e3:.3g} ms | **{v['forward_over_reverse']:.0f}×** "
                     f"| {v['max_relative_difference']:.1e} |")
    return "\n".join(lines)


def parse_args(argv=None) -> argparse.Namespace:
    return bench_parser(__doc__, "bench_jacobian", "smoke run: seed001 at one sub-step, one repeat").parse_args(argv)


def main(argv=None) -> dict:
    args = parse_args(argv)
    torch.set_default_dtype(torch.float64)
    torch.set_num_threads(1)
    cases = [("seed001", 1), ("delay", 1)] if args.quick else [(p, s) for p in PROBLEMS for s in (1, 4)]
    print("(6) Jacobians: exact forward sensitivities vs finite differences", flush=True)
    rows = [bench_problem(p, s, 1 if args.quick else 5) for p, s in cases]
    result = {"command": command_line(), "quick": bool(args.quick), "machine": machine_info(), "rows": rows,
              "finished_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    return emit(args, "bench_jacobian", result, report_markdown(result))


if __name__ == "__main__":
    main()
