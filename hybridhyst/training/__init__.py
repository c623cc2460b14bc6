"""Lightning modules (physics-only, hybrid, MLP, LSTM, standard PINN), losses, evaluation and callbacks, and the
builders that make one training run from a composed ``conf/train.yaml`` (``build``)."""

from .build import build_datamodule, build_module, build_trainer, run_info
from .callbacks import LoopFigures
from .evaluate import predict_split, predictions_frame, split_metrics
from .modules import MODULES, HybridModule, LSTMModule, MLPModule, PhysicsModule, SequenceModule, StdPINNModule

__all__ = ["MODULES", "HybridModule", "LSTMModule", "LoopFigures", "MLPModule", "PhysicsModule", "SequenceModule",
           "StdPINNModule", "build_datamodule", "build_module", "build_trainer", "predict_split", "predictions_frame",
           "run_info", "split_metrics"]
