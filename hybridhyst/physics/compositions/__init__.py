"""The seeds' models as named compositions of effects (each has a config file in ``conf/model/``).

| name | structure | source |
|---|---|---|
| ``vpptd_algebraic`` | Constitutive: c φ̇ + k φ + k₂ φ³ + M_s sgn φ̇ (φ̇ in rad/s) | seed 000 |
| ``modified_bouc_wen`` | Constitutive: viscous + Bouc–Wen (cubic term) + Coulomb, Table 1 functions of p | seed 001 |
| ``vpptd_rig`` | DrivenOscillator, base excitation, I = 0.51: the two-mass rig of Fig. 4 | seed 001 |
| ``bouc_wen_p`` | Constitutive with unit inertia, exponential functions of p | seed 002 |
| ``bouc_wen_classic`` | Constitutive: m ẍ + c ẋ + a k x + (1 − a) k z | seed 004 |
| ``piezo_attenuation`` | DrivenOscillator, voltage drive, attenuation + input-driven Bouc–Wen | seed 003 |
| ``dahl_friction``, ``lugre_friction`` | Constitutive friction laws | Dahl 1968; Canudas de Wit 1995 |
| ``boucwen_benchmark`` | DrivenOscillator of Noël & Schoukens (2016) | benchmark |
"""

from .benchmark import boucwen_benchmark as boucwen_benchmark
from .friction import dahl_friction as dahl_friction
from .friction import lugre_friction as lugre_friction
from .seed000 import SEED000_QUOTED as SEED000_QUOTED
from .seed000 import vpptd_algebraic as vpptd_algebraic
from .seed001 import MIXTURES as MIXTURES
from .seed001 import TABLE1 as TABLE1
from .seed001 import TABLE2_HZ as TABLE2_HZ
from .seed001 import modified_bouc_wen as modified_bouc_wen
from .seed001 import vpptd_rig as vpptd_rig
from .seed002 import bouc_wen_p as bouc_wen_p
from .seed003 import piezo_attenuation as piezo_attenuation
from .seed004 import bouc_wen_classic as bouc_wen_classic

COMPOSITIONS = {
    "vpptd_algebraic": vpptd_algebraic,
    "modified_bouc_wen": modified_bouc_wen,
    "vpptd_rig": vpptd_rig,
    "bouc_wen_p": bouc_wen_p,
    "bouc_wen_classic": bouc_wen_classic,
    "piezo_attenuation": piezo_attenuation,
    "dahl_friction": dahl_friction,
    "lugre_friction": lugre_friction,
    "boucwen_benchmark": boucwen_benchmark,
}

__all__ = [
    "COMPOSITIONS", "MIXTURES", "SEED000_QUOTED", "TABLE1", "TABLE2_HZ", "bouc_wen_classic", "bouc_wen_p",
    "boucwen_benchmark", "dahl_friction", "lugre_friction", "modified_bouc_wen",
    "piezo_attenuation", "vpptd_algebraic", "vpptd_rig",
]
