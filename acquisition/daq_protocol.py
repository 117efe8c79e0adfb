"""Wire protocol of the synchronised acquisition board (ORNI-DAQ9): frames, commands, link budget.

The full specification, with byte tables and a worked example, is ``docs/daq-protocol.md``. In
short: a 25-byte little-endian frame per sample — sync word ``A5 5A``, uint32 sample counter, eight
int16 ADC channels (six Nano-17 gauges, hot-wire bridge, thermocouple), a status byte (bit 0 = Hall
line, bit 1 = over-range: some channel's input was outside the ADC range) and a CRC-16/CCITT-FALSE (LE)
over bytes 2..22. Commands are ASCII lines. This module holds no
I/O: the encoder is used by the simulated board and the tests, the parser by the driver.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ornitail.acquisition.crc16 import crc16_ccitt_false_rows
from ornitail.calibration.signal_channels import TUNNEL_SIGNAL_CHANNELS

SYNC_WORD = b"\xa5\x5a"
FRAME_LENGTH_BYTES = 25
ANALOG_CHANNEL_COUNT = 8
CHANNEL_NAMES = TUNNEL_SIGNAL_CHANNELS
STATUS_BIT_HALL = 0x01
STATUS_BIT_OVERRANGE = 0x02
ADC_COUNT_MIN = -32768
ADC_COUNT_MAX = 32767
"""A channel reading either limit is clipped: its input was at or beyond the ADC range."""
ADC_RANGE_V = 10.24
VOLTS_PER_COUNT = ADC_RANGE_V / 32768.0  # 0.3125 mV per count, int16 covers -10.24 .. +10.2397 V
DEFAULT_BAUD = 4_000_000
DEFAULT_SAMPLE_RATE_HZ = 10_000.0
"""A board's rate when the rig file gives none, samples/s."""
BITS_PER_BYTE_ON_WIRE = 10  # 8N1: start bit, 8 data bits, stop bit
STOP_MARKER = b"OK STOPPED\n"
MINIMUM_SAMPLE_RATE_HZ = 100.0

_OFFSETS = np.arange(FRAME_LENGTH_BYTES)


def link_ceiling_frames_per_s(baud: int) -> float:
    """Frames per second a UART at ``baud`` (8N1) can carry: baud / (25 bytes * 10 bits)."""
    return baud / (FRAME_LENGTH_BYTES * BITS_PER_BYTE_ON_WIRE)


def encode_frames(counters: np.ndarray, counts: np.ndarray, status: np.ndarray) -> bytes:
    """Encode n samples into n consecutive frames.

    Parameters
    ----------
    counters : (n,) integers, sample counters (taken modulo 2**32).
    counts : (n, 8) int16 ADC counts of the analog channels in ``CHANNEL_NAMES`` order.
    status : (n,) uint8 status bytes (bit 0 Hall line, bit 1 overrange).
    """
    counters = np.asarray(counters, dtype=np.int64).astype(np.uint32)
    counts = np.asarray(counts, dtype=np.int16).reshape(-1, ANALOG_CHANNEL_COUNT)
    n = counters.shape[0]
    frames = np.empty((n, FRAME_LENGTH_BYTES), dtype=np.uint8)
    frames[:, 0:2] = np.frombuffer(SYNC_WORD, dtype=np.uint8)
    frames[:, 2:6] = counters.astype("<u4").view(np.uint8).reshape(n, 4)
    frames[:, 6:22] = counts.astype("<i2").view(np.uint8).reshape(n, 16)
    frames[:, 22] = np.asarray(status, dtype=np.uint8)
    crc = crc16_ccitt_false_rows(frames[:, 2:23])
    frames[:, 23] = crc & 0xFF
    frames[:, 24] = crc >> 8
    return frames.tobytes()


@dataclass
class DecodedFrames:
    """Frames accepted in one call: counters (n,) uint32, counts (n, 8) int16, status (n,)."""

    counters: np.ndarray
    counts: np.ndarray
    status: np.ndarray

    def __len__(self) -> int:
        return int(self.counters.shape[0])


