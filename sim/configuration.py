"""What is simulated: tail planform, tail position, balance mounting and vehicle parameters."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.sim.parameters import VehicleParameters
from ornitail.vehicle.geometry import TailGeometry, require_tail_position_mm, study_tail_geometry


@dataclass(frozen=True)
class BalanceMounting:
    """How the Nano-17 sits in the vehicle (all in the body frame of docs/frames.md).

    Parameters
    ----------
    sensor_origin_x_m : float
        Sensor origin along x_b from the fuselage axis (the strut attaches on the +x_b side).
    sensor_origin_station_m : float
        Sensor origin along the fuselage, aft of the wing leading edge.
    body_to_sensor_rotation : tuple of tuples
        Rows are the sensor axes expressed in body axes (x_b, y_b, z_b). Default: sensor x = x_b,
        sensor y = -y_b, sensor z = -z_b (sensor z points to the nose).
    """

    sensor_origin_x_m: float = 0.012
    sensor_origin_station_m: float = 0.060
    body_to_sensor_rotation: tuple[tuple[float, float, float], ...] = (
        (1.0, 0.0, 0.0),
        (0.0, -1.0, 0.0),
        (0.0, 0.0, -1.0),
    )

    def rotation_matrix(self) -> np.ndarray:
        return np.array(self.body_to_sensor_rotation, dtype=float)


@dataclass(frozen=True)
class VehicleConfiguration:
    """A DelFly II build: tail planform (None = tailless), tail position x_h (m), mounting,
    parameters.

    x_h is the distance from the flapping wings' trailing edge to the base tail's leading edge.
    """

    tail: TailGeometry | None
    x_h_m: float
    name: str = ""
    mounting: BalanceMounting = field(default_factory=BalanceMounting)
    parameters: VehicleParameters = field(default_factory=VehicleParameters)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.x_h_m) and 0.02 <= self.x_h_m <= 0.30):
            raise UserInputError(
                "x_h", f"tail position {self.x_h_m * 1e3:.1f} mm is outside 20-300 mm"
            )
        if self.tail is not None:
            self.tail.validate(f"tail {self.name or 'geometry'}")

    def without_tail(self) -> VehicleConfiguration:
        """The same vehicle with the horizontal tail (planform and base tail) removed."""
        return dataclasses.replace(self, tail=None, name=f"{self.name} tailless".strip())


def study_configuration(tail_name: str, x_h_mm: float) -> VehicleConfiguration:
    """A study tail (``"S3"``, ``"T2"``, ...) at tail position ``x_h_mm`` (millimetres)."""
    tail = study_tail_geometry(tail_name, where="tail")
    require_tail_position_mm("x_h_mm", x_h_mm)
    return VehicleConfiguration(tail=tail, x_h_m=x_h_mm / 1000.0, name=f"{tail_name}@{x_h_mm:g}mm")


def default_configuration() -> VehicleConfiguration:
    """The standard vehicle: tail T2 (the DelFly's standard tail) at x_h = 98 mm."""
    return study_configuration("T2", 98.0)
