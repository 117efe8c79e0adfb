"""SI factors for the unit strings found in ATI calibration files.

ATI writes the calibration's units as strings in the ``Calibration`` element (``ForceUnits``,
``TorqueUnits``, ``DistUnits``). The strings below are those the ATI DAQ F/T C library accepts
(``ftconfig.c``: ``ForceConv``, ``TorqueConv``, ``DistConv``) plus the ``kgf`` spellings used in
ATI's manuals. Each maps to the factor that turns one of that unit into SI (N, N m, m). Unknown
strings are refused: silently treating ``"lbf-in"`` as ``"N-m"`` would scale every torque by 9.
"""

from __future__ import annotations

from ornitail.core.errors import UserInputError
from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

NEWTONS_PER_POUND_FORCE = 4.4482216152605
METRES_PER_INCH = 0.0254
NEWTON_METRES_PER_POUND_FORCE_INCH = NEWTONS_PER_POUND_FORCE * METRES_PER_INCH

NEWTONS_PER_FORCE_UNIT: dict[str, float] = {
    "N": 1.0,
    "kN": 1000.0,
    "lb": NEWTONS_PER_POUND_FORCE,
    "lbf": NEWTONS_PER_POUND_FORCE,
    "klb": 1000.0 * NEWTONS_PER_POUND_FORCE,
    "klbf": 1000.0 * NEWTONS_PER_POUND_FORCE,
    "g": 1e-3 * STANDARD_GRAVITY_M_S2,
    "gf": 1e-3 * STANDARD_GRAVITY_M_S2,
    "kg": STANDARD_GRAVITY_M_S2,
    "kgf": STANDARD_GRAVITY_M_S2,
}

NEWTON_METRES_PER_TORQUE_UNIT: dict[str, float] = {
    "N-m": 1.0,
    "Nm": 1.0,
    "N-mm": 1e-3,
    "Nmm": 1e-3,
    "kN-m": 1000.0,
    "kNm": 1000.0,
    "lbf-in": NEWTON_METRES_PER_POUND_FORCE_INCH,
    "lb-in": NEWTON_METRES_PER_POUND_FORCE_INCH,
    "in-lb": NEWTON_METRES_PER_POUND_FORCE_INCH,
    "in-lbf": NEWTON_METRES_PER_POUND_FORCE_INCH,
    "lbf-ft": 12.0 * NEWTON_METRES_PER_POUND_FORCE_INCH,
    "lb-ft": 12.0 * NEWTON_METRES_PER_POUND_FORCE_INCH,
    "ft-lb": 12.0 * NEWTON_METRES_PER_POUND_FORCE_INCH,
    "ft-lbf": 12.0 * NEWTON_METRES_PER_POUND_FORCE_INCH,
    "kg-cm": STANDARD_GRAVITY_M_S2 * 0.01,
    "kgcm": STANDARD_GRAVITY_M_S2 * 0.01,
    "kgf-cm": STANDARD_GRAVITY_M_S2 * 0.01,
}

METRES_PER_DISTANCE_UNIT: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "in": METRES_PER_INCH,
    "ft": 12.0 * METRES_PER_INCH,
}


def _factor(table: dict[str, float], unit: str, where: str, kind: str) -> float:
    try:
        return table[unit]
    except KeyError:
        known = ", ".join(sorted(table))
        raise UserInputError(where, f"unknown {kind} unit {unit!r} (known: {known})") from None


def newtons_per_force_unit(unit: str, where: str) -> float:
    """Return how many newtons one ``unit`` of force is; ``where`` names the field for errors."""
    return _factor(NEWTONS_PER_FORCE_UNIT, unit, where, "force")


def newton_metres_per_torque_unit(unit: str, where: str) -> float:
    """Return how many newton metres one ``unit`` of torque is; ``where`` names the field."""
    return _factor(NEWTON_METRES_PER_TORQUE_UNIT, unit, where, "torque")


def metres_per_distance_unit(unit: str, where: str) -> float:
    """Return how many metres one ``unit`` of distance is; ``where`` names the field."""
    return _factor(METRES_PER_DISTANCE_UNIT, unit, where, "distance")