@dataclass
class StreamStatistics:
    """Running totals of what the parser saw since the stream started.

    frames_ok : frames with a valid CRC. crc_failures : frames that had a sync word and a full
    length but a wrong CRC. truncated_frames : sync words followed by fewer than 25 bytes before the
    next valid frame. garbage_bytes : bytes that were not part of any valid frame (includes the
    bytes of the two above). counter_gaps : places where the counter jumped forward by more than
    one. lost_samples : sum of the jumps minus one, i.e. the number of samples that never arrived.
    counter_resets : places where the counter went backwards (board restarted). resyncs : stretches of
    garbage bytes (each one made the parser search for the next frame; a run of garbage cut by a buffer
    boundary counts once). saturated_frames : valid frames with the over-range status bit set or an analog
    channel at -32768 or +32767 counts.
    """

    frames_ok: int = 0
    crc_failures: int = 0
    truncated_frames: int = 0
    garbage_bytes: int = 0
    counter_gaps: int = 0
    lost_samples: int = 0
    counter_resets: int = 0
    resyncs: int = 0
    saturated_frames: int = 0
    last_counter: int | None = field(default=None, repr=False)


class DaqFrameParser:
    """Incremental, vectorised parser of the ORNI-DAQ9 byte stream.

    Feed it whatever the port returned; it returns the complete valid frames and keeps the undecided
    tail for the next call. Frames are found by their sync word and accepted only with a valid CRC,
    so after garbage or a truncated frame the next intact frame is found again (resynchronisation
    within one frame). All work is numpy over whole buffers; a Python loop runs only in the rare
    case of two CRC-valid candidates overlapping each other.
    """

    def __init__(self) -> None:
        self._pending = b""
        self._in_garbage = False  # the last decided bytes were garbage (a stretch may go on)
        self.statistics = StreamStatistics()

    def feed(self, data: bytes, *, final: bool = False) -> DecodedFrames:
        """Parse ``data`` appended to the tail kept from the previous call.

        With ``final=True`` nothing is kept: an incomplete last frame is counted as truncated.
        """
        buffer_bytes = self._pending + bytes(data)
        buffer = np.frombuffer(buffer_bytes, dtype=np.uint8)
        n = buffer.shape[0]
        if n < 2:
            self._pending = b"" if final else buffer_bytes
            if final and n:
                self.statistics.garbage_bytes += n
                self.statistics.resyncs += 0 if self._in_garbage else 1
                self._in_garbage = True
            return _empty_frames()
        candidates = np.flatnonzero((buffer[:-1] == 0xA5) & (buffer[1:] == 0x5A))
        complete = candidates[candidates + FRAME_LENGTH_BYTES <= n]
        windows = buffer[complete[:, None] + _OFFSETS]
        received_crc = windows[:, 23].astype(np.uint16) | (windows[:, 24].astype(np.uint16) << 8)
        crc_ok = crc16_ccitt_false_rows(windows[:, 2:23]) == received_crc
        valid_rows = np.flatnonzero(crc_ok)
        accepted_rows = valid_rows[_non_overlapping(complete[valid_rows])]
        accepted_positions = complete[accepted_rows]
        last_end = (
            int(accepted_positions[-1]) + FRAME_LENGTH_BYTES if accepted_positions.size else 0
        )

        if final:
            undecided_start = n
        else:
            incomplete = candidates[
                (candidates + FRAME_LENGTH_BYTES > n) & (candidates >= last_end)
            ]
            if incomplete.size:
                undecided_start = int(incomplete[0])
            elif buffer[-1] == 0xA5 and n - 1 >= last_end:
                undecided_start = n - 1
            else:
                undecided_start = n

        rejected = complete[~crc_ok]
        rejected = rejected[~_covered_by(rejected, accepted_positions)]
        deferred = rejected[
            (rejected >= last_end) & (rejected + FRAME_LENGTH_BYTES > undecided_start)
        ]
        if deferred.size and not final:
            undecided_start = min(undecided_start, int(deferred[0]))
        decided_rejected = rejected[rejected < undecided_start]
        next_accepted = np.searchsorted(accepted_positions, decided_rejected, side="right")
        has_next = next_accepted < accepted_positions.size
        if accepted_positions.size:
            next_start = np.where(
                has_next,
                accepted_positions[np.minimum(next_accepted, accepted_positions.size - 1)],
                n,
            )
        else:  # a bad frame decided in a buffer without a valid one (garbage cut by buffer ends)
            next_start = np.full(decided_rejected.shape, n)
        overlaps_next = has_next & (decided_rejected + FRAME_LENGTH_BYTES > next_start)
        if final:
            truncated_at_end = candidates[
                (candidates + FRAME_LENGTH_BYTES > n) & (candidates >= last_end)
            ]
            self.statistics.truncated_frames += int(truncated_at_end.size)

        statistics = self.statistics
        statistics.truncated_frames += int(np.count_nonzero(overlaps_next))
        statistics.crc_failures += int(np.count_nonzero(~overlaps_next))
        statistics.garbage_bytes += undecided_start - FRAME_LENGTH_BYTES * int(
            accepted_positions.size
        )
        self._count_garbage_stretches(accepted_positions, undecided_start)
        self._pending = buffer_bytes[undecided_start:]

        frames = windows[accepted_rows]
        decoded = DecodedFrames(
            counters=frames[:, 2:6].copy().view("<u4").reshape(-1).astype(np.uint32),
            counts=frames[:, 6:22].copy().view("<i2").reshape(-1, ANALOG_CHANNEL_COUNT),
            status=frames[:, 22].copy(),
        )
        self._account_counters(decoded.counters)
        statistics.frames_ok += len(decoded)
        statistics.saturated_frames += int(np.count_nonzero(saturated_rows(decoded)))
        return decoded

    def _count_garbage_stretches(self, accepted_positions: np.ndarray, decided_end: int) -> None:
        """Count the stretches of garbage among the bytes decided in this call (``[0, decided_end)``)."""
        frame_ends = accepted_positions + FRAME_LENGTH_BYTES
        previous_ends = np.concatenate(([0], frame_ends[:-1]))
        # garbage bytes before each accepted frame, and after the last one
        before_frames = accepted_positions - previous_ends
        after_last = decided_end - (int(frame_ends[-1]) if frame_ends.size else 0)
        stretches = int(np.count_nonzero(before_frames)) + int(after_last > 0)
        first_stretch_at_start = (before_frames[0] > 0) if before_frames.size else after_last > 0
        if self._in_garbage and first_stretch_at_start:
            stretches -= 1  # the stretch began in an earlier call
        self.statistics.resyncs += stretches
        if after_last > 0:
            self._in_garbage = True
        elif frame_ends.size:
            self._in_garbage = False

    def _account_counters(self, counters: np.ndarray) -> None:
        if counters.size == 0:
            return
        statistics = self.statistics
        sequence = counters.astype(np.int64)
        if statistics.last_counter is not None:
            sequence = np.concatenate(([statistics.last_counter], sequence))
        steps = np.diff(sequence) % (1 << 32)
        backwards = steps >= (1 << 31)
        forward_gaps = (steps > 1) & ~backwards
        statistics.counter_gaps += int(np.count_nonzero(forward_gaps))
        statistics.lost_samples += int(np.sum(steps[forward_gaps] - 1))
        statistics.counter_resets += int(np.count_nonzero(backwards | (steps == 0)))
        statistics.last_counter = int(counters[-1])


