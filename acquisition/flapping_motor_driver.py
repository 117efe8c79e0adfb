"""Driver of the flapping-mechanism motor controller (ORNI-MOTOR line protocol).

The motor drives the wings through a gearbox; flapping frequency = rpm / 60 / gear ratio
(21.33 on the DelFly II).
"""

from __future__ import annotations

from ornitail.acquisition.line_instrument_connection import DEFAULT_LINE_BAUD
from ornitail.acquisition.line_instrument_driver import LineInstrumentDriver
from ornitail.core.errors import UserInputError, require_finite


class FlappingMotorDriver(LineInstrumentDriver):
    """Sets throttle or target rpm and reads the motor speed.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    max_rpm : float
        The rig's motor speed limit, rev/min.
    """

    model = "ORNI-MOTOR"
    """The model its ``ID?`` reply names (docs/instrument-protocols.md)."""

    def __init__(
        self,
        port: str,
        *,
        max_rpm: float,
        name: str = "flapping motor",
        baud: int = DEFAULT_LINE_BAUD,
    ) -> None:
        super().__init__(port, name=name, baud=baud, safe_state_command="OFF")
        self.max_rpm = float(max_rpm)

    def set_throttle(self, throttle_fraction: float) -> None:
        """Open-loop throttle, 0..1 of full power."""
        require_finite("throttle_fraction", throttle_fraction)
        if not 0.0 <= throttle_fraction <= 1.0:
            raise UserInputError(
                "throttle_fraction", f"{throttle_fraction:g} is outside 0..1 ({self.name})"
            )
        self.connection.command(f"THROTTLE {throttle_fraction:.4f}")

    def set_target_rpm(self, motor_rpm: float) -> None:
        """Closed-loop speed set point, rev/min; refused outside 0..max_rpm before sending."""
        require_finite("motor_rpm", motor_rpm)
        if not 0.0 <= motor_rpm <= self.max_rpm:
            raise UserInputError(
                "motor_rpm",
                f"{motor_rpm:g} rpm is outside the rig limit 0..{self.max_rpm:g} rpm "
                f"(max_motor_rpm, {self.name})",
            )
        self.connection.command(f"RPM {motor_rpm:.1f}")

    def read_rpm(self) -> float:
        """Measured motor speed, rev/min."""
        return self.connection.query_value("RPM?", "RPM")
