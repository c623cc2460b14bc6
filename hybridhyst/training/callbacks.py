"""Callbacks: hysteresis-loop figures of the held-out conditions in TensorBoard every N epochs."""

from __future__ import annotations

import lightning as L

from ..report.figures import Loop, draw_loops
from .evaluate import predict_split

__all__ = ["LoopFigures"]


class LoopFigures(L.Callback):
    """Every ``every_n_epochs`` epochs (and after the last), draw measured vs predicted loops (y against x;
    ``draw_loops``, axes in the data's units) of up to ``max_records`` test (held-out) records, or validation
    records without a test split, into the TensorBoard logger as ``loops/<condition>``. Does nothing without
    a TensorBoard logger."""

    def __init__(self, every_n_epochs: int = 10, max_records: int = 4):
        self.every, self.max_records = max(1, int(every_n_epochs)), int(max_records)

    def _draw(self, trainer, module):
        logger = getattr(trainer, "logger", None)
        if logger is None or not hasattr(getattr(logger, "experiment", None), "add_figure"):
            return
        dm = trainer.datamodule
        split = "test" if len(dm.records("test")) else "val"
        for p in predict_split(module, dm, split)[: self.max_records]:
            predictions = {"prediction": [p["y_pred"]]}
            if p["y_nominal"] is not None and module.kind == "hybrid":
                predictions["nominal"] = [p["y_nominal"]]
            loop = Loop(p["x"], p["y"], name=p["condition"], units=module.units)
            fig = draw_loops([loop], predictions, styles={"nominal": {"color": "C0", "ls": "--", "lw": 0.7}})
            logger.experiment.add_figure(f"loops/{p['condition']}", fig, global_step=trainer.global_step)
            import matplotlib.pyplot as plt  # after draw_loops, which selects the Agg backend

            plt.close(fig)

    def on_train_epoch_end(self, trainer, module):
        if (trainer.current_epoch + 1) % self.every == 0:
            self._draw(trainer, module)

    def on_train_end(self, trainer, module):
        if trainer.current_epoch % self.every != 0:
            self._draw(trainer, module)
