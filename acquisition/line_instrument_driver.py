"""What every line-protocol instrument driver shares: its connection, ``ID?`` on open, close, a safe state."""

from __future__ import annotations

from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.line_instrument_connection import (
    DEFAULT_LINE_BAUD,
    LineInstrumentConnection,
)
from ornitail.acquisition.serial_port_access import printable_excerpt


class LineInstrumentDriver:
    """Base of the fan, strut and motor drivers (docs/instrument-protocols.md).

    Parameters
    ----------
    port : str
        Serial device or pty path.
    name : str
        Name used in every message about this instrument.
    baud : int
        Line speed, bit/s.
    safe_state_command : str
        Command that brings the instrument to rest (sent by :meth:`safe_state`).
    """

    model: str
    """The model the instrument's ``ID?`` reply names (set by each driver)."""

    def __init__(
        self, port: str, *, name: str, baud: int = DEFAULT_LINE_BAUD, safe_state_command: str
    ) -> None:
        self.name = name
        self.connection = LineInstrumentConnection(port, name=name, baud=baud)
        self._safe_state_command = safe_state_command

    def open(self) -> str:
        """Open the port exclusively, drain what is pending, and return the controller's ``ID?`` reply.

        A reply that is not ``ID ...`` (a late answer to a crashed host's command) is drained and asked again
        once; the port is closed again if the instrument cannot be identified.
        """
        self.connection.open()
        try:
            reply = self.connection.query("ID?")
            if not reply.startswith("ID"):
                self.connection.discard_pending_input()
                reply = self.connection.query("ID?")
            if not reply.startswith("ID"):
                raise InstrumentReplyError(
                    self.name,
                    f"unexpected reply to 'ID?' on {self.connection.port}: {printable_excerpt(reply)}",
                )
        except BaseException:
            self.connection.close()
            raise
        return reply

    def close(self) -> None:
        """Close the port (does not bring the instrument to rest; call :meth:`safe_state` first)."""
        self.connection.close()

    def safe_state(self) -> None:
        """Bring the instrument to rest (fan stopped, motor off, strut halted)."""
        self.connection.command(self._safe_state_command)
