"""Starts the simulated instruments a rig file names, each on a real transport (ptys, virtual CAN).

All share one :class:`SimulatedClock` (so one time scale) and one :class:`SharedTunnelSignals`:
the fan, strut and motor set its operating point, the balance board (DAQ or NETCANOEM) reads it.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass

from ornitail.acquisition.rig_file import RigDescription
from ornitail.acquisition.shared_signal_source import SharedTunnelSignals
from ornitail.acquisition.simulated_actuators import (
    SimulatedFlappingMotor,
    SimulatedStrutActuator,
    SimulatedTunnelFan,
)
from ornitail.acquisition.simulated_clock import SimulatedClock
from ornitail.acquisition.simulated_daq_board import SimulatedDaqBoard
from ornitail.acquisition.simulated_netcanoem_board import SimulatedNetCanOemBoard
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tunnel_table import TunnelVelocityTable

SIMULATION_SAMPLE_RATE_HZ = 10_000.0


@dataclass
class SimulatedRigInstruments:
    """The running simulators of one rig; ``daq_board`` or ``netcanoem_board`` is None by route."""

    clock: SimulatedClock
    signals: SharedTunnelSignals
    fan: SimulatedTunnelFan
    strut: SimulatedStrutActuator
    motor: SimulatedFlappingMotor
    daq_board: SimulatedDaqBoard | None
    netcanoem_board: SimulatedNetCanOemBoard | None
    can_channel: str | None

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
            fan = SimulatedTunnelFan(clock, signals, tunnel_table).start()
            started.append(fan)
            strut = SimulatedStrutActuator(clock, signals).start()
            started.append(strut)
            motor = SimulatedFlappingMotor(
                clock, signals, gear_ratio=description.gear_ratio
            ).start()
            started.append(motor)
            daq_board = netcanoem_board = can_channel = None
            if description.balance_route == "serial_daq":
                daq_board = SimulatedDaqBoard(
                    signals,
                    clock,
                    sample_rate_hz=description.serial_daq.sample_rate_hz,
                    baud=description.serial_daq.baud,
                ).start()
                started.append(daq_board)
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
        except BaseException:
            for simulator in reversed(started):
                simulator.close()
            raise
        return cls(clock, signals, fan, strut, motor, daq_board, netcanoem_board, can_channel)

    def close(self) -> None:
        """Stop every simulator."""
        for simulator in (self.daq_board, self.netcanoem_board, self.motor, self.strut, self.fan):
            if simulator is not None:
                simulator.close()
