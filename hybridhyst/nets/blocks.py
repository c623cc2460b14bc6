"""MLP and LSTM blocks: feature sequences ``(batch, time, in)`` → ``(batch, time, out)``.

The last layer can start at zero (``zero_last=True``) so that a hybrid model's residual branch adds
nothing at initialisation and training starts exactly at the nominal physics (seed 003, Sec. 3.3).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

__all__ = ["LSTMNet", "MLP", "build_net", "count_parameters", "parse_hidden"]

_ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "gelu": nn.GELU, "silu": nn.SiLU, "elu": nn.ELU}


def parse_hidden(hidden) -> list[int]:
    """Hidden widths from a list ``[64, 64]`` or a string ``"2x64"`` (layers × width)."""
    if isinstance(hidden, str):
        try:
            layers, width = hidden.lower().replace("×", "x").split("x")
            return [int(width)] * int(layers)
        except ValueError:
            raise ValueError(f"hidden {hidden!r}: write layers x width, e.g. '4x128', or a list of widths") from None
    widths = [int(h) for h in hidden]
    if not widths or min(widths) < 1:
        raise ValueError(f"hidden {hidden!r}: need at least one layer of positive width")
    return widths


def _activation(name: str) -> nn.Module:
    if name not in _ACTIVATIONS:
        raise ValueError(f"unknown activation {name!r}; choose from {sorted(_ACTIVATIONS)}")
    return _ACTIVATIONS[name]()


class MLP(nn.Module):
    """Pointwise multilayer perceptron applied to every time sample.

    Parameters
    ----------
    n_in, n_out : feature and output sizes; hidden : widths (``[128] * 4`` or ``"4x128"``).
    activation : "tanh" (default, as seed 003), "relu", "gelu", "silu" or "elu".
    zero_last : initialise the output layer's weights and bias to zero.
    """

    def __init__(self, n_in: int, n_out: int = 1, hidden: Sequence[int] | str = "4x128", activation: str = "tanh",
                 zero_last: bool = True):
        super().__init__()
        widths = [int(n_in), *parse_hidden(hidden)]
        layers: list[nn.Module] = []
        for a, b in zip(widths[:-1], widths[1:]):
            layers += [nn.Linear(a, b), _activation(activation)]
        self.body = nn.Sequential(*layers)
        self.head = nn.Linear(widths[-1], int(n_out))
        self.hidden = widths[1:]
        self.activation = activation
        if zero_last:
            nn.init.zeros_(self.head.weight)
            nn.init.zeros_(self.head.bias)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.head(self.body(features))

    def layers(self) -> list[nn.Linear]:
        """The linear layers in order (an activation follows each but the last)."""
        return [m for m in self.body if isinstance(m, nn.Linear)] + [self.head]


class LSTMNet(nn.Module):
    """Stacked LSTM over the time axis followed by a linear head (zero-initialised if ``zero_last``).

    ``hidden`` gives the layers and their common width (``"2x64"`` or ``[64, 64]``; widths must match).
    """

    def __init__(self, n_in: int, n_out: int = 1, hidden: Sequence[int] | str = "2x64", zero_last: bool = True):
        super().__init__()
        widths = parse_hidden(hidden)
        if len(set(widths)) != 1:
            raise ValueError(f"LSTM layers share one width; got {widths}")
        self.hidden = widths
        self.lstm = nn.LSTM(int(n_in), widths[0], num_layers=len(widths), batch_first=True)
        self.head = nn.Linear(widths[0], int(n_out))
        if zero_last:
            nn.init.zeros_(self.head.weight)
            nn.init.zeros_(self.head.bias)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        out, _ = self.lstm(features)
        return self.head(out)


def build_net(kind: str, n_in: int, n_out: int = 1, hidden="4x128", activation: str = "tanh",
              zero_last: bool = True) -> nn.Module:
    """``"mlp"`` or ``"lstm"`` block (see ``MLP`` and ``LSTMNet``)."""
    if kind == "mlp":
        return MLP(n_in, n_out, hidden, activation, zero_last)
    if kind == "lstm":
        return LSTMNet(n_in, n_out, hidden, zero_last)
    raise ValueError(f"unknown network kind {kind!r}; choose 'mlp' or 'lstm'")


def count_parameters(module: nn.Module) -> int:
    """Trainable parameters of ``module``."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad)
