"""Driver of the strut pitch actuator (ORNI-STRUT line protocol, docs/instrument-protocols.md).

The wire speaks degrees; this driver speaks radians (``pitch_rad``) and converts at the edge.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from ornitail.acquisition.actuator_interfaces import require_pitch_within
from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.line_instrument_connection import DEFAULT_LINE_BAUD
from ornitail.acquisition.line_instrument_driver import LineInstrumentDriver


@dataclass
class StrutStatus:
    """Homed (the angle reference is known) and moving (still slewing to the target)."""

    homed: bool
    moving: bool


class StrutPitchDriver(LineInstrumentDriver):
    """Sets and reads the pitch angle of the strut that holds the vehicle.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    pitch_min_rad, pitch_max_rad : float
        The rig's pitch limits, rad (set points outside are refused before sending).
    """

    model = "ORNI-STRUT"
    """The model its ``ID?`` reply names (docs/instrument-protocols.md)."""

    def __init__(
        self,
        port: str,
        *,
        pitch_min_rad: float,
        pitch_max_rad: float,
        name: str = "strut pitch actuator",
        baud: int = DEFAULT_LINE_BAUD,
    ) -> None:
        super().__init__(port, name=name, baud=baud, safe_state_command="HALT")
        self.pitch_min_rad = float(pitch_min_rad)
        self.pitch_max_rad = float(pitch_max_rad)

    def status(self) -> StrutStatus:
        """Ask ``STATUS?``."""
        reply = self.connection.query("STATUS?")
        words = reply.split()
        fields = dict(word.split("=", 1) for word in words[1:] if "=" in word)
        if not words or words[0] != "STATUS" or not {"homed", "moving"} <= fields.keys():
            raise InstrumentReplyError(self.name, f"malformed STATUS reply {reply!r}")
        return StrutStatus(homed=fields["homed"] == "1", moving=fields["moving"] == "1")

    def home(self, timeout_s: float = 30.0, poll_interval_s: float = 0.02) -> None:
        """Run the homing move and wait (wall-clock ``timeout_s``) until the actuator is homed."""
        self.connection.command("HOME")
        self._wait(
            lambda status: status.homed and not status.moving, timeout_s, poll_interval_s, "homing"
        )

    def set_pitch(self, pitch_rad: float) -> None:
        """Command pitch ``pitch_rad`` (rad); refused outside the rig's limits before sending."""
        require_pitch_within(self.name, pitch_rad, self.pitch_min_rad, self.pitch_max_rad)
        self.connection.command(f"ANGLE {math.degrees(pitch_rad):.4f}")

    def read_pitch_rad(self) -> float:
        """Measured pitch angle, rad."""
        return math.radians(self.connection.query_value("ANGLE?", "ANGLE"))

    def wait_until_settled(self, timeout_s: float = 30.0, poll_interval_s: float = 0.02) -> None:
        """Wait (wall-clock ``timeout_s``) until the strut stops moving."""
        self._wait(lambda status: not status.moving, timeout_s, poll_interval_s, "settling")

    def _wait(self, done, timeout_s: float, poll_interval_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not done(self.status()):
            if time.monotonic() > deadline:
                raise InstrumentReplyError(
                    self.name, f"{what} did not finish within {timeout_s:g} s"
                )
            time.sleep(poll_interval_s)
