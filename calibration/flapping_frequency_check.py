"""Cross-check of the flapping frequency from the Hall sensor against the motor speed.

The DelFly's gearbox turns the crank once per 21.33 motor revolutions, so the flapping frequency
implied by the motor is ``motor_rpm / 60 / 21.33``. The Hall sensor on the crank gives the
flapping frequency directly (its edge detection belongs to balance processing). Disagreement
beyond a tolerance (2 % by default) flags a slipping gear, a missed Hall edge or a wrong rpm
channel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.vehicle.constants import DELFLY_GEAR_RATIO

DEFAULT_RELATIVE_TOLERANCE = 0.02


def flapping_frequency_hz_from_motor_rpm(
    motor_rpm: float | np.ndarray, gear_ratio: float = DELFLY_GEAR_RATIO
) -> float | np.ndarray:
    """Return the flapping frequency (Hz) implied by the motor speed ``motor_rpm`` (rev/min)."""
    return np.asarray(motor_rpm, dtype=float) / 60.0 / gear_ratio


@dataclass(frozen=True, eq=False)
class FlappingFrequencyCheck:
    """Result of comparing the Hall-derived and motor-derived flapping frequencies.

    Attributes
    ----------
    hall_frequency_hz, motor_frequency_hz : float or numpy.ndarray
        The two frequency estimates, Hz.
    relative_disagreement : float or numpy.ndarray
        ``(hall - motor) / motor``; 0 when both are 0, infinite when only the motor reads 0.
    disagrees : bool or numpy.ndarray
        True where ``|relative_disagreement| > tolerance``.
    tolerance : float
        The relative tolerance used.
    """

    hall_frequency_hz: float | np.ndarray
    motor_frequency_hz: float | np.ndarray
    relative_disagreement: float | np.ndarray
    disagrees: bool | np.ndarray
    tolerance: float


def check_flapping_frequency(
    hall_frequency_hz: float | np.ndarray,
    motor_rpm: float | np.ndarray,
    tolerance: float = DEFAULT_RELATIVE_TOLERANCE,
    gear_ratio: float = DELFLY_GEAR_RATIO,
) -> FlappingFrequencyCheck:
    """Compare the Hall-derived flapping frequency with ``motor_rpm / 60 / gear_ratio``.

    Works element-wise on arrays (one value per cycle or per set point).
    """
    hall, motor = np.broadcast_arrays(
        np.asarray(hall_frequency_hz, dtype=float),
        np.asarray(flapping_frequency_hz_from_motor_rpm(motor_rpm, gear_ratio)),
    )
    difference = hall - motor
    relative = np.divide(
        difference,
        motor,
        out=np.where(difference == 0.0, 0.0, np.inf),
        where=motor != 0.0,
    )
    disagrees = np.abs(relative) > tolerance

    def plain(array: np.ndarray):
        return array.item() if array.ndim == 0 else array

    return FlappingFrequencyCheck(
        plain(hall), plain(motor), plain(relative), plain(disagrees), tolerance
    )
