"""Simulated variable-frequency drive: a Modbus RTU server behind a pty, driving the tunnel simulator.

It answers 0x03 (read holding registers) and 0x06 (write single register) at its unit id with the register map of
:class:`ModbusVfdSettings`, like a drive: the output frequency ramps (``ramp_hz_per_s``) towards the frequency set
point while running and towards 0 when stopped, and publishes the tunnel velocity through :class:`FanSpeedMap`.
Refusals are Modbus exception replies: an unmapped or read-only register 02 (illegal data address), a set point
above ``max_frequency_hz`` or an unknown control value 03 (illegal data value), another function code 01 (illegal
function). A frame with a bad CRC, or for another unit, gets no reply (as the serial-line specification requires).
Frames are whole 0x03/0x06 requests (8 bytes); bytes that make no such frame are dropped once the line is quiet
for one tick (the RTU end-of-frame silence).
"""

from __future__ import annotations

import threading

from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.modbus_rtu import (
    MAX_READ_REGISTERS,
    READ_HOLDING_REGISTERS,
    WRITE_SINGLE_REGISTER,
    crc_ok,
    exception_reply,
    read_registers_reply,
    request_length,
)
from ornitail.acquisition.modbus_vfd_driver import ModbusVfdSettings
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.device import SimulatedDevice
from ornitail.simulated_instruments.line_instrument import first_order_step
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

ILLEGAL_FUNCTION, ILLEGAL_DATA_ADDRESS, ILLEGAL_DATA_VALUE = 0x01, 0x02, 0x03


