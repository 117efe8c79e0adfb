"""Thermocouple amplifier output voltage to temperature (AD8495-type, K-type thermocouple).

The AD8495 produces 5 mV per degree Celsius of measuring-junction temperature (cold-junction
compensated). Wired with its reference pin at 1.25 V, so that temperatures below 0 degC stay
positive, the output is ``V = 1.25 V + 5 mV/degC * T``, hence::

    T = (V - 1.25 V) / (5 mV/degC)

Example: 1.375 V -> (1.375 - 1.25) / 0.005 = 25 degC = 298.15 K. The offset and gain are
parameters for amplifiers wired differently (reference pin at 0 V: ``offset_v=0``). The linear
law is the amplifier's own nominal transfer function; its deviation from the thermocouple's
true curve (a few tenths of a degree near room temperature) is not corrected.
"""

from __future__ import annotations

import numpy as np

from ornitail.core.errors import require_finite

AD8495_OFFSET_V = 1.25
AD8495_GAIN_V_PER_K = 0.005
CELSIUS_TO_KELVIN_OFFSET = 273.15


def temperature_k_from_amplifier_voltage(
    voltage_v: float | np.ndarray,
    offset_v: float = AD8495_OFFSET_V,
    gain_v_per_k: float = AD8495_GAIN_V_PER_K,
) -> float | np.ndarray:
    """Return the measuring-junction temperature in kelvin for amplifier output ``voltage_v``.

    ``gain_v_per_k`` is the amplifier's sensitivity (V per kelvin, equal to V per degC) and
    ``offset_v`` its output at 0 degC. NaN or infinite voltages raise ``UserInputError``.
    """
    voltages = np.asarray(voltage_v, dtype=float)
    require_finite("thermocouple amplifier voltage", voltages.ravel().tolist())
    temperature_k = (voltages - offset_v) / gain_v_per_k + CELSIUS_TO_KELVIN_OFFSET
    return float(temperature_k) if temperature_k.ndim == 0 else temperature_k
