"""Starts the simulated instruments a rig file names, each on a real transport (ptys, virtual CAN).

:class:`SimulatedRigInstruments` is the simulation backend ``simulated`` of the rig (``[rig].simulated = true``;
entry point ``rig.simulated`` in the group ``ornitail.instruments``, :mod:`ornitail.acquisition.rig_simulation`).

All share one :class:`SimulatedClock` (so one time scale) and one :class:`SharedTunnelSignals`:
the fan, strut and motor set its operating point, the balance (DAQ board, NETCANOEM or Net F/T) reads it, so
every balance measures the same simulated vehicle.
Each actuator's simulator is the one of its rig-file backend: the ORNI line instruments for ``orni_line``, a Modbus
RTU drive for ``modbus_vfd``, a Zaber ASCII controller for ``zaber_ascii``. A third-party backend has no simulator
here: its driver is given the rig file's port.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.modbus_vfd_driver import MODBUS_VFD
from ornitail.acquisition.orni_line_backends import ORNI_LINE
from ornitail.acquisition.rig_file import RigDescription
from ornitail.acquisition.rig_simulation import RigSimulation
from ornitail.acquisition.zaber_strut_driver import ZABER_ASCII
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.hotwire_laws import HotwireLaw, load_hotwire_law
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.sim.configuration import study_configuration
from ornitail.simulated_instruments.actuators import (
    SimulatedFlappingMotor,
    SimulatedStrutActuator,
    SimulatedTunnelFan,
)
from ornitail.simulated_instruments.aux_daq_board import SimulatedAuxDaqBoard
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.daq_board import SimulatedDaqBoard
from ornitail.simulated_instruments.device import SimulatedDevice
from ornitail.simulated_instruments.modbus_vfd import SimulatedModbusVfd
from ornitail.simulated_instruments.netcanoem_board import SimulatedNetCanOemBoard
from ornitail.simulated_instruments.netft import SimulatedNetFt
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals
from ornitail.simulated_instruments.zaber_strut import SimulatedZaberStrut

SIMULATION_SAMPLE_RATE_HZ = 10_000.0
NETFT_RATE_ERROR_PPM = -40.0
"""The simulated Net F/T's crystal: 40 ppm slow (the auxiliary board's runs 80 ppm fast), so that aligning the two
needs both counter models."""
HOTWIRE_LAW_FILE = Path(__file__).parent / "data" / "hotwire_law.toml"
"""King's law of the simulated hot-wire (the simulator's own, :mod:`ornitail.sim.instruments`)."""


def simulated_hotwire_law() -> HotwireLaw:
    """The law of the simulated rig's hot-wire."""
    return load_hotwire_law(HOTWIRE_LAW_FILE)


