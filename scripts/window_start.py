"""How much does a training window's start state cost on the Bouc–Wen benchmark? Simulates the *true* system
(``model=boucwen_benchmark``, the published parameters) on the training record's windows as ``hybridhyst-train``
cuts them (256 samples, stride 128, 64 not scored) from four starts: the measured displacement with a
forward-difference velocity and the hysteretic state at 0 (what training does without an encoder), the same
with the true hysteretic state, the simulated (x, v) with z = 0, and the whole simulated state; and the RMSE of
the scored samples of each. The simulated states come from the true model run over the whole record from rest.
Writes ``experiments/boucwen_baselines/window_start.json`` with ``--json``.

    PYTHONPATH=. python scripts/window_start.py --json experiments/boucwen_baselines/window_start.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

WINDOW, STRIDE, WARMUP = 256, 128, 64


def run() -> dict:
    import numpy as np
    import torch

    from hybridhyst.data import load_builtin
    from hybridhyst.physics.compositions import boucwen_benchmark
    from hybridhyst.simulate import simulate

    rec = next(r for r in load_builtin("boucwen").records if r.conditions.get("split") == "train")
    t, u, y = (np.asarray(a, dtype=np.float64) for a in (rec.t, rec.x, rec.y))
    model = boucwen_benchmark().double()
    with torch.no_grad():
        whole, S = simulate(model, torch.tensor(u)[None], t=torch.tensor(t), return_states=True, backend="fast")
    whole, S = whole[0, :, 0].numpy(), S[0].numpy()
    starts = list(range(STRIDE, len(t) - WINDOW + 1, STRIDE))  # windows inside the record (the first starts at rest)
    U = torch.tensor(np.array([u[s:s + WINDOW] for s in starts]))
    Y = np.array([y[s:s + WINDOW] for s in starts])
    grid = torch.tensor(t[:WINDOW] - t[0])

    def scored_rmse(state0) -> float:
        with torch.no_grad():
            sim = simulate(model, U, t=grid, initial_state=torch.tensor(np.array(state0)), backend="fast")
        return float(np.sqrt(np.mean((sim[:, WARMUP:, 0].numpy() - Y[:, WARMUP:]) ** 2)))

    dv = [(y[s + 1] - y[s]) / (t[s + 1] - t[s]) for s in starts]
    rows = {
        "measured y, forward-difference v, z = 0 (training without an encoder)":
            scored_rmse([[y[s], v, 0.0] for s, v in zip(starts, dv)]),
        "measured y, forward-difference v, true z": scored_rmse([[y[s], v, S[s, 2]] for s, v in zip(starts, dv)]),
        "true x, v, z = 0": scored_rmse([[S[s, 0], S[s, 1], 0.0] for s in starts]),
        "true x, v, z": scored_rmse([list(S[s]) for s in starts]),
    }
    return {"record": rec.name, "window": WINDOW, "stride": STRIDE, "warmup": WARMUP, "windows": len(starts),
            "true_model_whole_record_rmse_m": float(np.sqrt(np.mean((whole - y) ** 2))),
            "scored_rmse_m": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="write the result here")
    args = parser.parse_args(argv)
    torch_threads()
    out = run()
    for name, value in out["scored_rmse_m"].items():
        print(f"{value:.3g} m  {name}")
    print(f"{out['true_model_whole_record_rmse_m']:.3g} m  the true model over the whole record from rest")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


def torch_threads():
    import torch

    torch.set_num_threads(1)


if __name__ == "__main__":
    sys.exit(main())
