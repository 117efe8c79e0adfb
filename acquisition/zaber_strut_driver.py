"""The ``zaber_ascii`` strut backend: the pitch strut on a Zaber-style ASCII motion controller.

Pitch (rad) <-> axis position (microsteps or encoder counts): ``counts = (pitch_deg - pitch_at_zero_counts_deg) *
counts_per_deg`` with both from ``[strut.zaber]`` (degrees only at that edge). Homing is ``home``; moves are
``move abs``; the position and state come from ``get pos`` (``BUSY`` while moving, flag ``WR``/``WH`` until homed);
the safe state is ``stop`` (decelerate and hold position: the motor stays energised, so the strut is held).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import ClassVar, Self

from ornitail.acquisition.actuator_interfaces import (
    ActuatorContext,
    ConnectedOverOnePort,
    PitchStrut,
    Reading,
    require_pitch_within,
)
from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.line_instrument_connection import LineInstrumentConnection
from ornitail.acquisition.serial_port_access import printable_excerpt
from ornitail.acquisition.zaber_ascii import (
    NOT_HOMED_FLAGS,
    ZaberReply,
    flag_meaning,
    parse_reply,
)
from ornitail.core.errors import UserInputError
from ornitail.core.toml_table import TomlTable

ZABER_ASCII = "zaber_ascii"
MAX_COUNTS = 2**31 - 1


@dataclass(frozen=True)
class ZaberStrutSettings:
    """``[strut.zaber]``: device address, axis, and the pitch <-> position conversion."""

    device: int = 1
    axis: int = 1
    counts_per_deg: float = 0.0
    """Axis position counts (microsteps or encoder counts) per degree of pitch (required; sign = direction)."""
    pitch_at_zero_counts_deg: float = 0.0
    """Pitch at axis position 0 (the home position unless the controller has a home offset), deg."""

    @classmethod
    def from_table(cls, table: TomlTable) -> ZaberStrutSettings:
        """Check ``[strut.zaber]``; every mistake names the file, table and key."""
        counts_per_deg = table.number("counts_per_deg")
        if counts_per_deg == 0:
            raise UserInputError(table.where("counts_per_deg"), "must not be 0")
        return cls(
            device=table.integer("device", 1, minimum=1, maximum=99),
            axis=table.integer("axis", 1, minimum=1, maximum=9),
            counts_per_deg=counts_per_deg,
            pitch_at_zero_counts_deg=table.number("pitch_at_zero_counts_deg", 0.0),
        )

    def counts_for_pitch(self, pitch_rad: float) -> int:
        """Axis position for pitch ``pitch_rad`` (rad), rounded to whole counts."""
        return round(
            (math.degrees(pitch_rad) - self.pitch_at_zero_counts_deg) * self.counts_per_deg
        )

    def pitch_rad_for_counts(self, counts: float) -> float:
        """Pitch (rad) at axis position ``counts``."""
        return math.radians(self.pitch_at_zero_counts_deg + counts / self.counts_per_deg)


@dataclass(frozen=True)
class ZaberAxisState:
    """Position (counts), moving, homed and the flag of one ``get pos`` reply."""

    position_counts: int
    moving: bool
    homed: bool
    warning: str


class ZaberAsciiStrut(ConnectedOverOnePort, PitchStrut):
    """Pitch strut on axis ``settings.axis`` of Zaber device ``settings.device``.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    settings : ZaberStrutSettings
        Address, axis and conversion.
    pitch_min_rad, pitch_max_rad : float
        The rig's pitch limits, rad (set points outside are refused before sending).
    """

    backend: ClassVar[str] = ZABER_ASCII
    settings_table: ClassVar[str | None] = "zaber"
    settings_keys: ClassVar[frozenset[str]] = frozenset(ZaberStrutSettings.__dataclass_fields__)
    default_baud: ClassVar[int] = 115_200

    def __init__(
        self,
        port: str,
        *,
        settings: ZaberStrutSettings,
        pitch_min_rad: float,
        pitch_max_rad: float,
        name: str = "strut pitch actuator",
        baud: int = 115_200,
        reply_timeout_s: float = 1.0,
    ) -> None:
        self.name = name
        self.settings = settings
        self.pitch_min_rad = float(pitch_min_rad)
        self.pitch_max_rad = float(pitch_max_rad)
        self.connection = LineInstrumentConnection(
            port, name=name, baud=baud, reply_timeout_s=reply_timeout_s
        )

    @classmethod
    def read_settings(cls, table: TomlTable) -> ZaberStrutSettings:
        return ZaberStrutSettings.from_table(table)

    @classmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        return cls(
            context.port,
            settings=context.settings,
            pitch_min_rad=context.limits.pitch_min_rad,
            pitch_max_rad=context.limits.pitch_max_rad,
            name=context.name,
            baud=context.baud,
            reply_timeout_s=context.reply_timeout_s,
        )

    # -- exchange ---------------------------------------------------------------------------
    def command(
        self, text: str, *, axis: int | None = None, accept_fault: bool = False
    ) -> ZaberReply:
        """Send ``/<device> <axis> <text>`` and return the accepted reply (axis 0 for device-wide commands).

        Raises
        ------
        InstrumentReplyError
            Rejected (``RJ``), a fault flag (unless ``accept_fault``), or not a reply from this device and axis.
        InstrumentDisconnected
            The port failed or nothing answered in time.
        """
        axis = self.settings.axis if axis is None else axis
        line = f"/{self.settings.device} {axis} {text}"
        answer = self.connection.query(line)
        reply = parse_reply(answer)
        port = self.connection.port
        if reply is None or reply.device != self.settings.device or reply.axis != axis:
            raise InstrumentReplyError(
                self.name, f"unexpected reply to {line!r} on {port}: {printable_excerpt(answer)}"
            )
        if not reply.accepted:
            raise InstrumentReplyError(
                self.name,
                f"rejected {line!r} on {port}: {reply.data} (flag {flag_meaning(reply.warning)})",
            )
        if reply.fault and not accept_fault:
            raise InstrumentReplyError(
                self.name, f"reports fault {flag_meaning(reply.warning)} after {line!r} on {port}"
            )
        return reply

    # -- connection -------------------------------------------------------------------------
    def open(self) -> str:
        """Open the port, drain it, ask ``get device.id``; return ``"Zaber device 1 axis 1 device.id=..."``."""
        self.connection.open()
        try:
            reply = self.command("get device.id", axis=0)
        except BaseException:
            self.connection.close()
            raise
        return (
            f"Zaber device {self.settings.device} axis {self.settings.axis} device.id={reply.data}"
        )

    def close(self) -> None:
        self.connection.close()

    # -- motion -----------------------------------------------------------------------------
    def safe_state(self) -> None:
        """``stop``: decelerate to rest and hold the position (accepted also with a fault flag: a faulted axis that
        accepts ``stop`` is at rest)."""
        self.command("stop", accept_fault=True)

    def state(self) -> ZaberAxisState:
        """``get pos``: position (counts), moving, homed, flag."""
        reply = self.command("get pos")
        try:
            counts = int(reply.data)
        except ValueError:
            raise InstrumentReplyError(
                self.name, f"position {reply.data!r} from 'get pos' is not a whole number"
            ) from None
        return ZaberAxisState(
            counts, reply.busy, reply.warning not in NOT_HOMED_FLAGS, reply.warning
        )

    def home(self, timeout_s: float = 30.0, poll_interval_s: float = 0.02) -> None:
        self.command("home")
        self._wait(
            lambda state: state.homed and not state.moving, timeout_s, poll_interval_s, "homing"
        )

    def set_pitch(self, pitch_rad: float) -> None:
        require_pitch_within(self.name, pitch_rad, self.pitch_min_rad, self.pitch_max_rad)
        counts = self.settings.counts_for_pitch(pitch_rad)
        if abs(counts) > MAX_COUNTS:
            raise UserInputError(
                "pitch", f"{counts} counts does not fit the controller's position ({self.name})"
            )
        self.command(f"move abs {counts}")

    def read_pitch_rad(self) -> float:
        return self.settings.pitch_rad_for_counts(self.state().position_counts)

    def wait_until_settled(self, timeout_s: float = 30.0, poll_interval_s: float = 0.02) -> None:
        self._wait(lambda state: not state.moving, timeout_s, poll_interval_s, "settling")

    def _wait(self, done, timeout_s: float, poll_interval_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not done(self.state()):
            if time.monotonic() > deadline:
                raise InstrumentReplyError(
                    self.name, f"{what} did not finish within {timeout_s:g} s on {self.route}"
                )
            time.sleep(poll_interval_s)

    def check_reading(self) -> Reading:
        state = self.state()
        return {
            "pitch_deg": math.degrees(self.settings.pitch_rad_for_counts(state.position_counts)),
            "position_counts": state.position_counts,
            "homed": state.homed,
        }
