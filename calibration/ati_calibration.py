"""ATI six-axis force/torque calibration: raw gauge voltages in, SI forces and torques out.

The working matrix maps bias-corrected gauge voltages to ``[Fx, Fy, Fz, Tx, Ty, Tz]`` in N and
N m::

    wrench = M_tool @ M_sensor @ (volts - bias)

where ``M_sensor`` is the file's calibration matrix in SI (format 1.0: ``Axis`` rows divided by
their ``scale`` with the file's ``BasicTransform`` applied; format 1.1: the ``UserAxis`` rows,
which already include it) and ``M_tool`` is the 6x6 matrix of the user's tool transform
(:mod:`ornitail.calibration.tool_transform`). The bias is a vector of raw voltages read at no
load; keep raw voltages, the bias and the matrix, never only biased forces.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ornitail.calibration.ati_cal_file import AXIS_NAMES, AtiCalFileContents, read_ati_cal_file
from ornitail.calibration.ati_units import (
    metres_per_distance_unit,
    newton_metres_per_torque_unit,
    newtons_per_force_unit,
)
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_bytes

WRENCH_COMPONENT_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz")
WRENCH_COMPONENT_UNITS = ("N", "N", "N", "N m", "N m", "N m")
WRENCH_COMPONENT_KEYS = ("fx_n", "fy_n", "fz_n", "tx_n_m", "ty_n_m", "tz_n_m")
"""The components as keys of printed JSON, each carrying its unit."""


def _si_row_factors(contents: AtiCalFileContents, source: str) -> np.ndarray:
    newtons = newtons_per_force_unit(contents.force_units, f"{source}: ForceUnits")
    newton_metres = newton_metres_per_torque_unit(contents.torque_units, f"{source}: TorqueUnits")
    return np.array([newtons] * 3 + [newton_metres] * 3)


MAX_CONDITION_NUMBER = 1e12
"""A calibration matrix worse conditioned than this is refused as singular."""


def _check_invertible(matrix_si: np.ndarray, source: str) -> None:
    """Refuse a non-finite, all-zero or singular calibration matrix (it maps loads to nothing)."""
    if not np.all(np.isfinite(matrix_si)):
        raise UserInputError(
            source, "calibration matrix has values too large to use (not finite in SI units)"
        )
    if not np.any(matrix_si):
        raise UserInputError(source, "calibration matrix is all zeros (singular)")
    condition = np.linalg.cond(matrix_si)
    if not np.isfinite(condition) or condition > MAX_CONDITION_NUMBER:
        rank = int(np.linalg.matrix_rank(matrix_si))
        raise UserInputError(
            source,
            f"calibration matrix is singular or badly scaled (rank {rank} of 6, condition number "
            f"{condition:.3g}): "
            "some loads would give no gauge signal",
        )


def basic_matrix_with_basic_transform_si(contents: AtiCalFileContents, source: str) -> np.ndarray:
    """Return the ``Axis``/``scale`` matrix in SI with the file's ``BasicTransform`` applied."""
    basic_matrix_si = contents.axis_rows * _si_row_factors(contents, source)[:, None]
    metres = metres_per_distance_unit(contents.distance_units, f"{source}: DistUnits")
    basic_transform = ToolTransform.from_si(
        contents.basic_transform_distances * metres, contents.basic_transform_angles_rad
    )
    return basic_transform.wrench_matrix() @ basic_matrix_si


