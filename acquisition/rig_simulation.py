"""Simulated instruments as a backend of the rig, found by name like the actuator backends.

The rig file chooses the simulation: ``[rig].simulated = true`` names the backend ``simulated`` (instruments started
in this process), ``[rig].simulator_control`` the backend ``simulator_server`` (instruments served by another
process); a rig with neither has real instruments and no simulation. A backend is a :class:`RigSimulation`
registered as the entry point ``rig.<name>`` in the group ``ornitail.instruments`` (ornitail's own come from
``ornitail.simulated_instruments``, which acquisition does not import). The rig reaches the simulated instruments
only through this interface.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from ornitail.acquisition.actuator_backends import entry_point_class
from ornitail.acquisition.rig_file import RigDescription
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.hotwire_laws import HotwireLaw
from ornitail.calibration.tunnel_table import TunnelVelocityTable

SIMULATION_ROLE = "rig"
"""The entry points of simulations are named ``rig.<name>``."""


@dataclass(frozen=True)
class SimulationLink:
    """A link the rig reaches its simulated instruments through, checked by ``ornitail rig check`` in a row of its
    own (the control socket of a simulator served by another process)."""

    name: str
    """Instrument name of the row."""
    rig_file_key: str
    """Where the rig file sets the link (``[rig].simulator_control``)."""
    route: str
    """Where it is connected: a socket path."""
    identity: str
    """What answered."""
    reading: dict[str, float] = field(default_factory=dict)
    """What it reported, keyed with units where they have one."""


class RigSimulation(ABC):
    """The simulated instruments of one rig, once reached (started, or connected to their server)."""

    @classmethod
    @abstractmethod
    def start(
        cls,
        description: RigDescription,
        calibration: AtiCalibration,
        tunnel_table: TunnelVelocityTable,
    ) -> RigSimulation:
        """Reach the simulated instruments of ``description``.

        Raises
        ------
        InstrumentError
            They cannot be reached (a simulator server that does not answer).
        """

    @classmethod
    def hotwire_law(cls) -> HotwireLaw | None:
        """The law of the simulated hot-wire (None: unknown)."""
        return None

    @property
    @abstractmethod
    def time_scale(self) -> float:
        """Rig seconds per wall second."""

    def now_s(self) -> float:
        """Rig time, s."""
        return time.monotonic() * self.time_scale

    def ports(self) -> dict[str, str]:
        """Ports that replace the rig file's, by role (``fan``, ``strut``, ``motor``, ``daq``, ``aux_daq``)."""
        return {}

    def can_bus(self) -> tuple[str, str] | None:
        """The CAN interface and channel that replace the rig file's, or None to keep them."""
        return None

    def netft_address(self) -> tuple[str, int, int] | None:
        """Host, RDT port and HTTP port that replace ``[balance.netft]``'s, or None to keep them."""
        return None

    def link(self) -> SimulationLink | None:
        """The link these instruments were reached through, once :meth:`start` answered (None: in this process)."""
        return None

    @abstractmethod
    def mount_vehicle(self, tail_id: str, x_h_m: float) -> None:
        """Put the study's vehicle with tail ``tail_id`` at tail position ``x_h_m`` (m) on the balance."""

    @abstractmethod
    def set_tail_attached(self, tail_attached: bool) -> None:
        """Fit (True) or remove (False) the simulated vehicle's tail."""

    @abstractmethod
    def close(self) -> None:
        """Stop what :meth:`start` started."""


def simulation_backend(description: RigDescription) -> type[RigSimulation] | None:
    """The simulation backend ``description`` chooses, or None for real instruments.

    Raises
    ------
    UserInputError
        The backend is not installed, cannot be loaded or is not a :class:`RigSimulation` (one line naming the
        rig file's field).
    """
    choice = description.simulation
    if choice is None:
        return None
    name, field = choice
    return entry_point_class(
        SIMULATION_ROLE,
        name,
        RigSimulation,
        f"{description.path}: {field}",
        missing=f"the simulated instruments ({name!r}) are not installed",
        registrant="ornitail.simulated_instruments and other packages",
    )
