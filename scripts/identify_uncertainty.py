"""Do ``hybridhyst-identify``'s standard deviations match the scatter of its estimates?

Monte Carlo on MR-damper loops made with scipy (Bouc–Wen state by ``solve_ivp``, 20 internal steps per sample,
one loop of 10 mm at 1 Hz, 400 Hz, 2 N white noise): ``hybridhyst-identify model=mr_damper noise_sd=2.0`` with
its defaults on each of ``--draws`` noise draws; per parameter the estimates' mean and sample sd against the
mean reported sd. Writes ``experiments/identify_uncertainty/summary.json`` and prints the table::

    OMP_NUM_THREADS=1 PYTHONPATH=. python scripts/identify_uncertainty.py --draws 16
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from hydra import compose, initialize_config_dir

from hybridhyst.cli import identify as identify_cli
from hybridhyst.cli.common import CONF_DIR
from hybridhyst.testbed.generators import mr_damper

TRUTH = {"viscous.c": 2.0, "stiffness.k": 0.8, "hysteresis.kappa": 80.0, "hysteresis.beta": 0.3,
         "hysteresis.gamma": 0.3, "hysteresis.n": 2.0}
AMPLITUDE_MM, FREQUENCY_HZ, RATE_HZ, NOISE_N = 10.0, 1.0, 400.0, 2.0
OUT = Path(__file__).resolve().parents[1] / "experiments" / "identify_uncertainty" / "summary.json"


def clean_loop() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(0.0, 2 / FREQUENCY_HZ, 1 / RATE_HZ)
    x = AMPLITUDE_MM * np.sin(2 * np.pi * FREQUENCY_HZ * t)
    return t, x, mr_damper(t, AMPLITUDE_MM, FREQUENCY_HZ, *TRUTH.values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=16)
    args = parser.parse_args()
    t, x, force = clean_loop()
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for draw in range(args.draws):
            path = Path(tmp) / f"draw{draw}.csv"
            noise = np.random.default_rng(100 + draw).normal(0.0, NOISE_N, len(t))
            pd.DataFrame({"record": "r", "t": t, "x_mm": x, "F_N": force + noise}).to_csv(path, index=False)
            overrides = [f"run_dir={Path(tmp) / f'run{draw}'}", "progress=false", "data=table", f"data.path={path}",
                         "data.record=record", "data.input=x_mm", "data.output=F_N",
                         "data.units={t: s, x: mm, y: N}", "model=mr_damper", f"noise_sd={NOISE_N}"]
            with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
                summary = identify_cli.run(compose(config_name="identify", overrides=overrides))
            runs.append({"coordinates": summary["coordinates"], "sd": summary["uncertainty"], "rmse": summary["rmse"]})
    table = {}
    for name, truth in TRUTH.items():
        values = np.array([r["coordinates"][name] for r in runs])
        reported = float(np.mean([r["sd"][name] for r in runs]))
        table[name] = {"truth": truth, "mean": float(values.mean()), "scatter_sd": float(values.std(ddof=1)),
                       "reported_sd": reported, "ratio": float(values.std(ddof=1) / reported)}
    result = {"command": "hybridhyst-identify model=mr_damper noise_sd=2.0 (defaults otherwise)",
              "data": {"amplitude_mm": AMPLITUDE_MM, "frequency_hz": FREQUENCY_HZ, "rate_hz": RATE_HZ,
                       "noise_n": NOISE_N, "truth": TRUTH},
              "draws": args.draws, "parameters": table, "runs": runs}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print(f"{'parameter':20s} {'truth':>8s} {'mean':>8s} {'scatter sd':>11s} {'reported sd':>12s} {'ratio':>6s}")
    for name, row in table.items():
        print(f"{name:20s} {row['truth']:8.4g} {row['mean']:8.4g} {row['scatter_sd']:11.3g} "
              f"{row['reported_sd']:12.3g} {row['ratio']:6.2f}")
    print(f"written: {OUT}")


if __name__ == "__main__":
    main()
