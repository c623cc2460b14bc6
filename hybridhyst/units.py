"""Known unit strings, the quantity each measures, and their validation (a misspelt unit is an error that names
the closest one). Below every layer: data reads with it, reports label axes with it."""

from __future__ import annotations

import difflib
from collections.abc import Mapping

__all__ = ["KNOWN_UNITS", "UNIT_QUANTITY", "check_units"]

# every known unit and the quantity it measures (axis labels say "force y [kip]"); None: no single quantity
UNIT_QUANTITY: dict[str, str | None] = {
    **dict.fromkeys(("s", "ms", "us", "min", "h"), "time"),
    **dict.fromkeys(("Hz", "kHz"), "frequency"),
    **dict.fromkeys(("m", "cm", "mm", "um", "nm", "in", "ft"), "displacement"),
    **dict.fromkeys(("deg", "rad", "rev"), "angle"),
    **dict.fromkeys(("N", "kN", "MN", "kip", "lb", "lbf"), "force"),
    **dict.fromkeys(("Nm", "N*m", "kNm", "kN*m", "Nmm", "N*mm", "lb*in", "kip*in"), "torque"),
    **dict.fromkeys(("m/s", "mm/s", "um/s", "in/s", "ft/s"), "velocity"),
    **dict.fromkeys(("deg/s", "rad/s", "rpm"), "angular velocity"),
    **dict.fromkeys(("m/s^2", "mm/s^2", "in/s^2", "g"), "acceleration"),
    **dict.fromkeys(("deg/s^2", "rad/s^2"), "angular acceleration"),
    **dict.fromkeys(("V", "mV", "kV"), "voltage"),
    **dict.fromkeys(("A", "mA"), "current"),
    "Ohm": "resistance", "W": "power",
    **dict.fromkeys(("T", "mT"), "flux density"),
    **dict.fromkeys(("Pa", "kPa", "MPa", "GPa", "bar", "mbar", "psi", "ksi"), "pressure"),
    **dict.fromkeys(("K", "degC"), "temperature"),
    **dict.fromkeys(("J", "kJ"), "energy"),
    **dict.fromkeys(("%", "1", "-"), None),
}
KNOWN_UNITS: frozenset[str] = frozenset(UNIT_QUANTITY)


def check_units(units: dict[str, str] | None, where: str, channels: dict[str, str] | None = None) -> dict[str, str]:
    """Validate a ``{channel: unit}`` mapping against ``KNOWN_UNITS``.

    Parameters
    ----------
    units : mapping from channel name ("t", "x", "y" or an extra channel) to a unit string.
    where : what is being read (e.g. ``"file 'loops.csv'"``), used in error messages.
    channels : ``{channel: description}`` of the channels that exist; a unit for any other name is an
        error. ``None`` accepts any channel name.

    Returns
    -------
    A plain ``dict`` copy of ``units``.

    Raises
    ------
    ValueError
        For a unit not in ``KNOWN_UNITS`` (naming the closest known unit) or a unit given for a
        channel that does not exist.
    """
    if units is not None and not isinstance(units, Mapping):
        raise ValueError(f"{where}: units must be a mapping {{channel: unit}}, e.g. 'data.units={{t: s, x: mm, y: N}}' "
                         f"(quoted on the command line, so the shell keeps the braces); got {units!r}")
    out = dict(units or {})
    for channel, unit in out.items():
        if channels is not None and channel not in channels:
            known = ", ".join(f"{k!r} ({v})" for k, v in channels.items())
            raise ValueError(f"{where}: unit given for unknown channel {channel!r}; units are keyed by channel: "
                             f"{known}")
        if not isinstance(unit, str) or unit not in KNOWN_UNITS:
            raise ValueError(f"{where}: unknown unit {unit!r} for channel {channel!r}; {_suggest(unit)}")
    return out


def _suggest(unit) -> str:
    text = str(unit)
    by_lower = {u.lower(): u for u in KNOWN_UNITS}
    close = [by_lower[text.lower()]] if text.lower() in by_lower else []
    close = close or difflib.get_close_matches(text, sorted(KNOWN_UNITS), n=1, cutoff=0.3)
    hint = f"did you mean {close[0]!r}? " if close else ""
    return hint + f"known units: {', '.join(sorted(KNOWN_UNITS, key=str.lower))}"
