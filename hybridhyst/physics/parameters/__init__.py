"""Constrained physical parameters and parameter functions of an operating condition.

A physical parameter is stored unconstrained and mapped to its admissible range by a
``torch.nn.utils.parametrize`` parametrization (``Positive``: softplus, ``Bounded``: scaled sigmoid),
never by clamping, so gradients survive at the bounds.

A *parameter function* maps an operating condition (e.g. underpressure p [MPa]) to a parameter value.
Every effect parameter is one of these modules; ``Constant`` is the usual case. Functions follow the
seeds: linear and polynomial in p (seed 001 Table 1), exponential rise-to-maximum / decay / growth
(seed 002 eqs. 7-12), one value per condition level, and a small neural network.
"""

from .base import FunctionCoordinate as FunctionCoordinate
from .base import ParameterFunction as ParameterFunction
from .constraints import Bounded as Bounded
from .constraints import ParameterSpec as ParameterSpec
from .constraints import Positive as Positive
from .constraints import render_unit as render_unit
from .functions import _FUNCTIONS as _FUNCTIONS  # noqa: F401 (the registered kinds, for tests)
from .functions import Constant as Constant
from .functions import ExpDecay as ExpDecay
from .functions import ExpGrowth as ExpGrowth
from .functions import ExpRise as ExpRise
from .functions import Fixed as Fixed
from .functions import Linear as Linear
from .functions import NeuralFunction as NeuralFunction
from .functions import PerCondition as PerCondition
from .functions import Polynomial as Polynomial
from .functions import build_function as build_function
from .functions import project_to_bounds as project_to_bounds

__all__ = [
    "Bounded",
    "Constant",
    "ExpDecay",
    "ExpGrowth",
    "ExpRise",
    "Fixed",
    "FunctionCoordinate",
    "Linear",
    "NeuralFunction",
    "ParameterFunction",
    "ParameterSpec",
    "PerCondition",
    "Polynomial",
    "Positive",
    "build_function",
    "project_to_bounds",
    "render_unit",
]
