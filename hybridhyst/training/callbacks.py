"""Callbacks: hysteresis-loop figures of the held-out conditions in TensorBoard every N epochs."""

from __future__ import annotations

import lightning as L

from .evaluate import predict_split

__all__ = ["LoopFigures"]


class LoopFigures(L.Callback):
    """Every ``every_n_epochs`` epochs (and after the last), draw measured vs predicted loops (y against x)
    of up to ``max_records`` test (held-out) records, or validation records without a test split, into the
    TensorBoard logger as ``loops/<condition>``. Does nothing without a TensorBoard logger."""

    def __init__(self, every_n_epochs: int = 10, max_records: int = 4):
        self.every, self.max_records = max(1, int(every_n_epochs)), int(max_records)

    def _draw(self, trainer, module):
        logger = getattr(trainer, "logger", None)
        if logger is None or not hasattr(getattr(logger, "experiment", None), "add_figure"):
            return
        dm = trainer.datamodule
        split = "test" if len(dm.records("test")) else "val"
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        units = module.units
        for p in predict_split(module, dm, split)[: self.max_records]:
            fig, ax = plt.subplots(figsize=(4.5, 3.5), dpi=90)
            ax.plot(p["x"], p["y"], lw=0.8, color="0.4", label="measured")
            ax.plot(p["x"], p["y_pred"], lw=0.9, color="C3", label="prediction")
            if p["y_nominal"] is not None and module.kind == "hybrid":
                ax.plot(p["x"], p["y_nominal"], lw=0.7, ls="--", color="C0", label="nominal")
            ax.set_xlabel(f"x [{units.get('x', '')}]")
            ax.set_ylabel(f"y [{units.get('y', '')}]")
            ax.set_title(p["condition"], fontsize=8)
            ax.legend(fontsize=7)
            fig.tight_layout()
            logger.experiment.add_figure(f"loops/{p['condition']}", fig, global_step=trainer.global_step)
            plt.close(fig)

    def on_train_epoch_end(self, trainer, module):
        if (trainer.current_epoch + 1) % self.every == 0:
            self._draw(trainer, module)

    def on_train_end(self, trainer, module):
        if trainer.current_epoch % self.every != 0:
            self._draw(trainer, module)
