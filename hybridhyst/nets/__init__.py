"""Plain neural blocks for residual branches and baselines (no physics inside)."""

from .blocks import MLP, LSTMNet, build_net, count_parameters, parse_hidden

__all__ = ["LSTMNet", "MLP", "build_net", "count_parameters", "parse_hidden"]
