"""The ``orni_line`` backends: the project's own ORNI fan, strut and motor line protocols behind the role interfaces.

These are the default backends (a rig file without ``backend`` uses them); the drivers themselves are
:mod:`tunnel_fan_driver`, :mod:`strut_pitch_driver` and :mod:`flapping_motor_driver`, unchanged. The fan's
velocity is converted to fan rpm through the tunnel table (:class:`FanSpeedMap`).
"""

from __future__ import annotations

import math
from typing import ClassVar, Self

from ornitail.acquisition.actuator_interfaces import (
    ActuatorContext,
    ConnectedOverOnePort,
    FlappingMotor,
    PitchStrut,
    Reading,
    TunnelFan,
)
from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.flapping_motor_driver import FlappingMotorDriver
from ornitail.acquisition.line_instrument_connection import LineInstrumentConnection
from ornitail.acquisition.line_instrument_driver import LineInstrumentDriver
from ornitail.acquisition.strut_pitch_driver import StrutPitchDriver
from ornitail.acquisition.tunnel_fan_driver import TunnelFanDriver

ORNI_LINE = "orni_line"
"""The backend name of the ORNI line protocols (the default)."""


def identity_fields(reply: str) -> dict[str, str]:
    """``ID model=ORNI-FAN serial=SIM00001 firmware=1.0.0`` -> ``{"model": "ORNI-FAN", ...}``."""
    return dict(word.split("=", 1) for word in reply.split()[1:] if "=" in word)


class _OrniLineCommon(ConnectedOverOnePort):
    """What the three ORNI line backends share (mixed into the line drivers)."""

    model: str
    connection: LineInstrumentConnection

    def identity_problem(self, identity: str, rig_file_key: str) -> str | None:
        model = identity_fields(identity).get("model")
        if model == self.model:
            return None
        return (
            f"{self.route} answers as {model or identity!r}, not {self.model}: "
            f"is {rig_file_key} the port of another instrument?"
        )


def _with_timeout(driver: LineInstrumentDriver, context: ActuatorContext) -> None:
    driver.connection.reply_timeout_s = context.reply_timeout_s


class OrniLineTunnelFan(_OrniLineCommon, TunnelFanDriver, TunnelFan):
    """ORNI-FAN: velocity through the tunnel table to fan rpm."""

    backend: ClassVar[str] = ORNI_LINE

    def __init__(self, port: str, *, speed_map: FanSpeedMap, max_rpm: float, **kwargs) -> None:
        super().__init__(port, max_rpm=max_rpm, **kwargs)
        self.speed_map = speed_map

    @classmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        fan = cls(
            context.port,
            speed_map=FanSpeedMap(context.tunnel_table),
            max_rpm=context.max_fan_rpm,
            name=context.name,
            baud=context.baud,
        )
        _with_timeout(fan, context)
        return fan

    def set_velocity(self, velocity_m_s: float) -> None:
        self.set_rpm(self.speed_map.rpm_for_velocity(velocity_m_s))

    def read_velocity_m_s(self) -> float:
        return self.speed_map.velocity_for_rpm(self.read_rpm())

    def check_reading(self) -> Reading:
        return {"fan_rpm": self.read_rpm()}


class OrniLineStrut(_OrniLineCommon, StrutPitchDriver, PitchStrut):
    """ORNI-STRUT: pitch in rad, degrees on the wire."""

    backend: ClassVar[str] = ORNI_LINE

    @classmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        strut = cls(
            context.port,
            pitch_min_rad=context.limits.pitch_min_rad,
            pitch_max_rad=context.limits.pitch_max_rad,
            name=context.name,
            baud=context.baud,
        )
        _with_timeout(strut, context)
        return strut

    def check_reading(self) -> Reading:
        return {"pitch_deg": math.degrees(self.read_pitch_rad()), "homed": self.status().homed}


class OrniLineMotor(_OrniLineCommon, FlappingMotorDriver, FlappingMotor):
    """ORNI-MOTOR: speed set point in rev/min."""

    backend: ClassVar[str] = ORNI_LINE

    @classmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        motor = cls(
            context.port, max_rpm=context.limits.max_motor_rpm, name=context.name, baud=context.baud
        )
        _with_timeout(motor, context)
        return motor

    def check_reading(self) -> Reading:
        return {"motor_rpm": self.read_rpm()}
