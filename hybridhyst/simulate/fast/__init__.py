"""Compiled fast path of ``simulate``: C loops generated from the effects' own equations.

``simulate(..., backend="fast")`` runs here: the model's equations are built by calling its own ``derivative``
and ``output`` on sympy symbols (``equations``), differentiated symbolically and written as C (``codegen``), built
with the system C compiler and loaded (``build``) into a forward loop and its exact discrete adjoint, wrapped as
a ``torch.autograd.Function`` (``function``). Values and gradients equal the reference loop's (tests assert
1e-8 relative in float64). ``tangent_fast`` runs the same map's forward sensitivities
w.r.t. every parameter and network weight in one pass (``simulate.simulate_jacobian``: Jacobians for least squares,
in identification and in training's Levenberg–Marquardt stage).
"""

from .function import prebuild_models as prebuild_models
from .function import simulate_fast as simulate_fast

__all__ = ["prebuild_models", "simulate_fast"]
