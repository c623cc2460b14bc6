"""Physics of the discovery test bed, written independently of the library (numpy and scipy only).

Nothing here imports ``hybridhyst``: the laws are re-derived from their textbook statements and computed
with numerics the library does not use, so that the discovery loop is judged on data it did not make:

* input signals are analytic (sums of sines with an optional smooth fade-in; x, ẋ, ẍ in closed form)
  and held at rest before t = 0;
* sign functions are exact (``np.sign``) or smoothed by arctan, erf or v/√(v² + δ²), never tanh;
* the play operator is the exact discrete one, y_k = clamp(y_{k-1}, x_k − r, x_k + r), on an input
  refined many times between samples;
* Dahl friction is integrated exactly in displacement (it is rate-independent: piecewise exponential),
  also behind a clearance (a gap in series: the increment split where the gap opens or closes), and so is
  Bouc–Wen with n = 2 (piecewise tanh / tan, split where the state crosses 0);
* control channels (a coil voltage, an underpressure schedule) are ``Schedule`` signals, exactly linear between
  their breakpoints (slewed staircases, ramps); a first-order lag of one is ``linear_lag`` (exact for them);
* Maxwell elements and other linear lags use an exact exponential integrator (first-order hold);
* other states (LuGre, Bouc–Wen, oscillators) use ``scipy.integrate.solve_ivp`` (LSODA, Radau or
  DOP853 with tight tolerances and a step limit of a tenth of the sample interval), or ``heun``, a
  fixed-step second-order scheme on a grid refined between the samples;
* noise is white or AR(1) (coloured) with a stated marginal standard deviation.

Units are whatever the caller uses consistently; every law returns arrays of the shape of its inputs.

Layout: ``signals`` (``Sines``, ``Schedule`` and their makers, ``fine_grid``), ``static_laws`` (signs, the Stribeck
curve, cogging), ``path_operators`` (play, Dahl, Bouc-Wen n = 2, clearance, travel, exact lags), ``odes``
(``integrate``, ``heun`` and the laws solved with them) and ``noise``; every name is importable from ``generators``.
"""

from __future__ import annotations

from .noise import ar1_noise, white_noise
from .odes import bouc_wen_yield, heun, integrate, lugre, mr_damper, oscillator
from .path_operators import (
    bouc_wen_n2,
    clearance_dahl,
    cumulative_travel,
    dahl_exact,
    kelvin_behind_play,
    linear_lag,
    maxwell_force,
    play,
    play_rate,
)
from .signals import Schedule, Sines, fine_grid, multisine, ramp, random_motion, sine, staircase
from .static_laws import cogging, sgn, stribeck_curve

__all__ = [
    "Schedule", "Sines", "ar1_noise", "bouc_wen_n2", "bouc_wen_yield", "clearance_dahl", "cogging",
    "cumulative_travel", "dahl_exact", "fine_grid", "heun", "integrate", "kelvin_behind_play", "linear_lag", "lugre",
    "maxwell_force", "mr_damper", "multisine", "oscillator", "play", "play_rate", "ramp", "random_motion", "sgn",
    "sine", "staircase", "stribeck_curve", "white_noise",
]
