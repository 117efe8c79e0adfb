"""Driver of ATI's NETCANOEM board over CAN (python-can): the second route to the Nano-17 balance.

The bus is opened with ``can.Bus(interface=..., channel=..., bitrate=...)`` from the rig file, so
socketcan, pcan, kvaser or python-can's in-process ``virtual`` bus differ only by configuration.

Threading
---------
Queries (serial number, matrix, counts per unit, ...) run in the caller's thread and are refused
while polling. :meth:`NetCanOemDriver.start_polling` starts one thread that sends gauge requests at
the requested rate (see Schedule), waits for the two replies of each, and hands blocks of samples (:class:`GaugeBlock`,
about every ``block_period_s``) to a bounded queue read with :meth:`get_block` (a full queue drops
the block and counts it). CAN error frames received are counted in :attr:`error_frames` and polling
goes on; a bus error from python-can, or ``missed_replies_limit`` requests in a row without an
answer, ends the thread with :class:`InstrumentDisconnected` (raised by ``get_block``).

Schedule
--------
The board answers one request at a time (no streaming opcode, no documented request queue), so the poller keeps
one request outstanding: it sends a gauge request, waits for both replies, then sends the next. Request k is due
at ``start + k / rate`` (:class:`PollSchedule`): a request not yet due is waited for, a late one is sent at once,
so a late wake-up or a slow round trip is made up by the requests after it (sent as fast as the replies come)
and the rate holds on average whenever the host's round trip is shorter than the period. A poller more than
``catch_up_limit_s`` (0.05 s) behind gives up: the schedule restarts at that request and the requests it never
sent are counted in :attr:`requests_skipped`, so a long stall does not end in a burst. Counters:
:attr:`requests_sent` = :attr:`samples_polled` (delivered) + :attr:`missed_replies` + :attr:`discarded_samples`
(samples lost); requests never sent (the host could not keep up) are not lost samples.

Measured on python-can's ``virtual`` bus against the simulated board (``benchmarks/netcanoem_ceiling.py``,
2-core VM shared with other jobs): a round trip is a request and two replies exchanged by two Python threads
(40-80 us for the bare frames), plus the simulated board's tunnel simulation for each sample (about 105 us at best,
150-190 us when other jobs load the host) and the driver's own work (40-60 us of poller CPU per request, most of it in
python-can); a ``time.sleep`` wakes 65-85 us late. Together they are close to the 253 us period of the 1 Mbit/s
ceiling (3953 samples/s), so there the poller runs back to back and the rate is what the host's round trip
allows: 66-98.5 % of the ceiling depending on other jobs. With the simulated board generating its signals 4 ms
ahead (one simulator call per 16 requests) the driver held 3952 samples/s, 100 % of the ceiling, nothing lost; see
``benchmarks/README.md``.

Foreign frames
--------------
Another node that sends frames with the board's identifiers (a second master polling it, a misconfigured
node) must not be taken for the board. A gauge sample is accepted only as the board sends it: the 8-byte
opcode-0 frame, then the 6-byte opcode-1 frame, after this driver's request. Frames with the board's base id
that are anything else (an opcode-1 frame first, a second opcode-0 frame, a request, another opcode or
length, anything waiting before the next request is sent) are counted in :attr:`foreign_frames`. The board
answers each request exactly once, so a sample is kept only once the next request finds no such frame
waiting: a doubled reply cannot be told from the foreign one, and that sample is discarded
(:attr:`discarded_samples`; a foreign frame is never delivered as a sample).

Saturation and status
---------------------
ATI's rule: a gauge reading -32768 or +32767 is saturated (``GaugeBlock.saturated``). The status word comes
with every sample (0 = healthy; see ATI's manual for its bits); :attr:`saturated_samples` and
:attr:`status_flagged_samples` count the samples with a saturated gauge or a non-zero status word.
"""

from __future__ import annotations

import contextlib
import queue
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import can
import numpy as np

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.acquisition.exclusive_locks import ExclusiveLock, LockHeld, device_lock
from ornitail.acquisition.instrument_errors import (
    InstrumentDisconnected,
    InstrumentInUse,
    InstrumentReplyError,
)
from ornitail.core.errors import UserInputError, require_finite

