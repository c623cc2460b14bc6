"""How much does a training window's start state cost on the Bouc–Wen benchmark? Simulates the *true* system
(``model=boucwen_benchmark``, the published parameters) on the training record's windows as ``hybridhyst-train``
cuts them (``RecordDataModule``: 256 samples, stride 128, 64 not scored) from four starts: the measured displacement
with a forward-difference velocity and the hysteretic state at 0 (what training does without an encoder), the same
with the true hysteretic state, the simulated (x, v) with z = 0, and the whole simulated state; and the RMSE of the
scored samples of each. The simulated states come from the true model run over the whole record from rest. Writes
``experiments/boucwen_baselines/window_start.json`` with ``--json``.

    PYTHONPATH=. python scripts/window_start.py --json experiments/boucwen_baselines/window_start.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

WINDOW, WARMUP = 256, 64


def run() -> dict:
    import numpy as np
    import torch

    from hybridhyst.data import load_builtin
    from hybridhyst.data.datamodule import RecordDataModule
    from hybridhyst.physics.compositions import boucwen_benchmark
    from hybridhyst.simulate import simulate

    torch.set_num_threads(1)
    rec = next(r for r in load_builtin("boucwen").records if r.conditions.get("split") == "train")
    # the windows exactly as hybridhyst-train cuts them (stride window // 2), each with its measured start (y, ẏ)
    dm = RecordDataModule([rec], window=WINDOW, warmup=WARMUP, batch_size=10**6)
    batch = next(iter(dm.train_dataloader()))
    inside = batch["start"] > 0  # the record's first window starts at rest in every variant: left out
    starts = batch["start"][inside].numpy()
    measured = batch["y0"][inside].numpy()
    model = boucwen_benchmark().double()
    with torch.no_grad():
        whole, S = simulate(model, torch.tensor(rec.x)[None], t=torch.tensor(rec.t), return_states=True,
                            backend="fast")
    whole, S = whole[0, :, 0].numpy(), S[0].numpy()
    U, Y, mask = batch["u"][inside], batch["y"][inside].numpy(), batch["mask"][inside].numpy() > 0

    def scored_rmse(state0) -> float:
        with torch.no_grad():
            sim = simulate(model, U, t=batch["t"][0] - batch["t"][0, 0], initial_state=torch.tensor(state0),
                           backend="fast")[..., 0].numpy()
        return float(np.sqrt(np.mean((sim - Y)[mask] ** 2)))

    z0 = np.zeros((len(starts), 1))
    rows = {
        "measured y, forward-difference v, z = 0 (training without an encoder)":
            scored_rmse(np.hstack([measured, z0])),
        "measured y, forward-difference v, true z": scored_rmse(np.hstack([measured, S[starts, 2:]])),
        "true x, v, z = 0": scored_rmse(np.hstack([S[starts, :2], z0])),
        "true x, v, z": scored_rmse(S[starts]),
    }
    return {"record": rec.name, "window": WINDOW, "stride": dm.stride, "warmup": WARMUP, "windows": len(starts),
            "true_model_whole_record_rmse_m": float(np.sqrt(np.mean((whole - np.asarray(rec.y)) ** 2))),
            "scored_rmse_m": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="write the result here")
    args = parser.parse_args(argv)
    out = run()
    for name, value in out["scored_rmse_m"].items():
        print(f"{value:.3g} m  {name}")
    print(f"{out['true_model_whole_record_rmse_m']:.3g} m  the true model over the whole record from rest")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
