"""The effect library: one effect per file; ``EFFECTS`` maps config names to classes.

Adding an effect = writing one file with an ``Effect`` subclass and listing it here.
"""

from .base import Effect as Effect
from .base import Kinematics as Kinematics
from .bouc_wen import BoucWenHysteresis as BoucWenHysteresis
from .coulomb import Coulomb as Coulomb
from .linear_stiffness import LinearStiffness as LinearStiffness
from .viscous import Viscous as Viscous

EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        Viscous,
        Coulomb,
        LinearStiffness,
        BoucWenHysteresis,
    )
}

__all__ = ["EFFECTS", "BoucWenHysteresis", "Coulomb", "Effect", "Kinematics", "LinearStiffness", "Viscous"]
