"""Request/reply over a serial port with newline-terminated ASCII lines (fan, strut, motor).

Each command is one line (``RPM 1200\\n``); each reply is one line: ``OK``, a value
(``RPM 1187.3``) or ``ERR <reason>``. The connection is locked so that a GUI and a sweep can share
one instrument. Port failures and silence raise :class:`InstrumentDisconnected`, ``ERR`` replies
:class:`InstrumentReplyError`, both naming the instrument.

The port is opened exclusively (a lock file naming the holder and pyserial's ``exclusive=True``; another
process gets :class:`InstrumentInUse`), then a newline ends any command a crashed host left half-written and
whatever the instrument still sends (a late reply) is drained before the first command.
"""

from __future__ import annotations

import termios
import threading
import time

import serial

from ornitail.acquisition.exclusive_locks import ExclusiveLock
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.serial_port_access import (
    close_quietly,
    drain_until_quiet,
    open_serial_exclusively,
    printable_excerpt,
)

DEFAULT_LINE_BAUD = 115_200
OPEN_QUIET_S = 0.1
"""On open, the line must stay quiet this long before the first command, s."""
OPEN_DRAIN_LIMIT_S = 2.0
"""On open, give up draining (the instrument keeps talking) after this long, s."""


class LineInstrumentConnection:
    """One ASCII line-protocol instrument on ``port``.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    name : str
        Instrument name used in error messages.
    baud : int
        Line rate, baud.
    reply_timeout_s : float
        How long to wait for a reply line, s.
    """

    def __init__(
        self, port: str, *, name: str, baud: int = DEFAULT_LINE_BAUD, reply_timeout_s: float = 1.0
    ) -> None:
        self.port = port
        self.name = name
        self.baud = baud
        self.reply_timeout_s = reply_timeout_s
        self._serial: serial.Serial | None = None
        self._port_lock: ExclusiveLock | None = None
        self._lock = threading.Lock()

    def open(self) -> None:
        """Open the port exclusively and drain it (InstrumentInUse, InstrumentDisconnected if it cannot)."""
        self._serial, self._port_lock = open_serial_exclusively(self.port, self.baud, self.name)
        try:
            self.discard_pending_input()
        except BaseException:
            self.close()
            raise

    def discard_pending_input(self) -> int:
        """End a half-written command line, drain until quiet (bounded); return the bytes discarded."""
        port = self._serial
        if port is None:
            raise InstrumentDisconnected(self.name, f"port {self.port} is not open")
        try:
            port.write(b"\n")
            drained = drain_until_quiet(port, quiet_s=OPEN_QUIET_S, limit_s=OPEN_DRAIN_LIMIT_S)
            port.reset_input_buffer()
        except (OSError, termios.error) as error:
            raise InstrumentDisconnected(self.name, f"port {self.port} failed: {error}") from None
        if not drained.quiet:
            raise InstrumentDisconnected(
                self.name,
                f"port {self.port} kept sending data for {OPEN_DRAIN_LIMIT_S:g} s "
                f"({drained.bytes_discarded} bytes) instead of waiting for a command",
            )
        return drained.bytes_discarded

    def close(self) -> None:
        """Close the port and release its lock; safe to call twice."""
        serial_port, self._serial = self._serial, None
        port_lock, self._port_lock = self._port_lock, None
        close_quietly(serial_port, port_lock)

    @property
    def is_open(self) -> bool:
        """True between open() and close()."""
        return self._serial is not None

    def query(self, command: str) -> str:
        """Send ``command`` and return the reply line without its newline.

        Raises
        ------
        InstrumentReplyError
            The instrument answered ``ERR <reason>``.
        InstrumentDisconnected
            The port failed or no full line arrived within ``reply_timeout_s``.
        """
        if self._serial is None:
            raise InstrumentDisconnected(self.name, f"port {self.port} is not open")
        with self._lock:
            try:
                # A reply left over from an exchange cut short (a timeout, an abort between write and read)
                # would otherwise be read as this command's answer, and every later one would be off by one.
                self._serial.reset_input_buffer()
                self._serial.write(command.encode("ascii") + b"\n")
                reply = b""
                deadline = time.monotonic() + self.reply_timeout_s
                while not reply.endswith(b"\n") and time.monotonic() < deadline:
                    reply += self._serial.read_until(b"\n")
            except (OSError, termios.error) as error:  # termios.error: flushing a vanished port
                raise InstrumentDisconnected(
                    self.name, f"port {self.port} failed: {error}"
                ) from None
        if not reply.endswith(b"\n"):
            raise InstrumentDisconnected(
                self.name,
                f"no reply to {command!r} within {self.reply_timeout_s:g} s on {self.port}",
            )
        text = reply.decode("ascii", errors="replace").strip()
        if text.startswith("ERR"):
            raise InstrumentReplyError(
                self.name,
                f"refused {command!r}: {printable_excerpt(text[3:].strip(), quote=False)}",
            )
        return text

    def command(self, command: str) -> None:
        """Send a set command and require the reply ``OK``."""
        reply = self.query(command)
        if reply != "OK":
            raise InstrumentReplyError(
                self.name, f"expected OK to {command!r}, got {printable_excerpt(reply)}"
            )

    def query_value(self, command: str, keyword: str) -> float:
        """Send a query such as ``RPM?`` and return the number of the reply ``RPM <value>``."""
        reply = self.query(command)
        words = reply.split()
        try:
            if len(words) != 2 or words[0] != keyword:
                raise ValueError
            return float(words[1])
        except ValueError:
            raise InstrumentReplyError(
                self.name,
                f"expected '{keyword} <number>' to {command!r}, got {printable_excerpt(reply)}",
            ) from None
