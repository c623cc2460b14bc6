"""Lightning modules (physics-only, hybrid, MLP, LSTM, standard PINN), losses, evaluation and callbacks."""

from .callbacks import LoopFigures
from .evaluate import predict_split, predictions_frame, split_metrics
from .modules import MODULES, HybridModule, LSTMModule, MLPModule, PhysicsModule, SequenceModule, StdPINNModule

__all__ = ["MODULES", "HybridModule", "LSTMModule", "LoopFigures", "MLPModule", "PhysicsModule", "SequenceModule",
           "StdPINNModule", "predict_split", "predictions_frame", "split_metrics"]
