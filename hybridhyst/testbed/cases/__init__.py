"""The cases of the independent discovery test bed: data from ``generators`` (no library physics), the
nominal a user would declare (a library model, the base law without the extra effect, constant
parameters, round starting values: never the truth), the split and what the loop should name.

Every case is a ``Case``; ``CASES`` lists them, ``CASE_BY_NAME`` finds one. Categories:

* ``single``: one library effect family missing from the nominal (each family at least once);
* ``pair``: two missing;
* ``condition``: seed 000's VPPTD law M = c φ̇ + k φ + k₂ φ³ + M_s sgn φ̇ (φ in deg, φ̇ in rad/s, M in Nm)
  with parameters rising with the underpressure (linearly or exponentially) plus one missing effect (in one
  case with a level that rises with the underpressure too); the nominal is ``vpptd_algebraic`` with constant
  parameters; a friction damper whose missing clearance has a level that rises with a coil current; and two
  cases whose condition varies in time within each record, a control channel (``Record.controls``): an MR damper
  whose coil voltage (a random staircase) reaches its damping and hysteretic force through a first-order lag
  (missing: ``control_lag``; the parameters' dependence on the voltage is found as trends), and a friction
  damper whose level follows an underpressure ramp (missing: the viscous term; the level's dependence on the
  pressure a trend). Their records carry a categorical condition (``set``) to split on, so that no numeric
  condition is offered as a trend;
* ``clean``: the nominal is the truth's structure: nothing may be added;
* ``out_of_library``: an effect the library does not have (cogging, friction whose level varies with
  position): nothing may be named, and the loop should flag structure it cannot name.

Aliases (an expected family with more than one acceptable library name), kept to exact special cases:

* Coulomb friction: ``coulomb`` or ``asymmetric_coulomb`` (asymmetric Coulomb with dF = 0 is Coulomb);
* Dahl friction: ``dahl`` or ``lugre`` (LuGre with Fs = Fc and σ1 = σ2 = 0 is Dahl).

A key parameter missing under its own name is looked up under the alias with the same parameter name
(``asymmetric_coulomb.Fc`` is the mean sliding level, as ``coulomb.Fc``; ``lugre.Fc`` the sliding level, as
``dahl.Fc``).

Layout: ``case`` (the ``Case`` record, ``CATEGORIES``, ``ALIASES``, units), ``assembly`` (records from a law, the
nominal builders, the standard test matrices, ``maxwell_records``), ``special_records`` (multisine, current-sweep and
control-channel records) and ``catalogue`` (the case list). Every public name is importable from ``cases`` itself.
"""

from .assembly import FREQ_SPLIT as FREQ_SPLIT
from .assembly import FREQS as FREQS
from .assembly import OSC as OSC
from .assembly import OSC_SPLIT as OSC_SPLIT
from .assembly import SLOW as SLOW
from .assembly import SMALL as SMALL
from .assembly import SMALL_SPLIT as SMALL_SPLIT
from .assembly import STD as STD
from .assembly import STD_SPLIT as STD_SPLIT
from .assembly import maxwell_records
from .case import ALIASES, CATEGORIES, Case
from .case import COULOMB as COULOMB
from .case import DAHL as DAHL
from .case import DAMPER_UNITS as DAMPER_UNITS
from .case import MM_UNITS as MM_UNITS
from .case import OSC_UNITS as OSC_UNITS
from .catalogue import CASE_BY_NAME, CASES, FAST_CASES
from .special_records import CONTROL_SETS as CONTROL_SETS
from .special_records import CONTROL_SPLIT as CONTROL_SPLIT
from .special_records import MR_ETA as MR_ETA
from .special_records import MR_NOISE as MR_NOISE
from .special_records import RAMP_NOISE as RAMP_NOISE
from .special_records import RAMP_TESTS as RAMP_TESTS

__all__ = ["CASES", "CASE_BY_NAME", "CATEGORIES", "FAST_CASES", "Case", "ALIASES", "maxwell_records"]