OPEN_QUIET_S = 0.02
"""On open, the bus must be quiet this long (no stale frame from a crashed host's polling), s."""
OPEN_DRAIN_LIMIT_S = 2.0
"""On open, a bus still busy with the board's ids after this long is an error, s."""


@dataclass
class GaugeReading:
    """One polled sample: status word, raw gauges (6,) int16, saturation flags (6,) bool."""

    status_word: int
    gauges: np.ndarray
    saturated: np.ndarray


@dataclass
class GaugeBlock:
    """Consecutive polled samples.

    host_time_s : (n,) the driver's ``clock()`` (default ``time.monotonic()``) when each request was sent, s.
    status_words : (n,) uint16.
    gauges : (n, 6) int16 raw gauge counts.
    saturated : (n, 6) bool, gauge at -32768 or +32767.
    """

    host_time_s: np.ndarray
    status_words: np.ndarray
    gauges: np.ndarray
    saturated: np.ndarray

    @property
    def flagged(self) -> np.ndarray:
        """(n,) bool: a gauge saturated or a non-zero status word (the board reports a condition)."""
        return self.saturated.any(axis=1) | (self.status_words != 0)


class PollSchedule:
    """When the poller sends its gauge requests: ``1 / period_s`` requests per clock second on average.

    Request k is due at ``start_s + k * period_s`` (clock seconds). The poller waits for a request that is not
    yet due and sends a late one at once, so the requests after a late wake-up or a slow round trip follow one
    another as fast as their replies come (one request outstanding, as the board answers one at a time) until
    the schedule is met again. A request more than ``catch_up_limit_s`` late is not made up: the schedule
    restarts at the time it is sent, and :meth:`sent` returns how many requests due before it were given up
    (after a long stall the poller resynchronises instead of bursting).
    """

    def __init__(self, period_s: float, start_s: float, catch_up_limit_s: float) -> None:
        self.period_s = period_s
        self.catch_up_limit_s = catch_up_limit_s
        self._start_s = start_s
        self._index = 0

    @property
    def due_s(self) -> float:
        """Clock time the next request is due, s."""
        return self._start_s + self._index * self.period_s

    def sent(self, now_s: float) -> int:
        """Count the request sent at clock time ``now_s`` (s), at or after :attr:`due_s`; return the number of
        earlier requests given up because it was more than ``catch_up_limit_s`` late (they will never be sent)."""
        late_s = now_s - self.due_s
        if late_s > self.catch_up_limit_s:
            self._start_s, self._index = now_s, 1
            return int(late_s // self.period_s)
        self._index += 1
        return 0


class NetCanOemDriver:
    """Polls raw Nano-17 gauges from a NETCANOEM board and reads its calibration.

    Parameters
    ----------
    interface, channel : str
        python-can interface name and channel (``"socketcan", "can0"``; ``"virtual", "rig0"``).
    bit_rate : float
        Bus bit rate, bit/s; sets the sample-rate ceiling.
    base_id : int
        The board's 7-bit base identifier.
    name : str
        Instrument name used in error messages.
    reply_timeout_s : float
        How long to wait for each reply, s.
    catch_up_limit_s : float
        A poller further behind its schedule than this resynchronises instead of making the lost time up,
        clock s (:class:`PollSchedule`).
    clock : callable returning s
        Schedules the polls and stamps each sample (default ``time.monotonic``; the rig passes its rig time).
    time_scale : float
        Clock seconds per wall second (``clock`` of a simulated rig runs faster than the wall clock).
    sleep : callable taking s, optional
        Waits the given clock seconds (default ``time.sleep`` of them divided by ``time_scale``); a test passes
        one that advances its fake clock.
    """

    def __init__(
        self,
        *,
        interface: str,
        channel: str,
        bit_rate: float = 1_000_000,
        base_id: int = protocol.DEFAULT_BASE_ID,
        name: str = "NETCANOEM balance",
        reply_timeout_s: float = 0.1,
        missed_replies_limit: int = 3,
        block_period_s: float = 0.01,
        queue_blocks: int = 2000,
        catch_up_limit_s: float = 0.05,
        clock: Callable[[], float] = time.monotonic,
        time_scale: float = 1.0,
        sleep: Callable[[float], None] | None = None,
    ) -> None:
        self._clock = clock
        self._time_scale = float(time_scale)
        self._sleep = sleep if sleep is not None else self._wall_sleep
        self.interface = interface
        self.channel = channel
        self.bit_rate = float(bit_rate)
        self.base_id = int(base_id)
        self.name = name
        self.reply_timeout_s = reply_timeout_s
        self.missed_replies_limit = missed_replies_limit
        self.block_period_s = block_period_s
        self.catch_up_limit_s = catch_up_limit_s
        self.blocks: queue.Queue[GaugeBlock | None] = queue.Queue(maxsize=queue_blocks)
        self.blocks_dropped = 0
        self.error_frames = 0
        self.missed_replies = 0
        self.requests_sent = 0  # gauge requests sent while polling
        self.requests_skipped = 0  # requests due but never sent: given up on resynchronising
        self.samples_polled = 0
        self.poller_cpu_s = 0.0  # the last polling thread's CPU time (time.thread_time), s
        self.foreign_frames = 0
        self.discarded_samples = 0
        self.saturated_samples = 0
        self.status_flagged_samples = 0
        self.stale_frames_discarded = 0
        self._bus: can.BusABC | None = None
        self._channel_lock: ExclusiveLock | None = None
        self._poller: threading.Thread | None = None
        self._stop_polling = threading.Event()
        self._failure: Exception | None = None

    # -- connection -------------------------------------------------------------------------
    def open(self) -> str:
        """Open the bus, take the channel's lock, drain stale frames, return the board's serial number.

        The lock (a lock file per interface and channel, released by the OS when the process dies) keeps a
        second ornitail process off the board (python-can's in-process ``virtual`` bus needs none); it is taken
        once the bus opened (no lock file for a channel that is not there) and before anything is sent. Replies
        still on the bus from a host that crashed while polling are read and dropped until the bus has been
        quiet for ``OPEN_QUIET_S`` (at most ``OPEN_DRAIN_LIMIT_S``), so none is taken for an answer.
        """
        try:
            self._bus = can.Bus(
                interface=self.interface, channel=self.channel, bitrate=int(self.bit_rate)
            )
        except (can.CanError, OSError, ValueError, ImportError) as error:
            raise InstrumentDisconnected(
                self.name,
                f"cannot open CAN interface {self.interface!r} channel {self.channel!r}: "
                f"{str(error).splitlines()[0] if str(error) else type(error).__name__}",
            ) from None
        try:
            if self.interface != "virtual":
                self._take_channel_lock()
            self._discard_stale_frames()
            return self.read_serial_number()
        except BaseException:
            self.close()
            raise

    def _take_channel_lock(self) -> None:
        """Lock this interface and channel for this process (InstrumentInUse naming the holder)."""
        lock: ExclusiveLock | None = device_lock(f"can-{self.interface}-{self.channel}")
        try:
            lock.acquire(detail=f"{self.name} on {self.interface}:{self.channel}")
        except LockHeld as held:
            holder = held.holder.describe() if held.holder else "another process"
            raise InstrumentInUse(
                self.name,
                f"CAN channel {self.interface}:{self.channel} is in use by {holder}; stop it or wait",
            ) from None
        except OSError:
            lock = None  # the lock folder is not usable; go on without it
        self._channel_lock = lock

    def _discard_stale_frames(self) -> None:
        """Drop frames with the board's ids until none came for ``OPEN_QUIET_S`` (bounded by ``OPEN_DRAIN_LIMIT_S``)."""
        assert self._bus is not None
        started = last_board_frame = time.monotonic()
        while True:
            now = time.monotonic()
            if now - last_board_frame >= OPEN_QUIET_S:
                return  # other nodes' traffic may go on; the board's ids are quiet
            if now - started > OPEN_DRAIN_LIMIT_S:
                break
            try:
                message = self._bus.recv(OPEN_QUIET_S - (now - last_board_frame))
            except (can.CanError, OSError) as error:
                raise InstrumentDisconnected(
                    self.name, f"CAN bus error on receive: {error}"
                ) from None
            if message is not None and self._is_board_frame(message):
                self.stale_frames_discarded += 1
                last_board_frame = time.monotonic()
        raise InstrumentDisconnected(
            self.name,
            f"{self.interface}:{self.channel} did not fall quiet within {OPEN_DRAIN_LIMIT_S:g} s "
            f"({self.stale_frames_discarded} frames); is another master polling the board?",
        )

    def close(self) -> None:
        """Stop polling, shut the bus down and release the channel lock; safe to call twice or after a failure."""
        if self._poller is not None:
            with contextlib.suppress(InstrumentDisconnected):
                self.stop_polling()
        if self._bus is not None:
            self._bus.shutdown()
            self._bus = None
        if self._channel_lock is not None:
            self._channel_lock.release()
            self._channel_lock = None

    def __enter__(self) -> NetCanOemDriver:
        self.open()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- request / reply --------------------------------------------------------------------
    def _wall_sleep(self, clock_s: float) -> None:
        time.sleep(clock_s / self._time_scale)

    def _request(self, opcode: int, data: bytes = b"") -> can.Message:
        return can.Message(
            arbitration_id=protocol.arbitration_id(self.base_id, opcode),
            is_extended_id=False,
            data=data,
        )

    def _send(self, opcode: int, data: bytes = b"") -> None:
        if self._bus is None:
            raise RuntimeError(f"{self.name}: bus is not open; call open() first")
        self._send_message(self._request(opcode, data))

    def _send_message(self, message: can.Message) -> None:
        assert self._bus is not None
        try:
            self._bus.send(message)
        except (can.CanError, OSError) as error:
            raise InstrumentDisconnected(self.name, f"CAN bus error on send: {error}") from None

    def _receive_message(self, timeout_s: float) -> can.Message | None:
        """The next frame that is not an error frame (those are counted), or None when none arrives
        within ``timeout_s`` seconds."""
        assert self._bus is not None
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                message = self._bus.recv(max(0.0, deadline - time.monotonic()))
            except (can.CanError, OSError) as error:
                raise InstrumentDisconnected(
                    self.name, f"CAN bus error on receive: {error}"
                ) from None
            if message is None or not message.is_error_frame:
                return message
            self.error_frames += 1

    def _receive(self, wanted: dict[int, int], timeout_s: float) -> dict[int, bytes] | None:
        """Collect one reply per opcode in ``wanted`` (opcode -> DLC); None on timeout."""
        assert self._bus is not None
        replies: dict[int, bytes] = {}
        deadline = time.monotonic() + timeout_s
        while len(replies) < len(wanted):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            message = self._receive_message(remaining)
            if message is None:
                return None
            if message.is_extended_id or message.is_remote_frame:
                continue
            base_id, opcode = protocol.split_arbitration_id(message.arbitration_id)
            if base_id != self.base_id:
                continue  # another node's own traffic
            if wanted.get(opcode) == message.dlc and opcode not in replies:
                replies[opcode] = bytes(message.data)
            else:
                self.foreign_frames += 1
        return replies

    def _is_board_frame(self, message: can.Message) -> bool:
        """True for a data frame with the board's base id (standard 11-bit identifier)."""
        if message.is_error_frame or message.is_extended_id or message.is_remote_frame:
            return False
        return protocol.split_arbitration_id(message.arbitration_id)[0] == self.base_id

    def _discard_waiting_frames(self) -> None:
        """Count and drop frames with the board's ids that wait before a request (no request of ours is
        outstanding, so they are foreign or late)."""
        assert self._bus is not None
        while True:
            message = self._receive_message(0.0)
            if message is None:
                return
            if self._is_board_frame(message):
                self.foreign_frames += 1

    def _receive_gauge_sample(self, timeout_s: float) -> tuple[bytes, bytes] | None | bool:
        """The two replies to one gauge request, in the board's order: their payloads (8 and 6 bytes); None on
        timeout; False when a doubled reply made the sample ambiguous (discarded)."""
        assert self._bus is not None
        first: bytes | None = None
        ambiguous = False
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            message = self._receive_message(remaining)
            if message is None:
                return None
            if not self._is_board_frame(message):
                continue
            opcode = protocol.split_arbitration_id(message.arbitration_id)[1]
            if opcode == protocol.OPCODE_READ_GAUGES and message.dlc == 8:
                if first is not None:
                    self.foreign_frames += 1
                    ambiguous = True
                    continue
                first = bytes(message.data)
            elif (
                opcode == protocol.OPCODE_GAUGES_SECOND_REPLY
                and message.dlc == 6
                and first is not None
            ):
                if ambiguous:
                    self.discarded_samples += 1
                    return False
                return first, bytes(message.data)
            else:
                self.foreign_frames += 1

    def _query(self, opcode: int, wanted: dict[int, int], data: bytes = b"") -> dict[int, bytes]:
        if self._poller is not None:
            raise RuntimeError(f"{self.name}: stop_polling() before sending opcode {opcode:#x}")
        self._send(opcode, data)
        replies = self._receive(wanted, self.reply_timeout_s)
        if replies is None:
            raise InstrumentDisconnected(
                self.name,
                f"no reply to opcode {opcode:#x} within {self.reply_timeout_s:g} s on "
                f"{self.interface}:{self.channel} (base id {self.base_id:#x})",
            )
        return replies

    # -- queries ----------------------------------------------------------------------------
    def read_serial_number(self) -> str:
        """Opcode 0x5: the board's serial number."""
        replies = self._query(protocol.OPCODE_SERIAL_NUMBER, {protocol.OPCODE_SERIAL_NUMBER: 8})
        return protocol.decode_serial_number(replies[protocol.OPCODE_SERIAL_NUMBER])

    def read_firmware_version(self) -> str:
        """Opcode 0xF: ``"major.minor.build"``."""
        replies = self._query(
            protocol.OPCODE_FIRMWARE_VERSION, {protocol.OPCODE_FIRMWARE_VERSION: 4}
        )
        return protocol.decode_firmware_version(replies[protocol.OPCODE_FIRMWARE_VERSION])

    def read_counts_per_unit(self) -> tuple[int, int]:
        """Opcode 0x7: ``(counts per force unit, counts per torque unit)``."""
        replies = self._query(protocol.OPCODE_COUNTS_PER_UNIT, {protocol.OPCODE_COUNTS_PER_UNIT: 8})
        return protocol.decode_counts_per_unit(replies[protocol.OPCODE_COUNTS_PER_UNIT])

    def read_unit_codes(self) -> tuple[int, int]:
        """Opcode 0x8: ``(force unit code, torque unit code)`` (2 = N, 3 = N-m)."""
        replies = self._query(protocol.OPCODE_UNIT_CODES, {protocol.OPCODE_UNIT_CODES: 2})
        payload = replies[protocol.OPCODE_UNIT_CODES]
        return payload[0], payload[1]

    def read_matrix_row(self, row: int) -> np.ndarray:
        """Opcode 0x2: row ``row`` (0..5, Fx..Tz) of the active calibration matrix, (6,) float."""
        if not 0 <= row <= 5:
            raise ValueError(f"matrix row {row} must be 0..5")
        wanted = {opcode: 8 for opcode in protocol.MATRIX_ROW_REPLY_OPCODES}
        replies = self._query(protocol.OPCODE_READ_MATRIX_ROW, wanted, bytes([row]))
        return protocol.decode_matrix_row(
            tuple(replies[op] for op in protocol.MATRIX_ROW_REPLY_OPCODES)
        )

    def read_matrix(self) -> np.ndarray:
        """All six rows: (6, 6) matrix from gauge counts to force/torque counts."""
        return np.vstack([self.read_matrix_row(row) for row in range(6)])

    def set_active_calibration(self, index: int) -> None:
        """Opcode 0x6: select calibration ``index`` (0..15); the board echoes the index."""
        if not 0 <= index <= 15:
            raise UserInputError("active_calibration", f"{index} must be 0..15")
        replies = self._query(
            protocol.OPCODE_SET_ACTIVE_CALIBRATION,
            {protocol.OPCODE_SET_ACTIVE_CALIBRATION: 1},
            bytes([index]),
        )
        if replies[protocol.OPCODE_SET_ACTIVE_CALIBRATION][0] != index:
            raise InstrumentReplyError(self.name, f"did not confirm active calibration {index}")

    def read_gauges(self) -> GaugeReading:
        """Opcode 0x0: one sample of status word and six raw gauges, with saturation flags."""
        replies = self._query(protocol.OPCODE_READ_GAUGES, _GAUGE_REPLIES)
        status_word, gauges = protocol.decode_gauge_replies(
            replies[protocol.OPCODE_READ_GAUGES], replies[protocol.OPCODE_GAUGES_SECOND_REPLY]
        )
        return GaugeReading(status_word, gauges, protocol.saturated_gauges(gauges))

    def wrench_from_gauges(
        self,
        gauges: np.ndarray,
        matrix: np.ndarray,
        counts_per_unit: tuple[int, int],
        unit_codes: tuple[int, int],
    ) -> np.ndarray:
        """Forces and torques, N and N m, from raw gauges (n, 6) with the board's own calibration.

        ``matrix @ gauges`` gives counts; dividing by counts per force (rows 0-2) or per torque
        (rows 3-5) gives the board's units, converted to SI with the unit codes. No bias is removed.
        """
        force_code, torque_code = unit_codes
        try:
            to_si = np.array(
                [protocol.FORCE_UNIT_CODES_TO_N[force_code]] * 3
                + [protocol.TORQUE_UNIT_CODES_TO_N_M[torque_code]] * 3
            )
        except KeyError:
            raise InstrumentReplyError(self.name, f"unknown unit codes {unit_codes}") from None
        divisors = np.array([counts_per_unit[0]] * 3 + [counts_per_unit[1]] * 3, dtype=float)
        return (np.asarray(gauges, dtype=float) @ np.asarray(matrix).T) / divisors * to_si

    # -- polling ----------------------------------------------------------------------------
    def sample_rate_ceiling_hz(self) -> float:
        """Polled sample rate the bus carries at this bit rate without bit stuffing (ATI's figure), samples/s.

        Stuff bits depend on the data; with the worst case the guaranteed rate is lower (about 3.3 k/s at
        1 Mbit/s instead of 3.95 k/s). The achieved rate is measured while polling.
        """
        return protocol.gauge_sample_rate_ceiling_hz(self.bit_rate, worst_case_stuffing=False)

    def check_sample_rate(self, sample_rate_hz: float) -> None:
        """Refuse a polling rate the bus cannot carry (UserInputError stating the ceiling)."""
        require_finite("sample_rate_hz", sample_rate_hz)
        ceiling = self.sample_rate_ceiling_hz()
        guaranteed = protocol.gauge_sample_rate_ceiling_hz(self.bit_rate, worst_case_stuffing=True)
        if not 0 < sample_rate_hz <= ceiling:
            raise UserInputError(
                "sample_rate_hz",
                f"{sample_rate_hz:g} samples/s exceeds the CAN ceiling of {ceiling:.0f} samples/s for "
                f"{self.name} at {self.bit_rate:g} bit/s ({protocol.gauge_sample_bits(worst_case_stuffing=False)} "
                f"bits per sample; {guaranteed:.0f}/s guaranteed with worst-case bit stuffing)",
            )
        if sample_rate_hz > guaranteed:
            warnings.warn(
                f"{self.name}: {sample_rate_hz:g} samples/s is above the {guaranteed:.0f}/s the bus guarantees "
                "with worst-case bit stuffing; watch the achieved rate",
                stacklevel=2,
            )

    def start_polling(self, sample_rate_hz: float) -> None:
        """Start the polling thread at ``sample_rate_hz`` (checked against the bus ceiling)."""
        self.check_sample_rate(sample_rate_hz)
        if self._bus is None:
            raise RuntimeError(f"{self.name}: open() before start_polling()")
        self._failure = None
        self._stop_polling.clear()
        self._poller = threading.Thread(
            target=self._poll_loop,
            args=(float(sample_rate_hz),),
            name=f"{self.name} poller",
            daemon=True,
        )
        self._poller.start()

    def stop_polling(self) -> None:
        """End the polling thread; raises its error if it ended with one."""
        poller = self._poller
        if poller is None:
            return
        self._stop_polling.set()
        poller.join(2.0)
        self._poller = None
        if self._failure is not None:
            raise self._failure

    def get_block(self, timeout_s: float = 1.0) -> GaugeBlock | None:
        """Next block, or None after ``timeout_s``; raises the poller's error if it failed."""
        try:
            block = self.blocks.get(timeout=timeout_s)
        except queue.Empty:
            block = None
        if block is None and self._failure is not None:
            raise self._failure
        return block

    def _poll_loop(self, sample_rate_hz: float) -> None:
        schedule = PollSchedule(1.0 / sample_rate_hz, self._clock(), self.catch_up_limit_s)
        request = self._request(protocol.OPCODE_READ_GAUGES)
        samples = _SampleBuffer()
        pending: tuple[float, bytes, bytes] | None = None  # confirmed by the next drain
        last_block_s = schedule.due_s
        missed_in_a_row = 0
        started_cpu_s = time.thread_time()
        try:
            while not self._stop_polling.is_set():
                delay = schedule.due_s - self._clock()
                if delay > 0:
                    self._sleep(delay)
                self._confirm(pending, samples)
                pending = None
                if samples.times and samples.times[-1] - last_block_s >= self.block_period_s:
                    last_block_s = samples.times[-1]
                    self._deliver(samples)
                sent_s = self._clock()
                self.requests_skipped += schedule.sent(sent_s)
                self._send_message(request)
                self.requests_sent += 1
                sample = self._receive_gauge_sample(self.reply_timeout_s)
                if sample is False:
                    missed_in_a_row = 0  # the board answered; a foreign frame spoiled the sample
                    continue
                if sample is None:
                    self.missed_replies += 1
                    missed_in_a_row += 1
                    if missed_in_a_row >= self.missed_replies_limit:
                        raise InstrumentDisconnected(
                            self.name,
                            f"{missed_in_a_row} gauge requests in a row got no reply on "
                            f"{self.interface}:{self.channel} (base id {self.base_id:#x})",
                        )
                    continue
                missed_in_a_row = 0
                pending = (sent_s, *sample)
            self._confirm(pending, samples)
            self._deliver(samples)
        except InstrumentDisconnected as error:
            self._deliver(samples)
            self._failure = error
            with contextlib.suppress(queue.Full):
                self.blocks.put_nowait(None)
        finally:
            self.poller_cpu_s = time.thread_time() - started_cpu_s

    def _confirm(self, pending: tuple[float, bytes, bytes] | None, samples: _SampleBuffer) -> None:
        """Drain the frames waiting before the next request; keep the last sample only if none has the board's
        ids (the board answers a request exactly once: an extra pair means one of the two was foreign)."""
        foreign_before = self.foreign_frames
        self._discard_waiting_frames()
        if pending is None:
            return
        if self.foreign_frames != foreign_before:
            self.discarded_samples += 1
            return
        samples.times.append(pending[0])
        samples.first_replies.append(pending[1])
        samples.second_replies.append(pending[2])
        self.samples_polled += 1

    def _deliver(self, samples: _SampleBuffer) -> None:
        """Decode the buffered samples into one block, queue it and empty the buffer."""
        if not samples.times:
            return
        status_words, gauges = protocol.decode_gauge_reply_batch(
            b"".join(samples.first_replies), b"".join(samples.second_replies)
        )
        block = GaugeBlock(
            host_time_s=np.asarray(samples.times),
            status_words=status_words,
            gauges=gauges,
            saturated=protocol.saturated_gauges(gauges),
        )
        samples.clear()
        self.saturated_samples += int(np.count_nonzero(block.saturated.any(axis=1)))
        self.status_flagged_samples += int(np.count_nonzero(block.status_words != 0))
        try:
            self.blocks.put_nowait(block)
        except queue.Full:
            self.blocks_dropped += 1


class _SampleBuffer:
    """Samples polled since the last block: send times (clock s) and the raw reply payloads."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.first_replies: list[bytes] = []
        self.second_replies: list[bytes] = []

    def clear(self) -> None:
        self.times, self.first_replies, self.second_replies = [], [], []


_GAUGE_REPLIES = {protocol.OPCODE_READ_GAUGES: 8, protocol.OPCODE_GAUGES_SECOND_REPLY: 6}
