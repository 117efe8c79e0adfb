"""The interfaces the rig drives its actuators through, one per role, whatever protocol a backend speaks.

Like python-can's ``BusABC``: :class:`Rig` knows only these classes; a backend (the project's ORNI line protocols,
a Modbus RTU drive, a Zaber controller, or a third party's class found through the ``ornitail.instruments``
entry-point group, see :mod:`actuator_backends`) implements one of them. SI units throughout: m/s, rad, rev/min.

A backend class also says how the rig file configures it: :attr:`Actuator.settings_table` names its sub-table
(``[fan.modbus]``), :meth:`Actuator.read_settings` checks that table, and :meth:`Actuator.from_rig` builds the
driver from an :class:`ActuatorContext` (port, baud, its checked settings, the rig's limits and tunnel table).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Self

from ornitail.acquisition.line_instrument_connection import DEFAULT_LINE_BAUD
from ornitail.core.errors import UserInputError, require_finite

if TYPE_CHECKING:
    from ornitail.acquisition.rig_file import SafetyLimits
    from ornitail.calibration.tunnel_table import TunnelVelocityTable
    from ornitail.core.toml_table import TomlTable

ROLES = ("fan", "strut", "motor")
"""The actuator roles of a rig, as the rig file's sections name them."""

Reading = dict[str, float | int | bool]
"""One reading for ``ornitail rig check``, keyed with units (``fan_rpm``, ``pitch_deg``)."""


@dataclass(frozen=True)
class ActuatorContext:
    """What a backend needs to build its driver.

    Attributes
    ----------
    name : str
        Instrument name used in every message ("tunnel fan").
    port : str
        Serial device or pty path (the rig file's ``port``, or the simulator's pty).
    baud : int
        Line rate, bit/s.
    reply_timeout_s : float
        How long the instrument may take to answer, s.
    settings : object
        What the backend's :meth:`Actuator.read_settings` returned (None without a settings table).
    limits : SafetyLimits
        The rig's limits (SI).
    tunnel_table : TunnelVelocityTable
        Fan rpm to velocity.
    max_fan_rpm : float
        Fan speed at the rig's velocity limit, rev/min.
    rig_file : pathlib.Path
        The rig file (for messages).
    """

    name: str
    port: str
    baud: int
    reply_timeout_s: float
    settings: Any
    limits: SafetyLimits
    tunnel_table: TunnelVelocityTable
    max_fan_rpm: float
    rig_file: Path


class Actuator(ABC):
    """What every actuator backend offers: open (identify), close, safe state, one reading for the rig check."""

    role: ClassVar[str]
    """``"fan"``, ``"strut"`` or ``"motor"`` (set by the role classes below)."""
    backend: ClassVar[str]
    """The backend's name in the rig file (``backend = "modbus_vfd"``)."""
    settings_table: ClassVar[str | None] = None
    """Name of the backend's rig-file sub-table (``"modbus"`` for ``[fan.modbus]``), None if it has none."""
    settings_keys: ClassVar[frozenset[str]] = frozenset()
    """Keys that sub-table may have."""
    default_baud: ClassVar[int] = DEFAULT_LINE_BAUD
    """Line rate used when the rig file gives none, bit/s."""

    name: str
    """Instrument name used in every message."""

    @classmethod
    def read_settings(cls, table: TomlTable) -> Any:
        """Check the backend's sub-table (every mistake a ``UserInputError`` naming file, table and key)."""
        return None

    @classmethod
    @abstractmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        """Create (not open) the driver."""

    @property
    @abstractmethod
    def route(self) -> str:
        """Where it is connected (port path), for messages and the rig check."""

    @property
    @abstractmethod
    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close`."""

    @abstractmethod
    def open(self) -> str:
        """Open the port exclusively, drain it, identify the instrument; return its identity as text."""

    @abstractmethod
    def close(self) -> None:
        """Close the port (does not make the instrument safe: call :meth:`safe_state` first)."""

    @abstractmethod
    def safe_state(self) -> None:
        """Bring the instrument to rest and confirm it (fan stopped, strut held, motor off)."""

    @abstractmethod
    def check_reading(self) -> Reading:
        """One reading for ``ornitail rig check``, keyed with units; moves nothing."""

    def identity_problem(self, identity: str, rig_file_key: str) -> str | None:
        """Why ``identity`` (what :meth:`open` returned) is not the instrument this driver speaks to, or None."""
        return None


def require_pitch_within(name: str, pitch_rad: float, low_rad: float, high_rad: float) -> None:
    """Refuse a pitch (rad) that is not finite or lies outside the rig's limits, before anything is sent to the
    strut called ``name``; the message shows degrees."""
    require_finite("pitch_rad", pitch_rad)
    if not low_rad <= pitch_rad <= high_rad:
        raise UserInputError(
            "pitch",
            f"{math.degrees(pitch_rad):g} deg is outside the rig limit "
            f"{math.degrees(low_rad):g}..{math.degrees(high_rad):g} deg ({name})",
        )


class ConnectedOverOnePort:
    """``route`` and ``is_open`` of an actuator driven over one connection, ``self.connection`` (its ``port`` path
    and ``is_open`` flag); mixed in before the role class."""

    connection: Any

    @property
    def route(self) -> str:
        return self.connection.port

    @property
    def is_open(self) -> bool:
        return self.connection.is_open


class TunnelFan(Actuator):
    """The tunnel fan: velocity set point and reading (m/s); its safe state is stopped."""

    role: ClassVar[str] = "fan"

    @abstractmethod
    def set_velocity(self, velocity_m_s: float) -> None:
        """Command jet velocity ``velocity_m_s`` (m/s) through the tunnel table."""

    @abstractmethod
    def read_velocity_m_s(self) -> float:
        """Jet velocity from the measured fan speed (or drive frequency) and the tunnel table, m/s."""

    def stop(self) -> None:
        """Stop the fan (the safe state)."""
        self.safe_state()


class PitchStrut(Actuator):
    """The strut that pitches the vehicle: home, pitch set point and reading (rad); its safe state holds still."""

    role: ClassVar[str] = "strut"

    @abstractmethod
    def home(self, timeout_s: float = 30.0) -> None:
        """Run the homing move and wait (wall clock, ``timeout_s``) until homed."""

    @abstractmethod
    def set_pitch(self, pitch_rad: float) -> None:
        """Command pitch ``pitch_rad`` (rad); refused outside the rig's limits before sending."""

    @abstractmethod
    def read_pitch_rad(self) -> float:
        """Measured pitch angle, rad."""

    @abstractmethod
    def wait_until_settled(self, timeout_s: float = 30.0) -> None:
        """Wait (wall clock, ``timeout_s``) until the strut stops moving."""


class FlappingMotor(Actuator):
    """The flapping-mechanism motor: speed set point and reading (rev/min); its safe state is off."""

    role: ClassVar[str] = "motor"

    @abstractmethod
    def set_target_rpm(self, motor_rpm: float) -> None:
        """Closed-loop speed set point, rev/min; refused outside the rig's limit before sending."""

    @abstractmethod
    def read_rpm(self) -> float:
        """Measured motor speed, rev/min."""

    def stop(self) -> None:
        """Stop the motor (the safe state)."""
        self.safe_state()


ROLE_INTERFACES: dict[str, type[Actuator]] = {
    "fan": TunnelFan,
    "strut": PitchStrut,
    "motor": FlappingMotor,
}
"""The interface a backend of each role must implement."""
