"""Driver of ATI's Net F/T over UDP (RDT streaming): the six-axis balance as a network device.

Protocol: :mod:`ornitail.acquisition.netft_protocol` (ATI document 9620-05-NET FT, sections 9.1 and 10).

Connection
----------
:meth:`NetFtDriver.open` takes the counts per unit from the rig file (``counts_per_unit``) or, when the rig
file gives none, reads them from the device's web server (``http://HOST:HTTP_PORT/netftapi2.xml``, as ATI's
manual advises), opens a UDP socket connected to ``HOST:RDT_PORT`` and asks for one record (start streaming
with a sample count of 1). A device that does not answer within ``reply_timeout_s``, a refused port or an
unreadable calibration page is a one-line :class:`InstrumentDisconnected` / :class:`InstrumentReplyError`
naming the instrument, the address and what failed.

Streaming
---------
:meth:`NetFtDriver.start_streaming` sends "start high-speed real-time streaming" (0x0002, sample count 0)
and starts one receiver thread. It gathers the datagrams and, about every ``block_period_s``, decodes them
into a :class:`WrenchBlock` (N and N m, with the records' ``rdt_sequence`` counters) for a bounded queue read
with :meth:`get_block`. Records missing from the ``rdt_sequence`` series are counted in
:attr:`NetFtDriver.lost_records`; :meth:`link_health` also gives the time since the last datagram. No
datagram for ``silence_limit_s`` while streaming ends the thread with :class:`InstrumentDisconnected` (raised
by ``get_block``). :meth:`stop` sends "stop streaming" (0x0000), the device's safe state, and ends the thread.
"""

from __future__ import annotations

import contextlib
import http.client
import queue
import socket
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import numpy as np

from ornitail.acquisition import netft_protocol as protocol
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.core.errors import UserInputError
from ornitail.core.toml_table import REQUIRED, TomlTable

RECEIVE_BUFFER_BYTES = 4 * 1024 * 1024
"""Requested kernel receive buffer (the OS caps it at net.core.rmem_max): room for bursts, bytes."""
POLL_TIMEOUT_S = 0.05
"""The receiver wakes at least this often to check for stop() and for silence; after stop() it reads
until the stream has been quiet this long, s."""
STOP_DRAIN_LIMIT_S = 1.0
"""After stop(), records still arriving are read for at most this long, s."""
MAX_DATAGRAM_BYTES = 65536
SCALING_KEYS = ("counts_per_force", "counts_per_torque", "force_unit", "torque_unit")
RIG_TABLE_KEYS = ("host", "rdt_port", "http_port", "rdt_rate_hz", *SCALING_KEYS)


@dataclass
class WrenchBlock:
    """Consecutive RDT records in SI units.

    rdt_sequence : (n,) uint32 record counters (1 for a request's first record). ft_sequence : (n,)
    uint32 device sample counters (7000 per s). status : (n,) uint32 system status (0 = healthy).
    wrench : (n, 6) float64 Fx Fy Fz in N and Tx Ty Tz in N m, sensor frame. host_time_s : the driver's
    ``clock`` (by default ``time.monotonic()``) when the block's last datagram arrived (arrival, not sampling,
    time), s.
    """

    rdt_sequence: np.ndarray
    ft_sequence: np.ndarray
    status: np.ndarray
    wrench: np.ndarray
    host_time_s: float


@dataclass
class NetFtLinkHealth:
    """Counts since streaming started and the age of the last datagram.

    records_received, lost_records (gaps in ``rdt_sequence``), malformed_datagrams (not a whole number of
    36-byte records) and their bytes, status_flagged_records (non-zero status), blocks_dropped (full queue);
    seconds_since_last_datagram : s, None before the first.
    """

    records_received: int
    lost_records: int
    malformed_datagrams: int
    malformed_bytes: int
    status_flagged_records: int
    blocks_dropped: int
    seconds_since_last_datagram: float | None


