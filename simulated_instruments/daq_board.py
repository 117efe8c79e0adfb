"""Simulated ORNI-DAQ9 board behind a pty, fed by the tunnel simulator in (scaled) real time.

The board runs in its own thread: it answers the ASCII commands of ``docs/daq-protocol.md`` and,
while streaming, writes the frames that are due on the :class:`SimulatedClock` in blocks every
``block_period_s`` of wall time. Samples come from a :class:`SharedTunnelSignals`, are quantised to
int16 ADC counts (clipped, with the overrange bit set) and the Hall voltage is thresholded to a bit.
If the driver does not read, the pty buffer fills and the board drops samples it cannot send (the
counters then show the gap), as a real board's FIFO would.

Fault injection (for tests): :meth:`inject_garbage`, :meth:`truncate_next_frame`,
:meth:`drop_samples`, :meth:`corrupt_next_crc`, :meth:`unplug` act on the next block written;
:meth:`hold_gauge_at_rail` (a channel stuck at the ADC limit, over-range bit set) and
:meth:`drop_periodically` (an overloaded link losing samples) and :meth:`overflow_fifo` (one long stall
of the host) start with the next block and last for a number of samples or until released.
"""

from __future__ import annotations

import threading
from collections import deque

import numpy as np

from ornitail.acquisition.daq_protocol import (
    ADC_COUNT_MAX,
    ADC_COUNT_MIN,
    ADC_RANGE_V,
    CHANNEL_NAMES,
    DEFAULT_BAUD,
    FRAME_LENGTH_BYTES,
    MINIMUM_SAMPLE_RATE_HZ,
    STATUS_BIT_HALL,
    STATUS_BIT_OVERRANGE,
    STOP_MARKER,
    VOLTS_PER_COUNT,
    DaqIdentity,
    encode_frames,
    format_identity,
    link_ceiling_frames_per_s,
)
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.device import SimulatedDevice
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

HALL_THRESHOLD_V = 1.65  # half of the 3.3 V logic level of the Hall sensor
HALL_HIGH_V = 3.3
FIRMWARE_VERSION = "1.0.0"
MODEL = "ORNI-DAQ9"