def saturated_rows(decoded: DecodedFrames) -> np.ndarray:
    """(n,) bool: frames whose board set the over-range status bit or with an analog channel at
    ``ADC_COUNT_MIN`` or ``ADC_COUNT_MAX`` (a clipped reading cannot be told from one exactly at the limit)."""
    at_limit = (decoded.counts == ADC_COUNT_MIN) | (decoded.counts == ADC_COUNT_MAX)
    return ((decoded.status & STATUS_BIT_OVERRANGE) != 0) | np.any(at_limit, axis=1)


def _empty_frames() -> DecodedFrames:
    return DecodedFrames(
        counters=np.zeros(0, dtype=np.uint32),
        counts=np.zeros((0, ANALOG_CHANNEL_COUNT), dtype=np.int16),
        status=np.zeros(0, dtype=np.uint8),
    )


def _non_overlapping(positions: np.ndarray) -> np.ndarray:
    """Mask of CRC-valid frame positions not overlapping an earlier kept one (first one wins)."""
    keep = np.ones(positions.shape, dtype=bool)
    if positions.size < 2 or np.all(np.diff(positions) >= FRAME_LENGTH_BYTES):
        return keep
    end = -1
    for index, position in enumerate(positions.tolist()):
        keep[index] = position >= end
        if keep[index]:
            end = position + FRAME_LENGTH_BYTES
    return keep


