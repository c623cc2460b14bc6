"""Lightning modules (physics-only, hybrid, MLP, LSTM, standard PINN), losses, evaluation and callbacks, and the
builders that make one training run from a composed ``conf/train.yaml`` (``build``).

The names below are imported on first use (PEP 562): every app reads its config through ``training.config``,
and an app that trains nothing (``hybridhyst-discover``, ``hybridhyst-identify``) need not import Lightning.
"""

from importlib import import_module

_WHERE = {
    "build_datamodule": "build", "build_module": "build", "build_trainer": "build", "run_info": "build",
    "LoopFigures": "callbacks",
    "predict_split": "evaluate", "predictions_frame": "evaluate", "split_metrics": "evaluate",
    **{name: "modules" for name in ("MODULES", "HybridModule", "LSTMModule", "MLPModule", "PhysicsModule",
                                    "SequenceModule", "StdPINNModule")},
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f".{_WHERE[name]}", __name__), name)


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
