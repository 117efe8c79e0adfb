"""Opening an instrument's serial port exclusively, draining what a previous owner left in it, safe error text.

Every serial driver opens its port through :func:`open_serial_exclusively`: an advisory lock file per port (named
after the port's real path, see :mod:`exclusive_locks`; it names the holder in a refusal) and pyserial's
``exclusive=True`` (a ``flock`` on the device itself, taken before pyserial changes any line setting). Both are
released by the kernel when the process dies. :func:`drain_until_quiet` reads and discards bytes until the line
has been quiet for a while, bounded in time, so that a stream or a reply left over by a crashed host is never taken
for an answer. :func:`printable_excerpt` keeps binary bytes out of error messages.
"""

from __future__ import annotations

import contextlib
import errno
import os
import termios
import time
from dataclasses import dataclass

import serial

from ornitail.acquisition.exclusive_locks import ExclusiveLock, LockHeld, device_lock
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentInUse

EXCERPT_CHARACTERS = 60
"""Characters of an unexpected reply quoted in an error message."""


def printable_excerpt(
    data: bytes | str, limit: int = EXCERPT_CHARACTERS, *, quote: bool = True
) -> str:
    """A short, printable rendering of ``data`` for one-line messages (quoted unless ``quote`` is False);
    mostly binary data becomes a byte count."""
    raw = data.encode("latin-1", errors="replace") if isinstance(data, str) else bytes(data)
    text = raw.strip().decode("ascii", errors="replace")
    unprintable = sum(
        1 for character in text if not (character.isprintable() and character.isascii())
    )
    if unprintable > max(2, len(text) // 10):
        return f"{len(raw)} bytes of binary data"
    clean = "".join(c if c.isprintable() and c.isascii() else "?" for c in text)
    if len(clean) > limit:
        clean = clean[: limit - 3] + "..."
    shown = repr(clean) if quote else clean
    return shown + ("" if len(raw) <= limit else f" ({len(raw)} bytes)")


def _reason(error: BaseException) -> str:
    number = getattr(error, "errno", None)
    if isinstance(number, int) and number > 0:
        return os.strerror(number)
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def open_serial_exclusively(
    port: str,
    baud: int,
    instrument_name: str,
    *,
    timeout_s: float = 0.05,
    parity: str = serial.PARITY_NONE,
    stop_bits: int = 1,
) -> tuple[serial.Serial, ExclusiveLock | None]:
    """Open ``port`` for ``instrument_name`` with the port's lock file and pyserial's exclusive flag
    (8 data bits, ``parity`` as pyserial's ``"N"``/``"E"``/``"O"``, ``stop_bits`` 1 or 2).

    Raises
    ------
    InstrumentInUse
        Another process (or another connection of this one) has the port; the message names it.
    InstrumentDisconnected
        The port does not exist or cannot be opened (unplugged, wrong path, no permission).
    """
    lock: ExclusiveLock | None = device_lock(port) if os.path.exists(port) else None
    try:
        if lock is not None:  # no lock file for a port that is not there: the open below says so
            lock.acquire(detail=f"{instrument_name} on {port}")
    except LockHeld as held:
        holder = held.holder.describe() if held.holder else "another process"
        raise InstrumentInUse(
            instrument_name,
            f"port {port} is in use by {holder}; stop it or wait until it is done",
        ) from None
    except OSError:  # the lock folder is unusable: pyserial's own lock on the device still applies
        lock = None
    try:
        connection = serial.Serial(
            port,
            baud,
            parity=parity,
            stopbits=stop_bits,
            timeout=timeout_s,
            write_timeout=1.0,
            exclusive=True,
        )
    except (OSError, ValueError, termios.error) as error:  # termios.error: line settings refused
        if lock is not None:
            lock.release()
        if getattr(error, "errno", None) in (errno.EAGAIN, errno.EWOULDBLOCK):
            raise InstrumentInUse(
                instrument_name, f"port {port} is locked by another program; stop it first"
            ) from None
        raise InstrumentDisconnected(
            instrument_name, f"cannot open port {port}: {_reason(error)}"
        ) from None
    return connection, lock


@dataclass(frozen=True)
class DrainResult:
    """What :func:`drain_until_quiet` discarded: bytes, whether ``marker`` was seen, whether the line went quiet."""

    bytes_discarded: int
    marker_seen: bool
    quiet: bool


def drain_until_quiet(
    connection: serial.Serial,
    *,
    quiet_s: float,
    limit_s: float,
    marker: bytes | None = None,
    quiet_after_marker_s: float | None = None,
) -> DrainResult:
    """Read and discard until nothing arrived for ``quiet_s`` (``quiet_after_marker_s`` once ``marker`` was
    seen), or until ``limit_s`` passed (then ``quiet`` is False). Port errors propagate as ``OSError``."""
    started = last_data = time.monotonic()
    total = 0
    marker_seen = False
    tail = b""
    while True:
        chunk = connection.read(max(1, connection.in_waiting))
        now = time.monotonic()
        if chunk:
            total += len(chunk)
            last_data = now
            if marker is not None and not marker_seen:
                window = tail + chunk
                marker_seen = marker in window
                tail = window[-(len(marker) - 1) :] if len(marker) > 1 else b""
        else:
            wanted_quiet = (
                quiet_after_marker_s
                if marker_seen and quiet_after_marker_s is not None
                else quiet_s
            )
            if now - last_data >= wanted_quiet:
                return DrainResult(total, marker_seen, True)
        if now - started > limit_s:
            return DrainResult(total, marker_seen, False)


def close_quietly(connection: serial.Serial | None, lock: ExclusiveLock | None) -> None:
    """Close ``connection`` and then release ``lock``, ignoring a port that has already vanished."""
    if connection is not None:
        with contextlib.suppress(OSError):
            connection.close()
    if lock is not None:
        lock.release()
