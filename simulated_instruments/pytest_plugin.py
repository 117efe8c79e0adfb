"""pytest fixtures for a simulated tunnel rig and each simulated instrument (no hardware needed).

Registered as the ``pytest11`` entry point ``ornitail``, so any project with ornitail installed can
use them in its own sweep-script tests::

    def test_my_sweep(simulated_rig):
        simulated_rig.set_tunnel_velocity(3.0)
        ...

Fixtures
--------
simulated_time_scale
    Simulated seconds per wall second for the actuators and the rig (default 20; override the
    fixture or pass ``--ornitail-time-scale``).
simulated_daq_time_scale
    Time scale of the DAQ board's sample clock (default 1: a faster clock multiplies the data rate).
simulated_clock, simulated_tunnel_signals
    The shared clock and the lock-guarded ``TunnelSignalSource`` (seed 0, 10 kHz).
simulated_daq, simulated_netcanoem, simulated_fan, simulated_strut, simulated_motor
    Running simulators; connect a driver to ``.port_path`` (serial) or ``.channel`` (virtual CAN).
simulated_rig_path, simulated_rig
    The rig file (default: the packaged simulated rig) and a connected :class:`Rig` on it, closed
    (safe state) after the test.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.simulated_instruments.actuators import (
    SimulatedFlappingMotor,
    SimulatedStrutActuator,
    SimulatedTunnelFan,
)
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.daq_board import SimulatedDaqBoard
from ornitail.simulated_instruments.netcanoem_board import SimulatedNetCanOemBoard
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

PACKAGED_DATA = DEFAULT_RIG_FILE.parent
PACKAGED_CALIBRATION = PACKAGED_DATA / "calibration" / "FT8884.cal"
PACKAGED_TUNNEL_TABLE = PACKAGED_DATA / "tunnel_table.csv"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("ornitail")
    group.addoption(
        "--ornitail-time-scale",
        type=float,
        default=None,
        help="simulated seconds per wall second for ornitail's simulated rig fixtures (default 20)",
    )


@pytest.fixture
def simulated_time_scale(request: pytest.FixtureRequest) -> float:
    """Time scale of the simulated actuators and rig (``--ornitail-time-scale``, default 20)."""
    option = request.config.getoption("--ornitail-time-scale")
    return 20.0 if option is None else float(option)


@pytest.fixture
def simulated_daq_time_scale() -> float:
    """Time scale of the simulated DAQ board's sample clock (default 1, real time)."""
    return 1.0


@pytest.fixture
def simulated_clock(simulated_time_scale: float) -> SimulatedClock:
    """A clock at ``simulated_time_scale``."""
    return SimulatedClock(simulated_time_scale)


@pytest.fixture
def simulated_tunnel_signals() -> SharedTunnelSignals:
    """A fresh tunnel signal source (seed 0, 10 kHz) shared by a test's simulated instruments."""
    return SharedTunnelSignals.from_simulator(seed=0, sample_rate_hz=10_000.0)


@pytest.fixture
def simulated_daq(
    simulated_tunnel_signals: SharedTunnelSignals, simulated_daq_time_scale: float
) -> Iterator[SimulatedDaqBoard]:
    """A running simulated ORNI-DAQ9 board; open ``SerialDaqDriver(board.port_path)``."""
    board = SimulatedDaqBoard(simulated_tunnel_signals, SimulatedClock(simulated_daq_time_scale))
    with board:
        yield board


@pytest.fixture
def simulated_netcanoem(
    simulated_tunnel_signals: SharedTunnelSignals, simulated_clock: SimulatedClock
) -> Iterator[SimulatedNetCanOemBoard]:
    """A running simulated NETCANOEM board on a fresh virtual CAN channel (``board.channel``)."""
    calibration = AtiCalibration.from_file(PACKAGED_CALIBRATION)
    board = SimulatedNetCanOemBoard(
        simulated_tunnel_signals,
        simulated_clock,
        calibration.matrix_si,
        channel=f"ornitail-test-{uuid.uuid4().hex[:8]}",
        serial_number=calibration.serial,
    )
    with board:
        yield board


@pytest.fixture
def simulated_fan(
    simulated_clock: SimulatedClock, simulated_tunnel_signals: SharedTunnelSignals
) -> Iterator[SimulatedTunnelFan]:
    """A running simulated fan controller (packaged tunnel table)."""
    with SimulatedTunnelFan(
        simulated_clock,
        simulated_tunnel_signals,
        TunnelVelocityTable.from_csv(PACKAGED_TUNNEL_TABLE),
    ) as fan:
        yield fan


@pytest.fixture
def simulated_strut(
    simulated_clock: SimulatedClock, simulated_tunnel_signals: SharedTunnelSignals
) -> Iterator[SimulatedStrutActuator]:
    """A running simulated strut pitch actuator (not homed at power-on)."""
    with SimulatedStrutActuator(simulated_clock, simulated_tunnel_signals) as strut:
        yield strut


@pytest.fixture
def simulated_motor(
    simulated_clock: SimulatedClock, simulated_tunnel_signals: SharedTunnelSignals
) -> Iterator[SimulatedFlappingMotor]:
    """A running simulated flapping-motor controller."""
    with SimulatedFlappingMotor(simulated_clock, simulated_tunnel_signals) as motor:
        yield motor


@pytest.fixture
def simulated_rig_path() -> Path:
    """The rig file ``simulated_rig`` loads (override to test your own simulated rig file)."""
    return DEFAULT_RIG_FILE


@pytest.fixture
def simulated_rig(simulated_rig_path: Path, simulated_time_scale: float) -> Iterator[Rig]:
    """A connected simulated rig (strut homed), closed with motor and fan in safe state after."""
    with Rig.from_file(simulated_rig_path, time_scale=simulated_time_scale) as rig:
        yield rig