class NetFtDriver:
    """Streams forces and torques from an ATI Net F/T.

    Parameters
    ----------
    host : str
        The device's IP address or name.
    rdt_port : int
        Its RDT UDP port (ATI's default 49152).
    http_port : int
        Its web server's port (80 on the device), for ``netftapi2.xml``.
    counts_per_unit : CountsPerUnit or None
        Scaling from the rig file; None reads it from the device on :meth:`open`.
    name : str
        Instrument name used in error messages.
    reply_timeout_s : float
        How long to wait for the first record and for the calibration page, s.
    silence_limit_s : float
        A stream silent this long is a disconnection, s.
    block_period_s : float
        About how often a block is delivered, s (wall clock).
    clock : callable returning s
        What blocks are stamped with (``WrenchBlock.host_time_s``): the monotonic clock, or a rig's clock.
    """

    def __init__(
        self,
        host: str,
        *,
        rdt_port: int = protocol.RDT_PORT,
        http_port: int = 80,
        counts_per_unit: protocol.CountsPerUnit | None = None,
        name: str = "Net F/T balance",
        reply_timeout_s: float = 1.0,
        silence_limit_s: float = 2.0,
        block_period_s: float = 0.01,
        queue_blocks: int = 2000,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.host = host
        self.rdt_port = int(rdt_port)
        self.http_port = int(http_port)
        self.counts_per_unit = counts_per_unit
        self.name = name
        self.reply_timeout_s = reply_timeout_s
        self.silence_limit_s = silence_limit_s
        self.block_period_s = block_period_s
        self.blocks: queue.Queue[WrenchBlock | None] = queue.Queue(maxsize=queue_blocks)
        self.records_received = 0
        self.lost_records = 0
        self.malformed_datagrams = 0
        self.malformed_bytes = 0
        self.status_flagged_records = 0
        self.blocks_dropped = 0
        self.clock = clock
        self._last_datagram_s: float | None = None
        self._socket: socket.socket | None = None
        self._receiver: threading.Thread | None = None
        self._stop_receiving = threading.Event()
        self._failure: Exception | None = None

    @classmethod
    def from_settings(cls, settings: NetFtSettings, **options: Any) -> NetFtDriver:
        """A driver for the device a rig file's ``[balance.netft]`` names; ``options`` as the constructor's."""
        return cls(
            settings.host,
            rdt_port=settings.rdt_port,
            http_port=settings.http_port,
            counts_per_unit=settings.counts_per_unit,
            **options,
        )

    @property
    def address(self) -> str:
        """``host:rdt_port`` as used in messages."""
        return f"{self.host}:{self.rdt_port}"

    # -- connection -------------------------------------------------------------------------
    def open(self) -> protocol.CountsPerUnit:
        """Read the scaling if the rig file gave none, open the UDP socket, check the device streams a
        record; return the scaling in use."""
        if self.counts_per_unit is None:
            self.counts_per_unit = self.read_counts_per_unit()
        try:
            self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
            self._socket.connect((self.host, self.rdt_port))  # only the device's datagrams get in
        except OSError as error:
            self.close()
            raise InstrumentDisconnected(
                self.name, f"cannot open UDP to {self.address}: {_reason(error)}"
            ) from None
        try:
            self._check_device_answers()
        except BaseException:
            self.close()
            raise
        return self.counts_per_unit

    def read_counts_per_unit(self) -> protocol.CountsPerUnit:
        """GET ``netftapi2.xml`` from the device's web server and parse its counts per unit and units."""
        url = f"http://{self.host}:{self.http_port}{protocol.XML_PAGE}"
        try:
            with urllib.request.urlopen(url, timeout=self.reply_timeout_s) as response:
                text = response.read()
        except (urllib.error.URLError, http.client.HTTPException, OSError) as error:
            raise InstrumentDisconnected(
                self.name, f"cannot read counts per unit from {url}: {_reason(error)}"
            ) from None
        try:
            return protocol.parse_netftapi2(text)
        except ValueError as error:
            raise InstrumentReplyError(self.name, f"{url}: {error}") from None

    def _check_device_answers(self) -> None:
        """Ask for one record and wait for it."""
        self.read_record()

    def read_record(self) -> protocol.RdtRecords:
        """Request one record (start streaming, sample count 1) and return it (not while streaming).

        Raises
        ------
        InstrumentDisconnected
            No record within ``reply_timeout_s`` or the port refused.
        """
        if self._receiver is not None:
            raise RuntimeError(f"{self.name}: read_record() while streaming")
        self._send(protocol.COMMAND_START_REALTIME_STREAMING, sample_count=1)
        deadline = time.monotonic() + self.reply_timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise InstrumentDisconnected(
                    self.name,
                    f"no RDT record from UDP {self.address} within {self.reply_timeout_s:g} s "
                    "(check the address, that RDT is enabled and the firewall)",
                )
            datagram = self._receive(remaining)
            if datagram and len(datagram) % protocol.RECORD_LENGTH == 0:
                return protocol.decode_records(datagram[-protocol.RECORD_LENGTH :])

    def close(self) -> None:
        """Stop streaming if needed and close the socket; safe to call twice or after a failure."""
        if self._receiver is not None:
            with contextlib.suppress(InstrumentDisconnected):
                self.stop()
        sock, self._socket = self._socket, None
        if sock is not None:
            sock.close()

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- commands ---------------------------------------------------------------------------
    def _send(self, command: int, sample_count: int = protocol.INFINITE_SAMPLES) -> None:
        if self._socket is None:
            raise RuntimeError(f"{self.name}: UDP {self.address} is not open; call open() first")
        try:
            self._socket.send(protocol.encode_request(command, sample_count))
        except OSError as error:
            raise InstrumentDisconnected(
                self.name,
                f"cannot send RDT command {command:#06x} to {self.address}: {_reason(error)}",
            ) from None

    def _receive(self, timeout_s: float) -> bytes | None:
        """One datagram, or None after ``timeout_s``; InstrumentDisconnected if the port is refused."""
        assert self._socket is not None
        self._socket.settimeout(max(timeout_s, 0.0))
        try:
            return self._socket.recv(MAX_DATAGRAM_BYTES)
        except (TimeoutError, BlockingIOError):
            return None
        except ConnectionRefusedError as error:  # ICMP port unreachable: nothing listens there
            raise InstrumentDisconnected(
                self.name, f"UDP {self.address} refused the RDT request: {_reason(error)}"
            ) from None
        except OSError as error:
            raise InstrumentDisconnected(
                self.name, f"receiving from UDP {self.address} failed: {_reason(error)}"
            ) from None

    def set_software_bias(self) -> None:
        """Command 0x0042: the device zeroes its readings at the present load (also while streaming)."""
        self._send(protocol.COMMAND_SET_SOFTWARE_BIAS)

    # -- streaming --------------------------------------------------------------------------
    def start_streaming(self) -> None:
        """Send "start high-speed real-time streaming" (sample count 0) and start the receiver thread."""
        if self._receiver is not None:
            raise RuntimeError(f"{self.name}: already streaming")
        self._drain()
        self.records_received = self.lost_records = self.malformed_datagrams = 0
        self.malformed_bytes = 0
        self.status_flagged_records = self.blocks_dropped = 0
        self._failure = None
        self._stop_receiving.clear()
        self._send(protocol.COMMAND_START_REALTIME_STREAMING)
        self._last_datagram_s = None
        self._receiver = threading.Thread(
            target=self._receive_loop, name=f"{self.name} receiver", daemon=True
        )
        self._receiver.start()

    def stop(self) -> None:
        """Send "stop streaming" (the device's safe state), end the receiver thread; raise its error if
        it failed."""
        receiver = self._receiver
        if receiver is None:
            return
        try:
            self._send(protocol.COMMAND_STOP_STREAMING)
        finally:
            self._stop_receiving.set()
            receiver.join(2.0)
            self._receiver = None
        if self._failure is not None:
            raise self._failure

    def get_block(self, timeout_s: float = 1.0) -> WrenchBlock | None:
        """Next block, or None after ``timeout_s``; raises the receiver's error if it failed."""
        try:
            block = self.blocks.get(timeout=timeout_s)
        except queue.Empty:
            block = None
        if block is None and self._failure is not None:
            raise self._failure
        return block

    def link_health(self) -> NetFtLinkHealth:
        """Counters since :meth:`start_streaming` and the age of the last datagram."""
        last = self._last_datagram_s
        return NetFtLinkHealth(
            records_received=self.records_received,
            lost_records=self.lost_records,
            malformed_datagrams=self.malformed_datagrams,
            malformed_bytes=self.malformed_bytes,
            status_flagged_records=self.status_flagged_records,
            blocks_dropped=self.blocks_dropped,
            seconds_since_last_datagram=None if last is None else time.monotonic() - last,
        )

    def _drain(self) -> None:
        """Drop datagrams waiting from before (the one-record check, a previous stream)."""
        while self._receive(0.0) is not None:
            pass

    def _receive_loop(self) -> None:
        assert self.counts_per_unit is not None
        pending = bytearray()
        previous_sequence = 0  # the device numbers a request's records from 1
        started_s = time.monotonic()
        last_block_s = started_s
        stop_deadline_s: float | None = None
        try:
            while True:
                if stop_deadline_s is None and self._stop_receiving.is_set():
                    stop_deadline_s = time.monotonic() + STOP_DRAIN_LIMIT_S
                datagram = self._receive(POLL_TIMEOUT_S)
                now = time.monotonic()
                if stop_deadline_s is not None and (datagram is None or now > stop_deadline_s):
                    break  # stopped: the records in flight are in, or the device keeps sending
                if datagram is not None:
                    self._last_datagram_s = now
                    if len(datagram) % protocol.RECORD_LENGTH or not datagram:
                        self.malformed_datagrams += 1
                        self.malformed_bytes += len(datagram)
                    else:
                        pending += datagram
                elif now - (self._last_datagram_s or started_s) > self.silence_limit_s:
                    raise InstrumentDisconnected(
                        self.name,
                        f"no RDT record from UDP {self.address} for {self.silence_limit_s:g} s",
                    )
                if pending and now - last_block_s >= self.block_period_s:
                    previous_sequence = self._deliver(pending, previous_sequence, self.clock())
                    pending = bytearray()
                    last_block_s = now
            if pending:
                self._deliver(pending, previous_sequence, self.clock())
        except InstrumentDisconnected as error:
            if pending:
                self._deliver(pending, previous_sequence, self.clock())
            self._failure = error
            with contextlib.suppress(queue.Full):
                self.blocks.put_nowait(None)

    def _deliver(self, data: bytearray, previous_sequence: int, host_time_s: float) -> int:
        """Decode, count and queue one block; return the newest ``rdt_sequence`` received so far."""
        assert self.counts_per_unit is not None
        records = protocol.in_sequence_order(protocol.decode_records(bytes(data)))
        self.lost_records += protocol.lost_records(records.rdt_sequence, previous_sequence)
        self.records_received += len(records.rdt_sequence)
        self.status_flagged_records += int(np.count_nonzero(records.status))
        block = WrenchBlock(
            rdt_sequence=records.rdt_sequence,
            ft_sequence=records.ft_sequence,
            status=records.status,
            wrench=self.counts_per_unit.to_si(records.counts),
            host_time_s=host_time_s,
        )
        try:
            self.blocks.put_nowait(block)
        except queue.Full:
            self.blocks_dropped += 1
        return protocol.newest_sequence(records.rdt_sequence, previous_sequence)


def _reason(error: BaseException) -> str:
    """First line of an OS or URL error, without the traceback's detail."""
    reason = getattr(error, "reason", None) or getattr(error, "strerror", None) or error
    return str(reason).splitlines()[0] if str(reason) else type(error).__name__


@dataclass(frozen=True)
class NetFtSettings:
    """``[balance.netft]``: the device's address, RDT and web ports, the RDT output rate it is set to (records/s)
    and its counts per unit (None: read from the device's ``netftapi2.xml`` on open)."""

    host: str
    rdt_port: int
    http_port: int
    rdt_rate_hz: float
    counts_per_unit: protocol.CountsPerUnit | None


def rdt_rate_problem(rate_hz: float) -> str | None:
    """Why ``rate_hz`` cannot be an RDT output rate (7000 records/s divided by a whole number), or None."""
    ratio = protocol.INTERNAL_SAMPLE_RATE_HZ / rate_hz if rate_hz > 0 else 0.0
    if ratio >= 1 and abs(ratio - round(ratio)) < 1e-9 * ratio:
        return None
    return (
        f"{rate_hz:g} records/s is not an RDT output rate: "
        f"{protocol.INTERNAL_SAMPLE_RATE_HZ:g} divided by a whole number (7000, 3500, 1000, ...)"
    )


def netft_settings_from_table(
    path: Path | str, table: dict[str, Any], *, simulated: bool = False
) -> NetFtSettings:
    """A rig file's ``[balance.netft]`` table, checked (see docs/rig-file.md).

    Keys: ``host`` (required unless ``simulated``: the simulator's loopback address is used), ``rdt_port``
    (49152), ``http_port`` (80), ``rdt_rate_hz`` (required: the RDT output rate set on the device's
    communication page, checked against the records' ``ft_sequence`` steps when streaming) and either all four
    of ``counts_per_force``, ``counts_per_torque``, ``force_unit``, ``torque_unit`` (the device's configuration
    page shows them) or none, to read them from the device's ``netftapi2.xml`` on open. UserInputError naming
    the file and key for a mistake.
    """
    fields = TomlTable(path, "balance.netft", table, RIG_TABLE_KEYS)
    host = fields.text("host", "127.0.0.1" if simulated else REQUIRED)
    given = [key for key in SCALING_KEYS if key in fields.table]
    scaling = None
    if given:
        missing = [key for key in SCALING_KEYS if key not in fields.table]
        if missing:
            raise UserInputError(
                fields.where(missing[0]),
                f"give all of {', '.join(SCALING_KEYS)} or none (then they are read from the device)",
            )
        units = {
            "force_unit": protocol.FORCE_UNITS_TO_N,
            "torque_unit": protocol.TORQUE_UNITS_TO_N_M,
        }
        for key, known in units.items():
            if protocol.normalised_unit(fields.text(key)) not in known:
                raise UserInputError(fields.where(key), f"unknown unit {table[key]!r}")
        scaling = protocol.CountsPerUnit(
            fields.number("counts_per_force", positive=True),
            fields.number("counts_per_torque", positive=True),
            fields.text("force_unit"),
            fields.text("torque_unit"),
        )
    rdt_rate_hz = fields.number("rdt_rate_hz", positive=True)
    problem = rdt_rate_problem(rdt_rate_hz)
    if problem is not None:
        raise UserInputError(fields.where("rdt_rate_hz"), problem)
    return NetFtSettings(
        host=host,
        rdt_port=fields.integer("rdt_port", protocol.RDT_PORT, minimum=1, maximum=65535),
        http_port=fields.integer("http_port", 80, minimum=1, maximum=65535),
        rdt_rate_hz=rdt_rate_hz,
        counts_per_unit=scaling,
    )
