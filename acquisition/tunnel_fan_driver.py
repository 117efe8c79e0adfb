"""Driver of the wind-tunnel fan controller (ORNI-FAN, docs/instrument-protocols.md)."""

from __future__ import annotations

from ornitail.acquisition.line_instrument_connection import DEFAULT_LINE_BAUD
from ornitail.acquisition.line_instrument_driver import LineInstrumentDriver
from ornitail.core.errors import UserInputError, require_finite


class TunnelFanDriver(LineInstrumentDriver):
    """Sets and reads the tunnel fan speed, rev/min.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    max_rpm : float
        Highest fan speed the rig allows (from the rig's velocity limit), rev/min.
    """

    model = "ORNI-FAN"
    """The model its ``ID?`` reply names (docs/instrument-protocols.md)."""

    def __init__(
        self, port: str, *, max_rpm: float, name: str = "tunnel fan", baud: int = DEFAULT_LINE_BAUD
    ) -> None:
        super().__init__(port, name=name, baud=baud, safe_state_command="STOP")
        self.max_rpm = float(max_rpm)

    def set_rpm(self, fan_rpm: float) -> None:
        """Command fan speed ``fan_rpm`` (rev/min); refused outside 0..max_rpm before sending."""
        require_finite("fan_rpm", fan_rpm)
        if not 0.0 <= fan_rpm <= self.max_rpm:
            raise UserInputError(
                "fan_rpm",
                f"{fan_rpm:g} rpm is outside the rig limit 0..{self.max_rpm:g} rpm ({self.name})",
            )
        self.connection.command(f"RPM {fan_rpm:.1f}")

    def read_rpm(self) -> float:
        """Measured fan speed, rev/min."""
        return self.connection.query_value("RPM?", "RPM")

    def read_target_rpm(self) -> float:
        """Commanded fan speed, rev/min."""
        return self.connection.query_value("TARGET?", "TARGET")
