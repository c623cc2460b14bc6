"""Synthetic experiments: data made by simulating the seeds' models (may use ``physics`` and ``simulate``).

* ``load_vpptd``: torque–angle loops of seed 001's modified Bouc–Wen damper (Table 1), registered as the
  built-in dataset ``"vpptd"`` (``hybridhyst.data.load_builtin("vpptd", ...)``);
* ``seed001``: the rig of seed 001 run in free vibration and under an underpressure schedule, and the
  identifiable combinations of its damper law;
* ``effects``: records with one undeclared library effect, made by the library's own effects and simulator:
  quick unit tests of the discovery loop's mechanics (an "inverse crime", never evidence of discovery).

Data for testing identification and discovery is *not* made here: ``hybridhyst.testbed`` has generators
that share no code with the library's models or simulator.
"""

from ..data.builtin import register_builtin
from .seed001 import forced_response as forced_response
from .seed001 import free_vibration_frequencies as free_vibration_frequencies
from .seed001 import identifiable_combinations as identifiable_combinations
from .vpptd import MIXTURES as MIXTURES
from .vpptd import PRESSURES as PRESSURES
from .vpptd import load_vpptd as load_vpptd

register_builtin("vpptd", load_vpptd)

__all__ = ["MIXTURES", "PRESSURES", "forced_response", "free_vibration_frequencies", "identifiable_combinations",
           "load_vpptd"]
