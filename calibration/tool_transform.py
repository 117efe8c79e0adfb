"""Tool transform: move the force/torque reference point and rotate the axes.

A tool transform describes a new frame relative to the current (sensor) frame by

- ``displacement_m``: the new origin, in metres, expressed in the current frame, and
- ``rotation``: the 3x3 matrix whose columns are the new unit axes expressed in the current frame.

Forces and torques then transform as::

    F' = R^T F
    T' = R^T (T - d x F)

The rotation is built from three angles with the ATI convention: rotate the frame about its x axis
by ``rx``, then about the resulting y axis by ``ry``, then about the resulting z axis by ``rz``
(intrinsic x-y'-z'', equivalently extrinsic z, y, x), i.e. ``R = Rx(rx) Ry(ry) Rz(rz)``. ``R^T``
is then exactly the force block of the tool-transform matrix that the ATI DAQ F/T C library builds
(``ftconfig.c``, function ``TTM``), and its torque block equals ``-R^T [d]x`` as above.

Degrees and millimetres appear only in :meth:`ToolTransform.from_mm_deg`, the user-facing edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ornitail.calibration.number_lists import parse_comma_separated_numbers
from ornitail.core.errors import UserInputError, require_finite

MAX_OFFSET_MM = 10_000.0
"""Largest tool-transform displacement accepted, mm (10 m: beyond any balance mounting)."""


def rotation_about_x(angle_rad: float) -> np.ndarray:
    """Rotation matrix of a frame turned by ``angle_rad`` about its x axis (columns = new axes)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_about_y(angle_rad: float) -> np.ndarray:
    """Rotation matrix of a frame turned by ``angle_rad`` about its y axis (columns = new axes)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_about_z(angle_rad: float) -> np.ndarray:
    """Rotation matrix of a frame turned by ``angle_rad`` about its z axis (columns = new axes)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def cross_product_matrix(vector: np.ndarray) -> np.ndarray:
    """Return the 3x3 matrix ``[v]x`` with ``[v]x @ w == np.cross(v, w)``."""
    x, y, z = vector
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


@dataclass(frozen=True, eq=False)
class ToolTransform:
    """A new force/torque frame relative to the current one (SI: metres, rotation matrix).

    Attributes
    ----------
    displacement_m : numpy.ndarray, shape (3,)
        Origin of the new frame in the current frame, metres.
    rotation : numpy.ndarray, shape (3, 3)
        Columns are the new frame's unit axes expressed in the current frame.
    """

    displacement_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    @classmethod
    def from_si(
        cls,
        displacement_m: tuple[float, float, float] | np.ndarray,
        angles_rad: tuple[float, float, float] | np.ndarray,
    ) -> ToolTransform:
        """Build from a displacement (m) and ATI angles ``(rx, ry, rz)`` in radians."""
        rx, ry, rz = (float(angle) for angle in angles_rad)
        rotation = rotation_about_x(rx) @ rotation_about_y(ry) @ rotation_about_z(rz)
        return cls(np.asarray(displacement_m, dtype=float).copy(), rotation)

    @classmethod
    def from_mm_deg(
        cls,
        dx_mm: float,
        dy_mm: float,
        dz_mm: float,
        rx_deg: float,
        ry_deg: float,
        rz_deg: float,
        where: str = "tool transform",
    ) -> ToolTransform:
        """Build from the user-facing six numbers: displacement in mm, ATI angles in degrees."""
        values = [dx_mm, dy_mm, dz_mm, rx_deg, ry_deg, rz_deg]
        require_finite(where, values)
        for name, value, bound in zip(
            ("dx", "dy", "dz", "rx", "ry", "rz"),
            values,
            [MAX_OFFSET_MM] * 3 + [360.0] * 3,
            strict=True,
        ):
            if abs(value) > bound:
                unit = "mm" if name.startswith("d") else "deg"
                raise UserInputError(
                    where, f"{name} = {value:g} {unit} is outside +-{bound:g} {unit}"
                )
        return cls.from_si(np.array(values[:3]) * 1e-3, np.radians(values[3:]))

    def angles_rad(self) -> np.ndarray:
        """Return the ATI angles ``(rx, ry, rz)`` in radians that produce :attr:`rotation`."""
        r = self.rotation
        ry = np.arcsin(np.clip(r[0, 2], -1.0, 1.0))
        rx = np.arctan2(-r[1, 2], r[2, 2])
        rz = np.arctan2(-r[0, 1], r[0, 0])
        return np.array([rx, ry, rz])

    def wrench_matrix(self) -> np.ndarray:
        """Return the 6x6 matrix mapping ``[F, T]`` in the current frame to ``[F', T']``."""
        rotation_transposed = self.rotation.T
        matrix = np.zeros((6, 6))
        matrix[:3, :3] = rotation_transposed
        matrix[3:, 3:] = rotation_transposed
        matrix[3:, :3] = -rotation_transposed @ cross_product_matrix(self.displacement_m)
        return matrix

    def inverse(self) -> ToolTransform:
        """Return the transform that takes the new frame back to the current one."""
        rotation_transposed = self.rotation.T
        return ToolTransform(-rotation_transposed @ self.displacement_m, rotation_transposed)

    def as_mm_deg(self) -> list[float]:
        """Return ``[dx_mm, dy_mm, dz_mm, rx_deg, ry_deg, rz_deg]`` for display."""
        return [*(self.displacement_m * 1e3).tolist(), *np.degrees(self.angles_rad()).tolist()]


def parse_tool_transform_option(text: str, where: str = "tool_transform") -> ToolTransform:
    """Parse ``"dx,dy,dz,rx,ry,rz"`` (mm and degrees) into a :class:`ToolTransform`."""
    values = parse_comma_separated_numbers(text, 6, where)
    return ToolTransform.from_mm_deg(*values, where=where)
