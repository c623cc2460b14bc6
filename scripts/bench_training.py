"""Benchmark of in-the-loop training: wall time per Adam epoch of the hybrid with a network inside the dynamics
(``baseline=hybrid_dynamics``) next to the LSTM baseline and the output hybrid, on the same windows and batch of
the Bouc–Wen benchmark's training record (``experiment=boucwen_baselines``), measured side by side in one run.

Every module is built by the training app's own builders (``hybridhyst.cli.train``) from the same composed
config; the nominal starts from the linear oscillator's model config (no identification: it is not part of an
epoch). A Lightning callback times each training epoch (validation off); the first epoch (model build, cache
load, warm-up) is excluded, the median of the rest is reported with its ratio to the LSTM's. Where CUDA is
available the same runs are repeated with ``trainer=gpu`` (GPU columns; "not measured" otherwise).

    PYTHONPATH=. python scripts/bench_training.py --json experiments/performance/bench_training.json --write-readme

``--quick`` is a smoke version (two short epochs on a fraction of the windows).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))  # bench_simulate
COMMON = ["experiment=boucwen_baselines", "datamodule.window=256", "datamodule.warmup=64", "datamodule.batch_size=64",
          "nominal_init.start=none", "logger=none", "progress=false", "trainer.check_val_every_n_epoch=1000",
          "trainer.limit_val_batches=0"]
MODULES = {
    "LSTM (2×64)": ["baseline=lstm"],
    "in-the-loop hybrid (2×32 MLP force, 1 latent state)": ["baseline=hybrid_dynamics", "freeze_nominal=false"],
    "in-the-loop hybrid + window-start encoder (past 64)": ["baseline=hybrid_dynamics", "freeze_nominal=false",
                                                            "encoder.past=64"],
    "output hybrid (4×128 MLP)": ["baseline=hybrid_mlp"],
}


def epoch_times(overrides: list[str], epochs: int, limit: float | None) -> tuple[list[float], int, int]:
    """Seconds per training epoch of one module, its number of weights and training windows."""
    import lightning as L
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli.train import build_datamodule, build_module
    from hybridhyst.settings import CONF_DIR, torch_settings

    class Clock(L.Callback):
        def __init__(self):
            self.times: list[float] = []

        def on_train_epoch_start(self, trainer, module):
            self.t0 = time.perf_counter()

        def on_train_epoch_end(self, trainer, module):
            self.times.append(time.perf_counter() - self.t0)

    with tempfile.TemporaryDirectory() as run_dir, initialize_config_dir(str(CONF_DIR), version_base=None):
        cfg = compose("train", overrides=[f"run_dir={run_dir}", *COMMON, *overrides])
        with torch_settings("float64", cfg.get("threads"), 0):
            dm = build_datamodule(cfg)
            module = build_module(cfg, dm)
            clock = Clock()
            accelerator = "gpu" if "trainer=gpu" in overrides else "cpu"
            trainer = L.Trainer(max_epochs=epochs, accelerator=accelerator, devices=1, precision="64-true",
                                logger=False, enable_checkpointing=False, enable_progress_bar=False,
                                enable_model_summary=False, limit_val_batches=0, num_sanity_val_steps=0,
                                limit_train_batches=limit, callbacks=[clock], gradient_clip_val=1.0)
            trainer.fit(module, dm)
            n_weights = sum(p.numel() for p in module.parameters() if p.requires_grad)
            return clock.times, n_weights, len(dm.train_dataloader().dataset)


def run(quick: bool) -> dict:
    epochs, limit = (2, 0.34) if quick else (6, None)
    devices = ["cpu"] + (["gpu"] if torch.cuda.is_available() else [])
    from bench_simulate import machine_brief

    out = {"epochs": epochs, **machine_brief(), "torch": torch.__version__,
           "gpu": torch.cuda.get_device_name(0) if torch.cuda.is_available() else None, "rows": {}}
    for name, overrides in MODULES.items():
        row = {}
        for device in devices:
            extra = ["trainer=gpu"] if device == "gpu" else []
            times, n_weights, windows = epoch_times(overrides + extra, epochs, limit)
            later = times[1:] or times
            row[device] = {"epoch_s": statistics.median(later), "all_epochs_s": times}
            row["weights"], row["windows"] = n_weights, windows
        out["rows"][name] = row
    lstm = out["rows"]["LSTM (2×64)"]
    for row in out["rows"].values():
        for device in devices:
            row[device]["ratio_to_lstm"] = row[device]["epoch_s"] / lstm[device]["epoch_s"]
    return out


def markdown(res: dict) -> str:
    first = next(iter(res["rows"].values()))
    gpu = res["gpu"] or "not measured (no GPU in this session)"
    lines = [f"Seconds per Adam epoch on the Bouc–Wen training record ({first['windows']} windows of 256 samples, 64 "
             f"per batch, float64), median of epochs 2–{res['epochs']}; {res['cpu_cores']} CPU cores, load average at "
             f"the start {res['load_average_at_start']}. GPU: {gpu}.", "",
             "| module | weights | CPU s/epoch | × LSTM | GPU s/epoch | × LSTM (GPU) |", "|---|---|---|---|---|---|"]
    for name, row in res["rows"].items():
        g = row.get("gpu")
        gpu_cols = f"{g['epoch_s']:.2f} | {g['ratio_to_lstm']:.2f}×" if g else "not measured | —"
        lines.append(f"| {name} | {row['weights']} | {row['cpu']['epoch_s']:.2f} | {row['cpu']['ratio_to_lstm']:.2f}× "
                     f"| {gpu_cols} |")
    return "\n".join(lines)


def main(argv=None) -> dict:
    from bench_simulate import simple_main

    return simple_main(argv, __doc__, "bench_training", run, markdown)


if __name__ == "__main__":
    main()