class SimulatedDaqBoard(SimulatedDevice):
    """An ORNI-DAQ9 board simulator; the driver connects to :attr:`port_path`.

    Parameters
    ----------
    signals : SharedTunnelSignals
        Where the nine channel voltages come from.
    clock : SimulatedClock
        Paces the sample clock (``time_scale`` times real time).
    sample_rate_hz : float
        Initial sampling rate (the driver may change it with ``RATE``), Hz.
    baud : int
        The line rate the board claims; it sets the ``max_rate_hz`` it accepts.
    block_period_s : float
        Wall-clock interval between writes, s.
    """

    def __init__(
        self,
        signals: SharedTunnelSignals,
        clock: SimulatedClock,
        *,
        sample_rate_hz: float = 10_000.0,
        baud: int = DEFAULT_BAUD,
        serial_number: str = "SIM00001",
        block_period_s: float = 0.005,
    ) -> None:
        self.signals = signals
        self.clock = clock
        self.sample_rate_hz = float(sample_rate_hz)
        self.identity = DaqIdentity(
            model=MODEL,
            serial_number=serial_number,
            firmware=FIRMWARE_VERSION,
            channels=CHANNEL_NAMES,
            volts_per_count=(VOLTS_PER_COUNT,) * 8,
            range_v=ADC_RANGE_V,
            hall_high_v=HALL_HIGH_V,
            baud=int(baud),
            max_rate_hz=link_ceiling_frames_per_s(baud),
        )
        self.block_period_s = block_period_s
        self._pty = PseudoTerminalPair.open_raw()
        self.port_path = self._pty.slave_path
        self._lock = threading.Lock()
        self._faults: deque[tuple[str, int | bytes]] = deque()
        self._unplug_requested = threading.Event()
        self._frozen = threading.Event()
        # channel -> [samples left (None: until released), counts held]; applied from the next block on
        self._rail_holds: dict[int, list[int | None]] = {}
        # (every n samples taken, drop the first k of them)
        self._periodic_drop: tuple[int, int] | None = None
        self._fifo_overflow_left = 0  # samples still to be lost to an injected FIFO overflow
        self._samples_taken = 0
        self._prepare_thread("simulated DAQ board")
        self._streaming = False
        self._next_counter = 0
        self._stream_start_s = 0.0
        self._samples_due_before = 0
        self._outgoing = b""
        self.samples_sent = 0
        self.samples_dropped_by_board = 0
        self.unplugged = False

    # -- lifecycle --------------------------------------------------------------------------
    def _close_transport(self) -> None:
        self._pty.close()

    # -- fault injection --------------------------------------------------------------------
    def inject_garbage(self, data: bytes) -> None:
        """Write ``data`` between two frames of the next block."""
        self._add_fault("garbage", bytes(data))

    def truncate_next_frame(self, keep_bytes: int = 10) -> None:
        """Send only the first ``keep_bytes`` bytes of one frame of the next block."""
        self._add_fault("truncate", int(keep_bytes))

    def drop_samples(self, count: int) -> None:
        """Skip ``count`` counters (samples that are taken but never sent)."""
        self._add_fault("drop", int(count))

    def corrupt_next_crc(self, count: int = 1) -> None:
        """Flip a CRC bit of ``count`` frames of the next block."""
        self._add_fault("crc", int(count))

    def freeze(self) -> None:
        """The board's firmware hangs: it sends nothing more and answers nothing, while its port stays open (the
        USB-serial bridge still enumerates, so the driver's port does not fail)."""
        self._frozen.set()

    def unplug(self) -> None:
        """Close the pty master: the driver's port fails as if the USB cable were pulled."""
        self._unplug_requested.set()

    def hold_gauge_at_rail(
        self, channel: int, samples: int | None = None, high: bool = True
    ) -> None:
        """Hold analog channel ``channel`` (0..7) at +32767 (``high``) or -32768 counts, with the over-range
        status bit set, for the next ``samples`` samples taken (None: until :meth:`release_gauge`)."""
        if not 0 <= channel < len(CHANNEL_NAMES) - 1:
            raise ValueError(f"analog channel {channel} must be 0..{len(CHANNEL_NAMES) - 2}")
        if samples is not None and samples < 1:
            raise ValueError(f"samples {samples} must be at least 1")
        with self._lock:
            self._rail_holds[channel] = [samples, ADC_COUNT_MAX if high else ADC_COUNT_MIN]

    def release_gauge(self, channel: int) -> None:
        """End a :meth:`hold_gauge_at_rail` of ``channel`` from the next block on."""
        with self._lock:
            self._rail_holds.pop(channel, None)

    def drop_periodically(self, every_samples: int, drop_samples: int) -> None:
        """From the next block on, of every ``every_samples`` samples taken the first ``drop_samples`` are never
        sent (counters keep counting them), until :meth:`stop_dropping`."""
        if not 0 < drop_samples < every_samples:
            raise ValueError(
                f"need 0 < drop_samples ({drop_samples}) < every_samples ({every_samples})"
            )
        with self._lock:
            self._periodic_drop = (int(every_samples), int(drop_samples))

    def overflow_fifo(self, samples: int) -> None:
        """The next ``samples`` samples taken are never sent (counters keep counting them): one stall of the
        host long enough to overflow the board's FIFO, as one counter gap in the stream."""
        if samples < 1:
            raise ValueError(f"samples {samples} must be at least 1")
        with self._lock:
            self._fifo_overflow_left = int(samples)

    def stop_dropping(self) -> None:
        """End :meth:`drop_periodically` from the next block on."""
        with self._lock:
            self._periodic_drop = None

    @property
    def faults_pending(self) -> int:
        """Faults injected but not yet written (they go out with the next block of frames)."""
        with self._lock:
            return len(self._faults)

    def _add_fault(self, kind: str, value: int | bytes) -> None:
        with self._lock:
            self._faults.append((kind, value))

    # -- board loop -------------------------------------------------------------------------
    def _run(self) -> None:
        command_buffer = b""
        while not self._closing.is_set():
            if self._unplug_requested.is_set():
                self.unplugged = True
                self._pty.close_master()
                return
            incoming = self._pty.read_available(self.block_period_s)
            if incoming is None:
                return
            if self._frozen.is_set():
                continue  # what arrives is lost; nothing goes out
            command_buffer += incoming
            while b"\n" in command_buffer:
                line, command_buffer = command_buffer.split(b"\n", 1)
                self._handle_command(line.decode("ascii", errors="replace").strip())
            if self._streaming:
                self._write_due_frames()
            self._flush_outgoing()

    def _reply(self, text: str) -> None:
        self._outgoing += text.encode("ascii") + b"\n"

    def _handle_command(self, command: str) -> None:
        words = command.split()
        if not words:
            return
        keyword = words[0].upper()
        if self._streaming and keyword != "STOP":
            return  # while streaming only STOP is heard, as documented
        if keyword == "ID?":
            self._reply(format_identity(self.identity))
        elif keyword == "RATE?":
            self._reply(f"RATE {self.sample_rate_hz:g}")
        elif keyword == "RATE" and len(words) == 2:
            self._set_rate(words[1])
        elif keyword == "START":
            self._reply("OK")
            self._streaming = True
            self._stream_start_s = self.clock.now_s()
            self._samples_due_before = 0
        elif keyword == "STOP":
            if self._streaming:
                self._write_due_frames()
            self._streaming = False
            self._outgoing += STOP_MARKER
        else:
            self._reply(f"ERR unknown command {command!r}")

    def _samples_due(self, elapsed_s: float) -> int:
        """Samples the board's clock has taken ``elapsed_s`` simulated seconds after START."""
        return int(elapsed_s * self.sample_rate_hz)

    def _sample_signals(self, count: int) -> np.ndarray:
        """The next ``count`` samples of the nine signals, V (the stream's samples ``_samples_due_before - count``
        onwards, taken at their rig times: a block generated late still holds the state of its own time)."""
        first = self._samples_due_before - count
        return self.signals.next_block_at_rate(
            count, self.sample_rate_hz, self._stream_start_s + first / self.sample_rate_hz
        )

    def _set_rate(self, text: str) -> None:
        try:
            rate = float(text)
        except ValueError:
            self._reply(f"ERR rate {text!r} is not a number")
            return
        if not MINIMUM_SAMPLE_RATE_HZ <= rate <= self.identity.max_rate_hz:
            self._reply(
                f"ERR rate {rate:g} outside "
                f"{MINIMUM_SAMPLE_RATE_HZ:g}..{self.identity.max_rate_hz:g} Hz"
            )
            return
        self.sample_rate_hz = rate
        self._reply("OK")

    def _write_due_frames(self) -> None:
        elapsed_s = self.clock.now_s() - self._stream_start_s
        due = self._samples_due(elapsed_s) - self._samples_due_before
        if due <= 0:
            return
        self._samples_due_before += due
        volts = self._sample_signals(due)
        scaled = np.rint(volts[:, :8] / VOLTS_PER_COUNT)
        counts = np.clip(scaled, -32768, 32767).astype(np.int16)
        status = np.where(volts[:, 8] > HALL_THRESHOLD_V, STATUS_BIT_HALL, 0).astype(np.uint8)
        status |= np.where(np.any(scaled != counts, axis=1), STATUS_BIT_OVERRANGE, 0).astype(
            np.uint8
        )
        counters = self._next_counter + np.arange(due, dtype=np.int64)
        with self._lock:
            faults = list(self._faults)
            self._faults.clear()
            self._apply_rail_holds(counts, status)
            periodic_drop = self._periodic_drop
            overflow = min(self._fifo_overflow_left, due)
            self._fifo_overflow_left -= overflow
        dropped = sum(int(value) for kind, value in faults if kind == "drop")
        if dropped:  # the skipped counters are simply never sent
            counters = counters + dropped
        self._next_counter = int(counters[-1]) + 1
        taken = self._samples_taken + np.arange(due, dtype=np.int64)
        self._samples_taken += due
        if periodic_drop is not None or overflow:  # taken (counted) but never sent
            sent = np.arange(due) >= overflow
            if periodic_drop is not None:
                every, drop = periodic_drop
                sent &= taken % every >= drop
            counters, counts, status = counters[sent], counts[sent], status[sent]
            self.samples_dropped_by_board += due - int(np.count_nonzero(sent))
            due = int(np.count_nonzero(sent))
            if due == 0:
                return
        data = encode_frames(counters, counts, status)
        data = self._apply_faults(data, faults)
        if len(self._outgoing) > 1_000_000:  # pty full for a long time: board FIFO overflows
            self.samples_dropped_by_board += due
            return
        self._outgoing += data
        self.samples_sent += due

    def _apply_rail_holds(self, counts: np.ndarray, status: np.ndarray) -> None:
        """Force held channels to their limit (with the over-range bit) in the first rows of this block."""
        for channel, hold in list(self._rail_holds.items()):
            left, value = hold
            rows = len(counts) if left is None else min(int(left), len(counts))
            counts[:rows, channel] = value
            status[:rows] |= STATUS_BIT_OVERRANGE
            if left is not None:
                hold[0] = int(left) - rows
                if hold[0] <= 0:
                    del self._rail_holds[channel]

    def _apply_faults(self, data: bytes, faults: list[tuple[str, int | bytes]]) -> bytes:
        frames = bytearray(data)
        middle = (len(frames) // FRAME_LENGTH_BYTES // 2) * FRAME_LENGTH_BYTES
        for kind, value in faults:
            if kind == "crc":
                for index in range(min(int(value), len(frames) // FRAME_LENGTH_BYTES)):
                    frames[index * FRAME_LENGTH_BYTES + 23] ^= 0x01
            elif kind == "truncate" and len(frames) >= FRAME_LENGTH_BYTES:
                del frames[middle + int(value) : middle + FRAME_LENGTH_BYTES]
            elif kind == "garbage":
                frames[middle:middle] = value
        return bytes(frames)

    def _flush_outgoing(self) -> None:
        if self._outgoing and not self.unplugged:
            written = self._pty.write_some(self._outgoing)
            self._outgoing = self._outgoing[written:]
