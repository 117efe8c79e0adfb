"""Starts the simulated instruments a rig file names, each on a real transport (ptys, virtual CAN).

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

import numpy as np

from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.modbus_vfd_driver import MODBUS_VFD
from ornitail.acquisition.orni_line_backends import ORNI_LINE
from ornitail.acquisition.rig_file import RigDescription
from ornitail.acquisition.shared_signal_source import SharedTunnelSignals
from ornitail.acquisition.simulated_actuators import (
    SimulatedFlappingMotor,
    SimulatedStrutActuator,
    SimulatedTunnelFan,
)
from ornitail.acquisition.simulated_aux_daq_board import SimulatedAuxDaqBoard
from ornitail.acquisition.simulated_clock import SimulatedClock
from ornitail.acquisition.simulated_daq_board import SimulatedDaqBoard
from ornitail.acquisition.simulated_device import SimulatedDevice
from ornitail.acquisition.simulated_modbus_vfd import SimulatedModbusVfd
from ornitail.acquisition.simulated_netcanoem_board import SimulatedNetCanOemBoard
from ornitail.acquisition.simulated_netft import SimulatedNetFt
from ornitail.acquisition.simulated_zaber_strut import SimulatedZaberStrut
from ornitail.acquisition.zaber_strut_driver import ZABER_ASCII
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tunnel_table import TunnelVelocityTable

SIMULATION_SAMPLE_RATE_HZ = 10_000.0
NETFT_RATE_ERROR_PPM = -40.0
"""The simulated Net F/T's crystal: 40 ppm slow (the auxiliary board's runs 80 ppm fast), so that aligning the two
needs both counter models."""


@dataclass
class SimulatedRigInstruments:
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
            seed=description.seed, sample_rate_hz=SIMULATION_SAMPLE_RATE_HZ
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

    def actuator_ports(self) -> dict[str, str]:
        """The pty of each actuator that has a simulator, by role (``{"fan": "/dev/pts/5", ...}``)."""
        simulators = {"fan": self.fan, "strut": self.strut, "motor": self.motor}
        return {role: sim.port_path for role, sim in simulators.items() if sim is not None}

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
