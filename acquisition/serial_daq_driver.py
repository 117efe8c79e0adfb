"""Driver of the ORNI-DAQ9 synchronised acquisition board over a serial port (pyserial).

Threading
---------
``start()`` launches one reader thread per board. It blocks in ``read(in_waiting or 1)`` with a
short timeout (never busy-polls), parses whatever arrived with the vectorised
:class:`DaqFrameParser`, and hands each parsed block (:class:`DaqBlock`) either to
``block_callback`` (called in the reader thread; it must return quickly) or to a bounded queue read
with :meth:`SerialDaqDriver.get_block`. If the queue is full the block is dropped and counted in
``blocks_dropped`` (a consumer too slow to keep up is a defect to fix, never hidden). A failure of
the port (unplugged cable) ends the thread; the error, an :class:`InstrumentDisconnected` naming the
board, is raised by the next
``get_block()`` /
``raise_if_failed()`` and passed to ``error_callback`` if given. Commands (``identify``,
``set_sample_rate``) are only allowed while the board is not streaming.
"""

from __future__ import annotations

import contextlib
import math
import queue
import termios
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import serial

from ornitail.acquisition.actuator_interfaces import Reading
from ornitail.acquisition.balance_interface import BalanceStream, CheckedDevice, LinkCounts
from ornitail.acquisition.daq_protocol import (
    ANALOG_CHANNEL_COUNT,
    CHANNEL_NAMES,
    DEFAULT_BAUD,
    DEFAULT_SAMPLE_RATE_HZ,
    MINIMUM_SAMPLE_RATE_HZ,
    STOP_MARKER,
    DaqFrameParser,
    DaqIdentity,
    DecodedFrames,
    StreamStatistics,
    counts_to_volts,
    link_ceiling_frames_per_s,
    parse_identity,
    saturated_rows,
)
from ornitail.acquisition.exclusive_locks import ExclusiveLock
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.serial_port_access import (
    close_quietly,
    drain_until_quiet,
    open_serial_exclusively,
    printable_excerpt,
)
from ornitail.core.errors import UserInputError, require_finite

# Parse when this much has arrived or this long has passed: bigger buffers cost less numpy overhead
# per frame (about 100 frames per parse at 10 kHz) while keeping latency near 10 ms.
PARSE_AT_BYTES = 4096
PARSE_INTERVAL_S = 0.01
OPEN_QUIET_S = 0.25
"""On open, a board that sends nothing (not even the stop marker) for this long is taken as stopped, s."""
OPEN_QUIET_AFTER_STOP_S = 0.05
"""On open, once the stop marker arrived the line must stay quiet this long, s."""
OPEN_DRAIN_LIMIT_S = 10.0
"""On open, a board still streaming this long after ``STOP`` is an error, s (a full 1 MB FIFO at 4 Mbaud: 2.5 s)."""
FIRST_SAMPLE_TIMEOUT_S = 5.0
"""How long the board may take to deliver its first sample after ``START`` in ``ornitail rig check``, s."""


@dataclass
class DaqBlock:
    """One block of consecutive samples as parsed from the stream.

    counters : (n,) uint32 board sample counters. volts : (n, 9) float64 in ``daq_protocol.CHANNEL_NAMES``
    order, V (Hall: 0 V or the logic-high V). host_time_s : the driver's ``clock()`` (default
    ``time.monotonic()``) when the read that completed its last frame returned (arrival, not sampling, time).
    saturated : (n,) bool, the board's over-range status bit or an analog channel at -32768 / +32767 counts
    (None: not known).
    """

    counters: np.ndarray
    volts: np.ndarray
    host_time_s: float
    saturated: np.ndarray | None = field(default=None)


