"""Request/reply with one Modbus RTU server (a drive) on a serial port: read holding registers, write one register.

The port is opened exclusively like every instrument's (:func:`open_serial_exclusively`) and drained until quiet.
Each exchange is locked (a GUI and a sweep may share the drive), starts no sooner than the RTU silent interval t3.5
after the previous reply, from an empty input buffer, and waits for a whole reply (its length follows from its first
bytes). Failures raise the project's instrument errors, one line
naming the instrument, the port and what failed: silence or a failed port :class:`InstrumentDisconnected`; a bad
CRC, a reply from another unit or function, or a Modbus exception :class:`InstrumentReplyError`.
"""

from __future__ import annotations

import termios
import threading
import time

import serial

from ornitail.acquisition.exclusive_locks import ExclusiveLock
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.modbus_rtu import (
    EXCEPTION_FLAG,
    READ_HOLDING_REGISTERS,
    WRITE_SINGLE_REGISTER,
    crc_ok,
    exception_text,
    read_holding_registers_request,
    reply_length,
    silent_interval_s,
    write_single_register_request,
)
from ornitail.acquisition.serial_port_access import (
    close_quietly,
    drain_until_quiet,
    open_serial_exclusively,
)

OPEN_QUIET_S = 0.1
"""On open, the line must stay quiet this long before the first request, s."""
OPEN_DRAIN_LIMIT_S = 2.0
"""On open, give up draining after this long, s."""
PARITIES = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD}


class ModbusRtuConnection:
    """One Modbus RTU server ``unit_id`` on ``port``.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    name : str
        Instrument name used in error messages.
    unit_id : int
        The server's address, 1..247.
    baud : int
        Line rate, bit/s.
    parity : str
        ``"N"``, ``"E"`` or ``"O"`` (default N with 2 stop bits, the default map's drive setting; the serial-line
        specification's own default is E with 1).
    stop_bits : int
        1 or 2.
    reply_timeout_s : float
        How long to wait for a whole reply, s.
    """

    def __init__(
        self,
        port: str,
        *,
        name: str,
        unit_id: int,
        baud: int,
        parity: str = "N",
        stop_bits: int = 2,
        reply_timeout_s: float = 1.0,
    ) -> None:
        self.port = port
        self.name = name
        self.unit_id = unit_id
        self.baud = baud
        self.parity = parity
        self.stop_bits = stop_bits
        self.reply_timeout_s = reply_timeout_s
        self._serial: serial.Serial | None = None
        self._port_lock: ExclusiveLock | None = None
        self._lock = threading.Lock()
        self._line_free_at = 0.0  # monotonic time after which the next request may start

    @property
    def is_open(self) -> bool:
        """True between open() and close()."""
        return self._serial is not None

    def open(self) -> None:
        """Open the port exclusively with the rig file's framing and drain it."""
        self._serial, self._port_lock = open_serial_exclusively(
            self.port,
            self.baud,
            self.name,
            parity=PARITIES[self.parity],
            stop_bits=self.stop_bits,
        )
        try:
            drained = drain_until_quiet(
                self._serial, quiet_s=OPEN_QUIET_S, limit_s=OPEN_DRAIN_LIMIT_S
            )
            self._serial.reset_input_buffer()
            if not drained.quiet:
                raise InstrumentDisconnected(
                    self.name,
                    f"port {self.port} kept sending data for {OPEN_DRAIN_LIMIT_S:g} s instead of waiting "
                    "for a Modbus request",
                )
        except (OSError, termios.error, serial.SerialException) as error:
            self.close()
            raise InstrumentDisconnected(self.name, f"port {self.port} failed: {error}") from None
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Close the port and release its lock; safe to call twice."""
        serial_port, self._serial = self._serial, None
        port_lock, self._port_lock = self._port_lock, None
        close_quietly(serial_port, port_lock)

    def read_registers(self, address: int, count: int) -> list[int]:
        """Read ``count`` holding registers from ``address`` (function 0x03); 16-bit unsigned values."""
        what = (
            f"read of register 0x{address:04X}"
            if count == 1
            else f"read of registers 0x{address:04X}..0x{address + count - 1:04X}"
        )
        reply = self._exchange(
            read_holding_registers_request(self.unit_id, address, count),
            READ_HOLDING_REGISTERS,
            what,
        )
        if reply[2] != 2 * count:
            raise InstrumentReplyError(
                self.name,
                f"reply to {what} on {self.port} holds {reply[2]} bytes, not {2 * count}",
            )
        data = reply[3:-2]
        return [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]

    def write_register(self, address: int, value: int) -> None:
        """Write ``value`` to holding register ``address`` (function 0x06) and check the echo."""
        what = f"write of {value} to register 0x{address:04X}"
        request = write_single_register_request(self.unit_id, address, value)
        reply = self._exchange(request, WRITE_SINGLE_REGISTER, what)
        if reply != request:
            raise InstrumentReplyError(
                self.name,
                f"reply to {what} on {self.port} is not its echo: {reply.hex(' ')}",
            )

    def _exchange(self, request: bytes, function: int, what: str) -> bytes:
        port = self._serial
        if port is None:
            raise InstrumentDisconnected(self.name, f"port {self.port} is not open")
        with self._lock:
            try:
                # The frame before must be followed by t3.5 of silence, or the drive joins the two frames.
                time.sleep(max(0.0, self._line_free_at - time.monotonic()))
                port.reset_input_buffer()  # a late reply to an earlier request must not answer this one
                port.write(request)
                reply = self._read_reply(port)
                self._line_free_at = time.monotonic() + silent_interval_s(self.baud)
            except (OSError, termios.error, serial.SerialException) as error:
                raise InstrumentDisconnected(
                    self.name, f"port {self.port} failed during {what}: {error}"
                ) from None
        if reply is None:
            raise InstrumentDisconnected(
                self.name,
                f"no reply to {what} (unit {self.unit_id}) within {self.reply_timeout_s:g} s on "
                f"{self.port}",
            )
        if not crc_ok(reply):
            raise InstrumentReplyError(
                self.name, f"reply to {what} on {self.port} has a bad CRC: {reply.hex(' ')}"
            )
        if reply[0] != self.unit_id:
            raise InstrumentReplyError(
                self.name,
                f"reply to {what} on {self.port} came from unit {reply[0]}, not {self.unit_id}",
            )
        if reply[1] == function | EXCEPTION_FLAG:
            raise InstrumentReplyError(
                self.name, f"refused {what} on {self.port}: {exception_text(reply[2])}"
            )
        if reply[1] != function:
            raise InstrumentReplyError(
                self.name,
                f"reply to {what} on {self.port} has function code 0x{reply[1]:02X}, "
                f"not 0x{function:02X}",
            )
        return reply

    def _read_reply(self, port: serial.Serial) -> bytes | None:
        """A whole reply, or None if it did not arrive within ``reply_timeout_s``."""
        reply = b""
        deadline = time.monotonic() + self.reply_timeout_s
        while time.monotonic() < deadline:
            wanted = reply_length(reply)
            if wanted is not None and len(reply) >= wanted:
                return reply[:wanted]
            missing = (3 if wanted is None else wanted) - len(reply)
            reply += port.read(max(1, missing))
        wanted = reply_length(reply)
        return reply[:wanted] if wanted is not None and len(reply) >= wanted else None