@dataclass(frozen=True, eq=False)
class AtiCalibration:
    """One ATI calibration, converted to SI, with an optional tool transform.

    Attributes
    ----------
    path : pathlib.Path
        The ``.cal`` file read.
    content_hash : str
        ``"sha256:<hex>"`` of the file's bytes (the tool transform is recorded separately).
    serial, body_style, family, part_number, calibration_date, file_format_version : str
        As written in the file.
    force_units, torque_units, distance_units : str
        The file's unit strings (the matrix below is already converted to SI).
    sensor_matrix_si : numpy.ndarray, shape (6, 6)
        Volts to ``[N, N, N, N m, N m, N m]`` in the calibration's own frame (BasicTransform
        applied, no tool transform).
    ranges_si : numpy.ndarray, shape (6,)
        Rated loads (``max``) of Fx..Tz in N and N m, in the calibration's own frame.
    tool_transform : ToolTransform
        The user's tool transform (identity unless set with :meth:`with_tool_transform`).
    matrix_si : numpy.ndarray, shape (6, 6)
        The working matrix: ``tool_transform.wrench_matrix() @ sensor_matrix_si``.
    """

    path: Path
    content_hash: str
    serial: str
    body_style: str
    family: str
    part_number: str
    calibration_date: str
    file_format_version: str
    force_units: str
    torque_units: str
    distance_units: str
    sensor_matrix_si: np.ndarray
    ranges_si: np.ndarray
    tool_transform: ToolTransform = field(default_factory=ToolTransform)
    matrix_si: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "matrix_si", self.tool_transform.wrench_matrix() @ self.sensor_matrix_si
        )

    @classmethod
    def from_file(cls, path: str | Path) -> AtiCalibration:
        """Read an ATI ``.cal`` file (format 1.0 or 1.1); bad files raise ``UserInputError``."""
        path = Path(path)
        contents, data = read_ati_cal_file(path)
        source = str(path)
        row_factors = _si_row_factors(contents, source)
        if contents.user_axis_rows is not None:
            sensor_matrix_si = contents.user_axis_rows * row_factors[:, None]
            ranges_si = contents.user_axis_maxima * row_factors
        else:
            sensor_matrix_si = basic_matrix_with_basic_transform_si(contents, source)
            ranges_si = contents.axis_maxima * row_factors
        _check_invertible(sensor_matrix_si, source)
        return cls(
            path=path,
            content_hash=content_hash_of_bytes(data),
            serial=contents.serial,
            body_style=contents.body_style,
            family=contents.family,
            part_number=contents.part_number,
            calibration_date=contents.calibration_date,
            file_format_version=contents.file_format_version,
            force_units=contents.force_units,
            torque_units=contents.torque_units,
            distance_units=contents.distance_units,
            sensor_matrix_si=sensor_matrix_si,
            ranges_si=ranges_si,
        )

    def with_tool_transform(self, tool_transform: ToolTransform) -> AtiCalibration:
        """Return a copy whose output is in the frame ``tool_transform`` describes.

        The transform replaces any earlier tool transform (as ATI's ``SetToolTransform`` does);
        it is relative to the calibration's own frame.
        """
        return dataclasses.replace(self, tool_transform=tool_transform)

    def forces_from_voltages(self, volts: np.ndarray, bias_volts: np.ndarray) -> np.ndarray:
        """Convert raw gauge voltages to forces and torques.

        Parameters
        ----------
        volts : array, shape (n, 6) or (6,)
            Raw gauge voltages, V.
        bias_volts : array, shape (6,)
            Raw gauge voltages at no load, V, subtracted before the matrix.

        Returns
        -------
        numpy.ndarray, shape like ``volts``
            ``[Fx, Fy, Fz, Tx, Ty, Tz]`` in N and N m, in the tool-transform frame.
        """
        volts = np.asarray(volts, dtype=float)
        bias_volts = np.asarray(bias_volts, dtype=float)
        if volts.shape[-1] != 6 or volts.ndim > 2 or bias_volts.shape != (6,):
            raise ValueError(f"need volts (n, 6), bias (6,); got {volts.shape}, {bias_volts.shape}")
        return (volts - bias_volts) @ self.matrix_si.T

    def voltages_from_forces(self, wrench: np.ndarray, bias_volts: np.ndarray) -> np.ndarray:
        """Invert :meth:`forces_from_voltages`: raw gauge voltages that produce ``wrench``.

        ``wrench`` has shape (n, 6) or (6,) in N and N m (tool-transform frame); the result has
        the same shape, in V, including ``bias_volts``. Used by simulators of the balance.
        """
        wrench = np.asarray(wrench, dtype=float)
        bias_volts = np.asarray(bias_volts, dtype=float)
        if wrench.shape[-1] != 6 or wrench.ndim > 2 or bias_volts.shape != (6,):
            raise ValueError(f"wrench (n, 6), bias (6,)? got {wrench.shape}, {bias_volts.shape}")
        return np.linalg.solve(self.matrix_si, wrench.T).T + bias_volts

    def summary(self) -> dict:
        """Return the calibration's identity, units, SI matrix, ranges and hash as plain data."""
        return {
            "path": str(self.path),
            "serial": self.serial,
            "body_style": self.body_style,
            "family": self.family,
            "part_number": self.part_number,
            "calibration_date": self.calibration_date,
            "file_format_version": self.file_format_version,
            "file_units": {
                "force": self.force_units,
                "torque": self.torque_units,
                "distance": self.distance_units,
            },
            "axis_names": list(AXIS_NAMES),
            "output_units": list(WRENCH_COMPONENT_UNITS),
            "matrix_si_per_volt": self.matrix_si.tolist(),
            "rated_ranges": dict(zip(WRENCH_COMPONENT_KEYS, self.ranges_si.tolist(), strict=True)),
            "tool_transform_mm_deg": self.tool_transform.as_mm_deg(),
            "content_hash": self.content_hash,
        }
