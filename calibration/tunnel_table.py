"""Wind-tunnel fan speed to flow velocity table, with its inverse for set points.

CSV columns ``fan_rpm,velocity_m_s`` (fan shaft speed in rev/min, mean jet velocity in m/s),
``#`` comment lines allowed. Both columns must be strictly increasing down the table, so that
the inverse (velocity to rpm) is unique. Values between rows are interpolated linearly; values
outside the table are refused rather than extrapolated.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.calibration.numeric_csv import read_numeric_csv_columns
from ornitail.core.errors import UserInputError, require_finite
from ornitail.core.hashing import content_hash_of_bytes

TUNNEL_TABLE_COLUMNS = ("fan_rpm", "velocity_m_s")


@dataclass(frozen=True, eq=False)
class TunnelVelocityTable:
    """Fan rpm to velocity table.

    Attributes
    ----------
    fan_rpm : numpy.ndarray
        Fan speeds, rev/min, strictly increasing.
    velocity_m_s : numpy.ndarray
        Jet velocities at those speeds, m/s, strictly increasing.
    content_hash : str
        ``"sha256:<hex>"`` of the table file.
    path : pathlib.Path | None
        The file read, if any.
    """

    fan_rpm: np.ndarray
    velocity_m_s: np.ndarray
    content_hash: str
    path: Path | None = None

    @classmethod
    def from_csv(cls, path: str | Path) -> TunnelVelocityTable:
        """Read and check a ``fan_rpm,velocity_m_s`` CSV table."""
        path = Path(path)
        columns, line_numbers, data = read_numeric_csv_columns(
            path, TUNNEL_TABLE_COLUMNS, minimum_rows=2
        )
        for name in TUNNEL_TABLE_COLUMNS:
            steps = np.diff(columns[name])
            not_increasing = np.flatnonzero(steps <= 0.0)
            if not_increasing.size:
                row = not_increasing[0] + 1
                raise UserInputError(
                    f"{path}: line {line_numbers[row]}, column {name}",
                    f"{columns[name][row]:g} does not increase on the previous row "
                    f"({columns[name][row - 1]:g}); the table must be strictly increasing",
                )
        return cls(columns["fan_rpm"], columns["velocity_m_s"], content_hash_of_bytes(data), path)

    def _interpolate(
        self, value: float | np.ndarray, known: np.ndarray, wanted: np.ndarray, name: str
    ) -> float | np.ndarray:
        values = np.asarray(value, dtype=float)
        require_finite(name, values.ravel().tolist())
        outside = values[(values < known[0]) | (values > known[-1])]
        if outside.size:
            raise UserInputError(
                name,
                f"{outside.flat[0]:g} is outside the tunnel table's range "
                f"{known[0]:g} to {known[-1]:g} (table {self.path}); no extrapolation",
            )
        result = np.interp(values, known, wanted)
        return float(result) if result.ndim == 0 else result

    def velocity_m_s_at_rpm(self, fan_rpm: float | np.ndarray) -> float | np.ndarray:
        """Return the jet velocity (m/s) at fan speed(s) ``fan_rpm`` (rev/min)."""
        return self._interpolate(fan_rpm, self.fan_rpm, self.velocity_m_s, "fan_rpm")

    def rpm_for_velocity(self, velocity_m_s: float | np.ndarray) -> float | np.ndarray:
        """Return the fan speed (rev/min) that gives jet velocity ``velocity_m_s`` (m/s)."""
        return self._interpolate(velocity_m_s, self.velocity_m_s, self.fan_rpm, "velocity_m_s")