class SimulatedModbusVfd(SimulatedDevice):
    """A drive on a pty; the driver opens :attr:`port_path`.

    Parameters
    ----------
    clock : SimulatedClock
        Shared simulated time.
    signals : SharedTunnelSignals
        The tunnel simulator whose velocity it sets.
    speed_map : FanSpeedMap
        Tunnel table with ``fan_rpm_per_hz``.
    settings : ModbusVfdSettings
        Unit id and register map it serves.
    max_frequency_hz : float
        Highest set point it accepts, Hz (a drive's maximum output frequency parameter).
    ramp_hz_per_s : float
        Acceleration and deceleration of the output frequency, Hz/s.
    """

    def __init__(
        self,
        clock: SimulatedClock,
        signals: SharedTunnelSignals,
        speed_map: FanSpeedMap,
        settings: ModbusVfdSettings,
        *,
        max_frequency_hz: float = 60.0,
        ramp_hz_per_s: float = 10.0,
        tick_period_s: float = 0.005,
    ) -> None:
        self.clock = clock
        self.signals = signals
        self.speed_map = speed_map
        self.settings = settings
        self.max_frequency_hz = max_frequency_hz
        self.ramp_hz_per_s = ramp_hz_per_s
        self.tick_period_s = tick_period_s
        self.running = False
        self.setpoint_counts = 0
        self.output_hz = 0.0
        self.frames_with_bad_crc = 0
        self._pty = PseudoTerminalPair.open_raw()
        self.port_path = self._pty.slave_path
        self._state_lock = threading.Lock()
        self._unplug_requested = threading.Event()
        self.unplugged = False
        self._prepare_thread("simulated Modbus VFD")
        self._last_time_s = clock.now_s()
        self._publish()

    # -- physics ----------------------------------------------------------------------------
    @property
    def setpoint_hz(self) -> float:
        """The frequency set point, Hz."""
        return self.setpoint_counts * self.settings.frequency_scale_hz_per_count

    def _publish(self) -> None:
        self.signals.set_operating_point(
            tunnel_velocity_m_s=self.speed_map.velocity_for_frequency_hz(self.output_hz)
        )

    def advance(self, dt_s: float) -> None:
        """Ramp the output frequency by ``dt_s`` simulated seconds."""
        target = self.setpoint_hz if self.running else 0.0
        previous = self.output_hz
        self.output_hz = first_order_step(self.output_hz, target, dt_s, 0.0, self.ramp_hz_per_s)
        if self.output_hz != previous:
            self._publish()

    # -- protocol ---------------------------------------------------------------------------
    def _read(self, address: int) -> int | None:
        scale = self.settings.frequency_scale_hz_per_count
        registers = {
            self.settings.control_register: (
                self.settings.run_command if self.running else self.settings.stop_command
            ),
            self.settings.frequency_setpoint_register: self.setpoint_counts,
            self.settings.frequency_command_register: self.setpoint_counts,
            self.settings.output_frequency_register: round(self.output_hz / scale),
        }
        return registers.get(address)

    def _write(self, address: int, value: int) -> int | None:
        """Carry out a write; None if done, else the exception code."""
        settings = self.settings
        if address == settings.control_register:
            if value == settings.run_command:
                self.running = True
            elif value == settings.stop_command:
                self.running = False
            else:
                return ILLEGAL_DATA_VALUE
            return None
        if address == settings.frequency_setpoint_register:
            if value * settings.frequency_scale_hz_per_count > self.max_frequency_hz + 1e-9:
                return ILLEGAL_DATA_VALUE
            self.setpoint_counts = value
            return None
        return ILLEGAL_DATA_ADDRESS

    def handle(self, frame: bytes) -> bytes | None:
        """Answer one request frame (CRC already checked); None when it gets no reply."""
        unit_id, function = frame[0], frame[1]
        if unit_id != self.settings.unit_id:
            return None
        if function == READ_HOLDING_REGISTERS:
            address = int.from_bytes(frame[2:4], "big")
            count = int.from_bytes(frame[4:6], "big")
            if not 1 <= count <= MAX_READ_REGISTERS:
                return exception_reply(unit_id, function, ILLEGAL_DATA_VALUE)
            values = [self._read(address + offset) for offset in range(count)]
            if any(value is None for value in values):
                return exception_reply(unit_id, function, ILLEGAL_DATA_ADDRESS)
            return read_registers_reply(unit_id, values)  # type: ignore[arg-type]
        if function == WRITE_SINGLE_REGISTER:
            address = int.from_bytes(frame[2:4], "big")
            value = int.from_bytes(frame[4:6], "big")
            code = self._write(address, value)
            return frame if code is None else exception_reply(unit_id, function, code)
        return exception_reply(unit_id, function, ILLEGAL_FUNCTION)

    def _frames(self, buffer: bytes, line_quiet: bool) -> tuple[list[bytes], bytes]:
        """Split whole frames off ``buffer``; what is left once the line is quiet is one (odd) frame."""
        frames = []
        while True:
            wanted = request_length(buffer)
            if wanted is not None and len(buffer) >= wanted:
                frames.append(buffer[:wanted])
                buffer = buffer[wanted:]
                continue
            if buffer and line_quiet:
                frames.append(buffer)
                buffer = b""
            return frames, buffer

    # -- thread -----------------------------------------------------------------------------
    def unplug(self) -> None:
        """Close the pty master, as a pulled cable."""
        self._unplug_requested.set()

    def _close_transport(self) -> None:
        self._pty.close()

    def _run(self) -> None:
        buffer = b""
        outgoing = b""
        while not self._closing.is_set():
            if self._unplug_requested.is_set():
                self.unplugged = True
                self._pty.close_master()
                return
            incoming = self._pty.read_available(self.tick_period_s)
            if incoming is None:
                return
            now_s = self.clock.now_s()
            with self._state_lock:
                self.advance(now_s - self._last_time_s)
                self._last_time_s = now_s
                frames, buffer = self._frames(buffer + incoming, line_quiet=not incoming)
                for frame in frames:
                    if not crc_ok(frame):
                        self.frames_with_bad_crc += 1
                        continue
                    reply = self.handle(frame)
                    if reply is not None:
                        outgoing += reply
            while outgoing:
                written = self._pty.write_some(outgoing)
                if written == 0:
                    break
                outgoing = outgoing[written:]