class SerialDaqDriver(BalanceStream, CheckedDevice):
    """Streams the nine synchronised channels of an ORNI-DAQ9 board (a :class:`BalanceStream` of its own, or the
    auxiliary acquisition beside another balance, see :mod:`aligned_balance`).

    Parameters
    ----------
    port : str
        Serial device, e.g. ``/dev/ttyACM0`` (or a pty path for the simulated board).
    baud : int
        Line rate, baud; sets the link ceiling ``baud / 250`` frames/s.
    name : str
        Instrument name used in error messages.
    block_callback, error_callback : optional callables run in the reader thread.
    queue_blocks : int
        Capacity of the block queue used when no ``block_callback`` is given.
    reply_timeout_s : float
        How long to wait for a command reply before declaring the board disconnected, s.
    clock : callable returning s
        Stamps each block's ``host_time_s`` (default ``time.monotonic``; the rig passes its rig time).
    rig_file_key : str
        Where the rig file sets the port (``[balance.aux_daq].port`` for the board beside another balance).
    check_sample_rate_hz : float
        The rig file's rate, at which ``ornitail rig check`` streams its one sample, samples/s.

    Attributes
    ----------
    reader_cpu_s : float
        CPU time the reader thread has used (reading + parsing + delivering), s.
    blocks_dropped : int
        Blocks discarded because the queue was full.
    """

    model = "ORNI-DAQ9"
    """The model its ``ID?`` reply names (docs/daq-protocol.md)."""

    def __init__(
        self,
        port: str,
        *,
        baud: int = DEFAULT_BAUD,
        name: str = "acquisition board",
        block_callback: Callable[[DaqBlock], None] | None = None,
        error_callback: Callable[[Exception], None] | None = None,
        queue_blocks: int = 2000,
        reply_timeout_s: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
        rig_file_key: str = "[balance.serial_daq].port",
        check_sample_rate_hz: float = DEFAULT_SAMPLE_RATE_HZ,
    ) -> None:
        self.port = port
        self.rig_file_key = rig_file_key
        self.check_sample_rate_hz = float(check_sample_rate_hz)
        self._clock = clock
        self.baud = int(baud)
        self.name = name
        self._block_callback = block_callback
        self._error_callback = error_callback
        self.blocks: queue.Queue[DaqBlock | None] = queue.Queue(maxsize=queue_blocks)
        self._blocks_dropped = 0
        self._reply_timeout_s = reply_timeout_s
        self._serial: serial.Serial | None = None
        self._port_lock: ExclusiveLock | None = None
        self.stale_bytes_discarded = 0
        self._parser = DaqFrameParser()
        self._reader: threading.Thread | None = None
        self._last_bytes_s = 0.0
        self._stop_requested = threading.Event()
        self._failure: Exception | None = None
        self.identity: DaqIdentity | None = None
        self.sample_rate_hz: float | None = None
        self.reader_cpu_s = 0.0

    # -- connection -------------------------------------------------------------------------
    def open(self) -> DaqIdentity:
        """Open the port exclusively, bring the board to a known state, check it answers ``ID?``.

        A board may still be streaming (its host crashed or was killed without ``STOP``): the driver sends
        ``STOP``, drains the stream up to the board's stop marker and until the line is quiet (at most
        ``OPEN_DRAIN_LIMIT_S``), and only then asks ``ID?``. Binary bytes never reach an error message.

        Raises
        ------
        InstrumentInUse
            Another process (or connection) has the port.
        InstrumentDisconnected
            The port cannot be opened, fails, or the board keeps streaming after ``STOP``.
        InstrumentReplyError
            The board does not identify itself.
        """
        self._serial, self._port_lock = open_serial_exclusively(self.port, self.baud, self.name)
        try:
            self._stop_stream_left_running()
            try:
                self.identity = self.identify()
            except (
                InstrumentReplyError
            ):  # a late byte slipped in: quiet the line once more, ask again
                self._stop_stream_left_running()
                self.identity = self.identify()
        except BaseException:
            self.close()
            raise
        return self.identity

    def _stop_stream_left_running(self) -> None:
        """Send ``STOP`` (after a newline that ends any half-written command) and drain until quiet."""
        port = self._port()
        try:
            port.write(b"\nSTOP\n")
            drained = drain_until_quiet(
                port,
                quiet_s=OPEN_QUIET_S,
                quiet_after_marker_s=OPEN_QUIET_AFTER_STOP_S,
                limit_s=OPEN_DRAIN_LIMIT_S,
                marker=STOP_MARKER,
            )
            port.reset_input_buffer()
        except (OSError, termios.error) as error:
            raise InstrumentDisconnected(self.name, f"port {self.port} failed: {error}") from None
        self.stale_bytes_discarded += drained.bytes_discarded
        if not drained.quiet:
            raise InstrumentDisconnected(
                self.name,
                f"still sending data {OPEN_DRAIN_LIMIT_S:g} s after STOP on {self.port} "
                f"({drained.bytes_discarded} bytes); power-cycle the board",
            )

    def close(self) -> None:
        """Stop streaming if needed, close the port and release its lock; safe to call twice or after a failure."""
        if self._reader is not None:
            with contextlib.suppress(InstrumentDisconnected):
                self.stop()
        serial_port, self._serial = self._serial, None
        port_lock, self._port_lock = self._port_lock, None
        close_quietly(serial_port, port_lock)

    def __enter__(self) -> SerialDaqDriver:
        self.open()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- commands ---------------------------------------------------------------------------
    def _port(self) -> serial.Serial:
        if self._serial is None:
            raise RuntimeError(f"{self.name}: port {self.port} is not open; call open() first")
        return self._serial

    def query(self, command: str) -> str:
        """Send one ASCII command line and return the reply line (without newline)."""
        if self._reader is not None:
            raise RuntimeError(
                f"{self.name}: cannot send {command!r} while streaming; stop() first"
            )
        port = self._port()
        try:
            port.write(command.encode("ascii") + b"\n")
            reply = b""
            deadline = time.monotonic() + self._reply_timeout_s
            while not reply.endswith(b"\n") and time.monotonic() < deadline:
                reply += port.read_until(b"\n")
        except OSError as error:
            raise InstrumentDisconnected(self.name, f"port {self.port} failed: {error}") from None
        if not reply.endswith(b"\n"):
            raise InstrumentDisconnected(
                self.name,
                f"no reply to {command!r} within {self._reply_timeout_s:g} s on {self.port}",
            )
        text = reply.decode("ascii", errors="replace").strip()
        if text.startswith("ERR"):
            raise InstrumentReplyError(
                self.name,
                f"refused {command!r}: {printable_excerpt(text[3:].strip(), quote=False)}",
            )
        return text

    def identify(self) -> DaqIdentity:
        """Ask ``ID?``: model, serial, firmware, channel list, volts per count, link ceiling."""
        reply = self.query("ID?")
        try:
            return parse_identity(reply)
        except (ValueError, KeyError) as error:
            raise InstrumentReplyError(
                self.name,
                f"malformed reply to 'ID?' on {self.port}: {printable_excerpt(reply)} "
                f"({printable_excerpt(str(error), quote=False)})",
            ) from None

    def link_ceiling_hz(self) -> float:
        """Highest frame rate the serial link carries at this baud rate, Hz."""
        return link_ceiling_frames_per_s(self.baud)

    def set_sample_rate(self, sample_rate_hz: float) -> None:
        """Set the board's sampling clock, Hz; refused above the link ceiling or below 100 Hz."""
        require_finite("sample_rate_hz", sample_rate_hz)
        ceiling = self.link_ceiling_hz()
        if not MINIMUM_SAMPLE_RATE_HZ <= sample_rate_hz <= ceiling:
            raise UserInputError(
                "sample_rate_hz",
                f"{sample_rate_hz:g} Hz is outside {MINIMUM_SAMPLE_RATE_HZ:g}..{ceiling:g} Hz "
                f"(ceiling = {self.baud} baud / 250 bits per frame for {self.name})",
            )
        self.query(f"RATE {sample_rate_hz:g}")
        reply = self.query("RATE?")
        words = reply.split()
        try:
            rate_hz = float(words[1])
        except (IndexError, ValueError):
            rate_hz = math.nan
        if len(words) != 2 or words[0] != "RATE" or not (math.isfinite(rate_hz) and rate_hz > 0):
            raise InstrumentReplyError(
                self.name, f"malformed reply to 'RATE?' on {self.port}: {printable_excerpt(reply)}"
            )
        self.sample_rate_hz = rate_hz

    # -- streaming --------------------------------------------------------------------------
    def start(self) -> None:
        """Start streaming and the reader thread."""
        if self.identity is None:
            raise RuntimeError(f"{self.name}: open() before start()")
        self.query("START")
        self._parser = DaqFrameParser()
        self._failure = None
        self._stop_requested.clear()
        self._reader = threading.Thread(
            target=self._read_loop, name=f"{self.name} reader", daemon=True
        )
        self._reader.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Ask the board to stop, let the reader drain up to the stop marker, end the thread."""
        reader = self._reader
        if reader is None:
            return
        self._stop_requested.set()
        write_error: OSError | None = None
        if reader.is_alive():
            try:
                self._port().write(b"STOP\n")
            except OSError as error:
                write_error = error
        reader.join(timeout_s)
        self._reader = None
        if self._serial is not None:
            # a vanished port cannot be flushed; its failure is reported below
            with contextlib.suppress(OSError, termios.error):
                self._serial.reset_input_buffer()
        if write_error is not None and self._failure is None:
            self._failure = InstrumentDisconnected(
                self.name, f"port {self.port} failed: {write_error}"
            )
        if self._failure is not None:
            raise self._failure

    @property
    def streaming(self) -> bool:
        """True while the reader thread runs."""
        return self._reader is not None and self._reader.is_alive()

    @property
    def statistics(self) -> StreamStatistics:
        """Running totals: frames, CRC failures, truncated, garbage bytes, gaps, lost samples."""
        return self._parser.statistics

    def raise_if_failed(self) -> None:
        """Raise the reader thread's error, if it ended with one."""
        if self._failure is not None:
            raise self._failure

    def get_block(self, timeout_s: float = 1.0) -> DaqBlock | None:
        """Next block from the queue, or None after ``timeout_s``; raises the reader's error."""
        try:
            block = self.blocks.get(timeout=timeout_s)
        except queue.Empty:
            self.raise_if_failed()
            return None
        if block is None:
            self.raise_if_failed()
        return block

    def _deliver(self, decoded_block: DaqBlock) -> None:
        if self._block_callback is not None:
            self._block_callback(decoded_block)
            return
        try:
            self.blocks.put_nowait(decoded_block)
        except queue.Full:
            self._blocks_dropped += 1

    def _read_loop(self) -> None:
        port = self._port()
        identity = self.identity
        assert identity is not None
        pending = b""
        stop_deadline: float | None = None
        cpu_start_s = time.thread_time()
        last_parse_s = time.monotonic()
        try:
            while True:
                self.reader_cpu_s = time.thread_time() - cpu_start_s
                chunk = port.read(port.in_waiting or 1)
                if chunk:
                    self._last_bytes_s = self._clock()  # the newest complete frame arrived by then
                    pending += chunk
                if self._stop_requested.is_set():
                    stop_deadline = stop_deadline or time.monotonic() + 1.0
                    marker_at = pending.find(STOP_MARKER)
                    if marker_at >= 0 or time.monotonic() > stop_deadline:
                        final_bytes = pending if marker_at < 0 else pending[:marker_at]
                        self._publish(self._parser.feed(final_bytes, final=True), identity)
                        return
                    # keep bytes that may be the start of the marker for the next read
                    keep = len(STOP_MARKER) - 1
                    pending, ready = pending[-keep:], pending[:-keep]
                    self._publish(self._parser.feed(ready), identity)
                    continue
                now_s = time.monotonic()
                if len(pending) >= PARSE_AT_BYTES or now_s - last_parse_s >= PARSE_INTERVAL_S:
                    self._publish(self._parser.feed(pending), identity)
                    pending, last_parse_s = b"", now_s
        except OSError as error:  # SerialException from read, EIO from in_waiting: unplugged
            self._failure = InstrumentDisconnected(
                self.name, f"serial port {self.port} failed while streaming ({error})"
            )
            if self._error_callback is not None:
                self._error_callback(self._failure)
            with contextlib.suppress(queue.Full):
                self.blocks.put_nowait(None)

    def _publish(self, decoded: DecodedFrames, identity: DaqIdentity) -> None:
        if len(decoded):
            self._deliver(
                DaqBlock(
                    decoded.counters,
                    counts_to_volts(decoded, identity),
                    self._last_bytes_s,
                    saturated_rows(decoded),
                )
            )

    # -- BalanceStream ----------------------------------------------------------------------
    @property
    def blocks_dropped(self) -> int:
        """Blocks discarded because the queue was full."""
        return self._blocks_dropped

    @blocks_dropped.setter
    def blocks_dropped(self, value: int) -> None:
        self._blocks_dropped = int(value)

    @property
    def channel_names(self) -> tuple[str, ...]:
        """The board's nine channels (``daq_protocol.CHANNEL_NAMES``)."""
        return tuple(CHANNEL_NAMES)

    def start_stream(self, sample_rate_hz: float) -> float:
        """Set the board's rate (``RATE``), start streaming; the rate the board confirmed, Hz."""
        self.set_sample_rate(sample_rate_hz)
        self.start()
        assert self.sample_rate_hz is not None
        return self.sample_rate_hz

    def stop_stream(self) -> None:
        """``STOP`` and end the reader thread."""
        self.stop()

    def read_block(self, timeout_s: float) -> DaqBlock | None:
        """:meth:`get_block`."""
        return self.get_block(timeout_s=timeout_s)

    def link_counts(self) -> LinkCounts:
        """CRC failures, lost samples, garbage bytes and resyncs of the parser."""
        statistics = self.statistics
        return LinkCounts(
            crc_failures=statistics.crc_failures,
            lost_samples=statistics.lost_samples,
            garbage_bytes=statistics.garbage_bytes,
            resyncs=statistics.resyncs,
        )

    def adc_limits_v(self) -> tuple[np.ndarray, np.ndarray]:
        """-32768 and +32767 counts of each analog channel in volts (the identity's volts per count)."""
        identity = self.identity
        if identity is None:
            raise RuntimeError(f"{self.name}: open() before adc_limits_v()")
        volts_per_count = np.asarray(identity.volts_per_count, dtype=float)[:ANALOG_CHANNEL_COUNT]
        return -32768 * volts_per_count, 32767 * volts_per_count

    # -- rig check (CheckedDevice) ------------------------------------------------------------
    def checked_devices(self) -> tuple[CheckedDevice, ...]:
        """The board itself: one device."""
        return (self,)

    @property
    def route(self) -> str:
        """The serial port."""
        return self.port

    def check_identity(self) -> tuple[str, str | None]:
        """``STOP`` and ``ID?`` (:meth:`open`): model, serial number and firmware, and whether it is an ORNI-DAQ9."""
        identity = self.open()
        text = (
            f"model={identity.model} serial={identity.serial_number} firmware={identity.firmware}"
        )
        if identity.model == self.model:
            return text, None
        return text, (
            f"{self.port} answers as {identity.model!r}, not {self.model}: is {self.rig_file_key} the right port?"
        )

    def check_reading(self) -> Reading:
        """The first sample streamed at :attr:`check_sample_rate_hz`: the rate and every channel, V."""
        self.start_stream(self.check_sample_rate_hz)
        deadline = time.monotonic() + FIRST_SAMPLE_TIMEOUT_S
        while time.monotonic() < deadline:
            block = self.get_block(timeout_s=0.1)
            if block is not None and len(block.counters):
                return {
                    "sample_rate_hz": float(self.sample_rate_hz or self.check_sample_rate_hz),
                    **{
                        name: float(value)
                        for name, value in zip(CHANNEL_NAMES, block.volts[0], strict=True)
                    },
                }
        raise InstrumentDisconnected(
            self.name, f"no sample within {FIRST_SAMPLE_TIMEOUT_S:g} s after START on {self.port}"
        )