def _covered_by(positions: np.ndarray, frame_starts: np.ndarray) -> np.ndarray:
    """True where a position lies inside one of the accepted frames starting at ``frame_starts``."""
    if frame_starts.size == 0 or positions.size == 0:
        return np.zeros(positions.shape, dtype=bool)
    index = np.searchsorted(frame_starts, positions, side="right") - 1
    inside = index >= 0
    start = frame_starts[np.maximum(index, 0)]
    return inside & (positions < start + FRAME_LENGTH_BYTES)


@dataclass(frozen=True)
class DaqIdentity:
    """What the board reports to ``ID?``.

    volts_per_count : (8,) volts per ADC count of the analog channels; the Hall line is a bit shown
    as 0 V or ``hall_high_v`` volts.
    """

    model: str
    serial_number: str
    firmware: str
    channels: tuple[str, ...]
    volts_per_count: tuple[float, ...]
    range_v: float
    hall_high_v: float
    baud: int
    max_rate_hz: float


def format_identity(identity: DaqIdentity) -> str:
    """Format the ``ID?`` reply line (without the newline)."""
    return (
        f"ID model={identity.model} serial={identity.serial_number} firmware={identity.firmware} "
        f"channels={','.join(identity.channels)} "
        f"volts_per_count={','.join(repr(float(v)) for v in identity.volts_per_count)} "
        f"range_v={identity.range_v!r} hall_high_v={identity.hall_high_v!r} baud={identity.baud} "
        f"max_rate_hz={identity.max_rate_hz!r}"
    )


def parse_identity(line: str) -> DaqIdentity:
    """Parse an ``ID ...`` reply line; raises ValueError if a field is missing or malformed."""
    words = line.strip().split()
    if not words or words[0] != "ID":
        raise ValueError(f"not an ID reply: {line!r}")
    fields = dict(word.split("=", 1) for word in words[1:] if "=" in word)
    missing = sorted(
        {
            "model",
            "serial",
            "firmware",
            "channels",
            "volts_per_count",
            "range_v",
            "hall_high_v",
            "baud",
            "max_rate_hz",
        }
        - fields.keys()
    )
    if missing:
        raise ValueError(f"ID reply lacks {', '.join(missing)}: {line!r}")
    volts_per_count = tuple(float(v) for v in fields["volts_per_count"].split(","))
    channels = tuple(fields["channels"].split(","))
    if len(volts_per_count) != ANALOG_CHANNEL_COUNT or len(channels) != len(CHANNEL_NAMES):
        raise ValueError(f"ID reply lists the wrong number of channels: {line!r}")
    return DaqIdentity(
        model=fields["model"],
        serial_number=fields["serial"],
        firmware=fields["firmware"],
        channels=channels,
        volts_per_count=volts_per_count,
        range_v=float(fields["range_v"]),
        hall_high_v=float(fields["hall_high_v"]),
        baud=int(fields["baud"]),
        max_rate_hz=float(fields["max_rate_hz"]),
    )


def counts_to_volts(decoded: DecodedFrames, identity: DaqIdentity) -> np.ndarray:
    """Return the (n, 9) float64 volts of decoded frames, Hall as 0 V or ``hall_high_v``."""
    volts = np.empty((len(decoded), len(CHANNEL_NAMES)), dtype=np.float64)
    np.multiply(decoded.counts, np.asarray(identity.volts_per_count), out=volts[:, :8])
    volts[:, 8] = np.where(decoded.status & STATUS_BIT_HALL, identity.hall_high_v, 0.0)
    return volts
