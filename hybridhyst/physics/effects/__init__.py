"""The effect library: one effect per file; ``EFFECTS`` maps config names to classes.

Adding an effect = writing one file with an ``Effect`` subclass, importing it here and adding it to ``EFFECTS``
(docs/extending.md).
"""

from .asymmetric_coulomb import AsymmetricCoulomb as AsymmetricCoulomb
from .attenuation import Attenuation as Attenuation
from .backlash import Backlash as Backlash
from .base import Effect as Effect
from .base import Kinematics as Kinematics
from .bouc_wen import BoucWenHysteresis as BoucWenHysteresis
from .bouc_wen_p import BoucWenNormalised as BoucWenNormalised
from .clearance import Clearance as Clearance
from .control_lag import ControlLag as ControlLag
from .control_saturation import ControlSaturation as ControlSaturation
from .coulomb import Coulomb as Coulomb
from .cubic_stiffness import CubicStiffness as CubicStiffness
from .dahl import Dahl as Dahl
from .inertia import Inertia as Inertia
from .linear_stiffness import LinearStiffness as LinearStiffness
from .lugre import LuGre as LuGre
from .maxwell import Maxwell as Maxwell
from .neural import NeuralEffect as NeuralEffect
from .relaxing_backlash import RelaxingBacklash as RelaxingBacklash
from .spencer import SpencerMR as SpencerMR
from .stribeck import Stribeck as Stribeck
from .time_delay import TimeDelay as TimeDelay
from .travel_damping import TravelDamping as TravelDamping
from .travel_drift import TravelDrift as TravelDrift
from .travel_stiffness import TravelStiffness as TravelStiffness
from .viscous import Viscous as Viscous

EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        Viscous,
        Coulomb,
        AsymmetricCoulomb,
        Stribeck,
        LinearStiffness,
        CubicStiffness,
        BoucWenHysteresis,
        BoucWenNormalised,
        Dahl,
        LuGre,
        Maxwell,
        Backlash,
        RelaxingBacklash,
        Clearance,
        Inertia,
        Attenuation,
        TimeDelay,
        TravelDrift,
        TravelStiffness,
        TravelDamping,
        ControlLag,
        ControlSaturation,
        SpencerMR,
        NeuralEffect,
    )
}

# every effect class by its Python name, with the registry and the base classes
__all__ = ["EFFECTS", "Effect", "Kinematics", *sorted(cls.__name__ for cls in EFFECTS.values())]