@dataclass
class SimulatedRigInstruments(RigSimulation):
    """The running simulators of one rig; ``daq_board``, ``netcanoem_board`` or ``netft`` is None by route, an
    actuator's simulator None when its backend has none here (a third party's)."""

    clock: SimulatedClock
    signals: SharedTunnelSignals
    fan: SimulatedTunnelFan | SimulatedModbusVfd | None
    strut: SimulatedStrutActuator | SimulatedZaberStrut | None
    motor: SimulatedFlappingMotor | None
    daq_board: SimulatedDaqBoard | None
    netcanoem_board: SimulatedNetCanOemBoard | None
    can_channel: str | None
    aux_daq_board: SimulatedAuxDaqBoard | None = None
    """The ORNI-DAQ9 beside the CAN or Net F/T balance (``[balance.aux_daq]``), on a clock of its own, else None."""
    netft: SimulatedNetFt | None = None
    """The Net F/T on the loopback (route ``netft``), on a crystal of its own, else None."""

    @classmethod
    def start(
        cls,
        description: RigDescription,
        calibration: AtiCalibration,
        tunnel_table: TunnelVelocityTable,
    ) -> SimulatedRigInstruments:
        """Start every simulator of ``description`` (a unique virtual CAN channel per rig)."""
        clock = SimulatedClock(description.time_scale)
        signals = SharedTunnelSignals.from_simulator(
            seed=description.seed, sample_rate_hz=SIMULATION_SAMPLE_RATE_HZ, clock=clock.now_s
        )
        started: list = []
        try:
            fan = _fan_simulator(description, clock, signals, tunnel_table)
            started.append(fan)
            strut = _strut_simulator(description, clock, signals)
            started.append(strut)
            motor = None
            if description.motor.backend == ORNI_LINE:
                motor = SimulatedFlappingMotor(clock, signals, gear_ratio=description.gear_ratio)
            started.append(motor)
            started = [simulator.start() for simulator in started if simulator is not None]
            daq_board = netcanoem_board = can_channel = aux_daq_board = netft = None
            if description.balance_route == "serial_daq":
                daq_board = SimulatedDaqBoard(
                    signals,
                    clock,
                    sample_rate_hz=description.serial_daq.sample_rate_hz,
                    baud=description.serial_daq.baud,
                ).start()
                started.append(daq_board)
            elif description.netft is not None:
                netft = SimulatedNetFt(
                    _loads_of(signals, calibration),
                    rate_hz=description.netft.rdt_rate_hz,
                    clock=clock.now_s,
                    rate_error_ppm=NETFT_RATE_ERROR_PPM,
                ).start()
                started.append(netft)
            else:
                can_channel = f"{description.can.channel}-{uuid.uuid4().hex[:8]}"
                netcanoem_board = SimulatedNetCanOemBoard(
                    signals,
                    clock,
                    calibration.matrix_si,
                    channel=can_channel,
                    base_id=description.can.base_id,
                    serial_number=calibration.serial[:8],
                ).start()
                started.append(netcanoem_board)
            if description.aux_daq is not None:
                aux_daq_board = SimulatedAuxDaqBoard(
                    signals,
                    clock,
                    sample_rate_hz=description.aux_daq.sample_rate_hz,
                    baud=description.aux_daq.baud,
                ).start()
                started.append(aux_daq_board)
        except BaseException:
            for simulator in reversed(started):
                if simulator is not None:
                    simulator.close()
            raise
        return cls(
            clock,
            signals,
            fan,
            strut,
            motor,
            daq_board,
            netcanoem_board,
            can_channel,
            aux_daq_board,
            netft,
        )

    @classmethod
    def hotwire_law(cls) -> HotwireLaw:
        """The law of the simulated hot-wire."""
        return simulated_hotwire_law()

    @property
    def time_scale(self) -> float:
        """Rig seconds per wall second (the shared clock's)."""
        return self.clock.time_scale

    def now_s(self) -> float:
        """Rig time, s: the shared simulated clock."""
        return self.clock.now_s()

    def ports(self) -> dict[str, str]:
        """The pty of each simulator on a serial port, by role (``{"fan": "/dev/pts/5", ..., "daq": ...}``)."""
        simulators = {
            "fan": self.fan,
            "strut": self.strut,
            "motor": self.motor,
            "daq": self.daq_board,
            "aux_daq": self.aux_daq_board,
        }
        return {role: sim.port_path for role, sim in simulators.items() if sim is not None}

    def can_bus(self) -> tuple[str, str] | None:
        """python-can's virtual bus on the simulated NETCANOEM's channel (whatever ``[balance.can]`` says), or
        None when the rig has no CAN balance."""
        return None if self.can_channel is None else ("virtual", self.can_channel)

    def netft_address(self) -> tuple[str, int, int] | None:
        """The simulated Net F/T's loopback address, if the rig has one."""
        if self.netft is None:
            return None
        return self.netft.host, self.netft.rdt_port, self.netft.http_port

    def mount_vehicle(self, tail_id: str, x_h_m: float) -> None:
        """Put the study's vehicle with tail ``tail_id`` at ``x_h_m`` (m) on the simulated balance."""
        self.signals.mount_vehicle(study_configuration(tail_id, x_h_m * 1000.0))

    def set_tail_attached(self, tail_attached: bool) -> None:
        """Fit or remove the simulated vehicle's tail."""
        self.signals.set_operating_point(tail_attached=tail_attached)

    def close(self) -> None:
        """Stop every simulator."""
        simulators = (self.aux_daq_board, self.daq_board, self.netcanoem_board, self.netft)
        for simulator in (*simulators, self.motor, self.strut, self.fan):
            if simulator is not None:
                simulator.close()


def _loads_of(
    signals: SharedTunnelSignals, calibration: AtiCalibration
) -> Callable[[np.ndarray], np.ndarray]:
    """The Net F/T's loads: the shared gauge signals at the device's sample times through the sensor's calibration
    (N and N m in the sensor frame; the device applies its calibration to its own gauges)."""
    matrix_si = calibration.matrix_si

    def loads(times_s: np.ndarray) -> np.ndarray:
        return signals.samples_at_times(times_s)[:, :6] @ matrix_si.T

    return loads


def _fan_simulator(
    description: RigDescription,
    clock: SimulatedClock,
    signals: SharedTunnelSignals,
    tunnel_table: TunnelVelocityTable,
) -> SimulatedDevice | None:
    backend = description.fan.backend
    if backend == ORNI_LINE:
        return SimulatedTunnelFan(clock, signals, tunnel_table)
    if backend == MODBUS_VFD:
        settings = description.fan.settings
        return SimulatedModbusVfd(
            clock, signals, FanSpeedMap(tunnel_table, settings.fan_rpm_per_hz), settings
        )
    return None


def _strut_simulator(
    description: RigDescription, clock: SimulatedClock, signals: SharedTunnelSignals
) -> SimulatedDevice | None:
    backend = description.strut.backend
    if backend == ORNI_LINE:
        return SimulatedStrutActuator(clock, signals)
    if backend == ZABER_ASCII:
        return SimulatedZaberStrut(clock, signals, description.strut.settings)
    return None
