"""Hot-wire calibration points and the anemometer's temperature correction.

Points CSV (``#`` comment lines allowed, extra columns ignored)::

    velocity_m_s,voltage_v,temperature_c
    0.20,1.4523,20.1

``velocity_m_s`` is the reference flow velocity (m/s, >= 0), ``voltage_v`` the anemometer bridge
voltage E (V, > 0), ``temperature_c`` the flow temperature during that point (degC). Inside,
temperatures are kelvin.

Temperature correction (constant-temperature anemometer, wire at ``T_w``)::

    E_corr = E * sqrt((T_w - T_ref) / (T_w - T_flow))

turns a voltage read at flow temperature ``T_flow`` into the voltage the same velocity would give
at the law's reference temperature ``T_ref``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.calibration.numeric_csv import read_numeric_csv_columns
from ornitail.calibration.thermocouple_amplifier import CELSIUS_TO_KELVIN_OFFSET
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_bytes

HOTWIRE_POINT_COLUMNS = ("velocity_m_s", "voltage_v", "temperature_c")
MINIMUM_HOTWIRE_POINTS = 4


@dataclass(frozen=True, eq=False)
class HotwireCalibrationPoints:
    """Calibration points of a hot-wire probe (SI: m/s, V, K)."""

    velocity_m_s: np.ndarray
    voltage_v: np.ndarray
    temperature_k: np.ndarray
    content_hash: str
    path: Path | None = None


MAX_HOTWIRE_VELOCITY_M_S = 300.0
"""Fastest calibration velocity accepted, m/s (hot-wire laws hold for subsonic flow)."""


def read_hotwire_points(path: str | Path) -> HotwireCalibrationPoints:
    """Read a ``velocity_m_s,voltage_v,temperature_c`` CSV file of calibration points."""
    path = Path(path)
    columns, line_numbers, data = read_numeric_csv_columns(
        path, HOTWIRE_POINT_COLUMNS, minimum_rows=MINIMUM_HOTWIRE_POINTS
    )
    checks = (
        ("velocity_m_s", columns["velocity_m_s"] < 0.0, "velocity must not be negative"),
        (
            "velocity_m_s",
            columns["velocity_m_s"] > MAX_HOTWIRE_VELOCITY_M_S,
            f"velocity must be at most {MAX_HOTWIRE_VELOCITY_M_S:g} m/s (a subsonic hot wire)",
        ),
        ("voltage_v", columns["voltage_v"] <= 0.0, "bridge voltage must be positive"),
        (
            "temperature_c",
            columns["temperature_c"] <= -CELSIUS_TO_KELVIN_OFFSET,
            "temperature must be above absolute zero",
        ),
    )
    for name, bad, problem in checks:
        if np.any(bad):
            row = int(np.flatnonzero(bad)[0])
            raise UserInputError(
                f"{path}: line {line_numbers[row]}, column {name}",
                f"{problem} (got {columns[name][row]:g})",
            )
    return HotwireCalibrationPoints(
        velocity_m_s=columns["velocity_m_s"],
        voltage_v=columns["voltage_v"],
        temperature_k=columns["temperature_c"] + CELSIUS_TO_KELVIN_OFFSET,
        content_hash=content_hash_of_bytes(data),
        path=path,
    )


def temperature_corrected_voltage(
    voltage_v: float | np.ndarray,
    flow_temperature_k: float | np.ndarray,
    reference_temperature_k: float,
    wire_temperature_k: float,
) -> np.ndarray:
    """Return ``E * sqrt((T_w - T_ref) / (T_w - T_flow))`` (V), temperatures in kelvin.

    The wire must be hotter than both the reference and the flow temperature.
    """
    flow_temperature_k = np.asarray(flow_temperature_k, dtype=float)
    if np.any(flow_temperature_k >= wire_temperature_k) or (
        reference_temperature_k >= wire_temperature_k
    ):
        raise UserInputError(
            "wire temperature",
            f"wire ({wire_temperature_k:.2f} K) must be hotter than the flow "
            f"(up to {np.max(flow_temperature_k):.2f} K) and the reference "
            f"({reference_temperature_k:.2f} K)",
        )
    ratio = (wire_temperature_k - reference_temperature_k) / (
        wire_temperature_k - flow_temperature_k
    )
    return np.asarray(voltage_v, dtype=float) * np.sqrt(ratio)
