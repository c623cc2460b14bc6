"""Symbolic twins of the effects' elementary functions (sympy), for the compiled fast path.

Effects are written once against the functions in ``effects.base`` (``tanh``, ``exp``, ``absolute``,
``sign``, ``abs_pow`` …). Called with torch tensors they compute the reference; called with sympy
expressions they build the equations that ``hybridhyst.simulate.fast`` differentiates symbolically and
compiles. The non-smooth functions below carry the same derivative conventions as the torch reference:
d|x|/dx = sign(x), d sign(x)/dx = 0, and |z|^n with derivatives 0 at z = 0.
"""

from __future__ import annotations

import sympy as sp

ZERO = sp.S.Zero


class Sign(sp.Function):
    """sign(x) with derivative 0 (as torch.sign)."""

    def fdiff(self, argindex=1):
        return sp.S.Zero


class Step(sp.Function):
    """The unit step, 1 for x ≥ 0 and 0 for x < 0, with derivative 0 (as the torch reference)."""

    def fdiff(self, argindex=1):
        return sp.S.Zero


class Absolute(sp.Function):
    """|x| with derivative sign(x) (as torch.abs)."""

    def fdiff(self, argindex=1):
        return Sign(self.args[0])


class AbsPowLog(sp.Function):
    """|z|^n · log|z| (0 at z = 0): the derivative of |z|^n with respect to n."""

    def fdiff(self, argindex=1):  # second derivatives are never needed by first-order sensitivities
        raise NotImplementedError("AbsPowLog has no derivative in hybridhyst")


class AbsPow(sp.Function):
    """|z|^n, 0 at z = 0, with d/dz = n |z|^(n−1) sign(z) and d/dn = |z|^n log|z|."""

    def fdiff(self, argindex=1):
        z, n = self.args
        if argindex == 1:
            return n * AbsPow(z, n - 1) * Sign(z)
        return AbsPowLog(z, n)


class Tanh(sp.tanh):
    """tanh of a real argument, real by declaration. sympy's own ``tanh`` asks, whenever a product or a derivative
    needs to know whether it is real, whether the imaginary part of its argument is a multiple of π/2; on the long
    arguments of composed effects (a friction term's velocity behind a play) that runs polynomial gcds for tens of
    seconds per model. Every quantity in the equations is real: the answer is yes."""

    def _eval_is_real(self):
        return True

    def _eval_is_extended_real(self):
        return True

    def fdiff(self, argindex=1):
        return 1 - Tanh(self.args[0]) ** 2


def is_symbolic(x) -> bool:
    return isinstance(x, sp.Basic)


def tanh(x):
    return Tanh(x)


def exp(x):
    return sp.exp(x)


def sigmoid(x):
    return 1 / (1 + sp.exp(-x))


def absolute(x):
    return Absolute(x)


def step(x):
    return Step(x)


def sign(x):
    return Sign(x)


def abs_pow(z, n):
    return AbsPow(z, n)


class SymbolicState:
    """Stands in for a ``(batch, state_dim)`` tensor: ``state[:, i]`` is the i-th symbol."""

    def __init__(self, symbols):
        self.symbols = list(symbols)

    def __getitem__(self, index):
        _, i = index
        if isinstance(i, slice):  # state[:, lo:hi]: an effect's own states
            return SymbolicState(self.symbols[i])
        return self.symbols[i]

    @property
    def shape(self):
        return (1, len(self.symbols))
