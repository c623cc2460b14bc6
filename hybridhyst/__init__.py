"""hybridhyst: hybrid physics–neural modelling of hysteresis in smart dampers and actuators.

The public surface: data records and readers, the nominal-model structures and
builder, and the one simulator. Everything else is reached through its subpackage.
"""

from .data import Record as Record
from .data import RecordSet as RecordSet
from .data import load_builtin as load_builtin
from .data import read_table as read_table
from .physics import Constitutive as Constitutive
from .physics import DrivenOscillator as DrivenOscillator
from .physics import build_model as build_model
from .simulate import simulate as simulate
from .synth import load_vpptd as load_vpptd  # also registers the built-in dataset "vpptd"

__version__ = "0.1.0"

__all__ = [
    "Constitutive",
    "DrivenOscillator",
    "Record",
    "RecordSet",
    "build_model",
    "load_builtin",
    "load_vpptd",
    "read_table",
    "simulate",
]
