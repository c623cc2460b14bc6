"""The default training recipe, chosen by measurement: learning rate and schedule on the bundled default run and
the own-data example, by how the logged validation RMSE ends (does the curve settle, or thrash?) and how low it
gets.

Each recipe runs ``hybridhyst-train`` on (a) the default data (BRFD, 36 lb, ``hybridhyst-train``'s own defaults)
and (b) the README's own-data example (``examples/own_data/damper_loops.csv``, the constant-parameter law
``vpptd_algebraic`` + an MLP that sees the pressure; 0.05 and 0.09 MPa held out, 0.03 and 0.07 MPa validate),
60 epochs each, everything else at its default. Read from each run's TensorBoard events: the best validation
RMSE, the spread (max − min) of the last five epochs' and the last one; from metrics.json the test RMSE of the
evaluated (best) checkpoint.

    PYTHONPATH=. python scripts/training_recipe.py --out experiments/training_recipe
"""

from __future__ import annotations

import argparse
import glob
import json
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECIPES = {
    "constant 3e-3 (the default before)": ["trainer.lr_schedule=constant", "trainer.lr=3e-3"],
    "constant 1e-3": ["trainer.lr_schedule=constant", "trainer.lr=1e-3"],
    "cosine 3e-3 → 1 %": ["trainer.lr_schedule=cosine", "trainer.lr=3e-3", "trainer.lr_final_ratio=0.01"],
    "cosine 3e-3 → 10 %": ["trainer.lr_schedule=cosine", "trainer.lr=3e-3", "trainer.lr_final_ratio=0.1"],
    "cosine 1e-2 → 1 % (the default now)": ["trainer.lr_schedule=cosine", "trainer.lr=1e-2",
                                            "trainer.lr_final_ratio=0.01"],
    "cosine 1e-2 → 10 %": ["trainer.lr_schedule=cosine", "trainer.lr=1e-2", "trainer.lr_final_ratio=0.1"],
}
OWN = ["data=table", "data.path=examples/own_data/damper_loops.csv", "data.record=record", "data.input=angle_deg",
       "data.output=torque_nm", "data.conditions=[pressure_mpa]", "data.units={t: s, x: deg, y: Nm}",
       "model=vpptd_algebraic", "split.held_out=[{pressure_mpa: [0.05, 0.09]}]",
       "split.val=[{pressure_mpa: [0.03, 0.07]}]", "datamodule.conditions=[pressure_mpa]"]
EXAMPLES = {"default (BRFD)": [], "own data (damper_loops.csv)": OWN}


def curve(run_dir: Path) -> list[float]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    for f in glob.glob(str(run_dir / "tensorboard" / "**" / "events*"), recursive=True):
        ev = EventAccumulator(f)
        ev.Reload()
        if "val/rmse" in ev.Tags()["scalars"]:
            return [e.value for e in ev.Scalars("val/rmse")]
    raise RuntimeError(f"no val/rmse in {run_dir}")


def run_one(overrides: list[str], run_dir: Path) -> dict:
    t0 = time.perf_counter()
    subprocess.run(["hybridhyst-train", f"hydra.run.dir={run_dir}", "progress=false", *overrides], cwd=ROOT,
                   check=True, capture_output=True)
    v = curve(run_dir)
    metrics = json.loads((run_dir / "metrics.json").read_text())
    return {"best_val": min(v), "last5_spread": max(v[-5:]) - min(v[-5:]), "last_val": v[-1],
            "test_rmse": metrics["test"]["rmse"], "epochs": len(v), "wall_s": time.perf_counter() - t0}


def markdown(res: dict) -> str:
    lines = []
    for example, rows in res.items():
        lines += [f"**{example}** (validation RMSE per epoch from TensorBoard; test: the evaluated checkpoint)", "",
                  "| recipe | best val | last 5 epochs: spread | last val | test RMSE |", "|---|---|---|---|---|"]
        for name, r in rows.items():
            lines.append(f"| {name} | {r['best_val']:.4f} | {r['last5_spread']:.4f} "
                         f"({100 * r['last5_spread'] / r['last_val']:.1f} %) | {r['last_val']:.4f} | "
                         f"{r['test_rmse']:.4f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for example, data in EXAMPLES.items():
            res[example] = {}
            for i, (name, recipe) in enumerate(RECIPES.items()):
                res[example][name] = run_one(data + recipe, Path(tmp) / f"{len(res)}_{i}")
                print(example, name, res[example][name], flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "recipes.json").write_text(json.dumps(res, indent=1))
    (args.out / "table.md").write_text(markdown(res))
    print(markdown(res))


if __name__ == "__main__":
    main()
