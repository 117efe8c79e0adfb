"""The balance stream: a display copy always, a recorder while one is attached (sweeps and manual records).

A pump thread takes every block from the DAQ driver. It hands it to the attached :class:`Recorder` (whose
bounded queue never waits) and offers a decimated copy to a drop-oldest :class:`DisplayFeed`, so a slow or frozen
display can never cost a recorded sample. While recording it remembers the sample counters of the recent rows, so
a set point's rows are chosen by when the board *took* them (:meth:`LiveBalance.row_sampled_at`), not by
when they reached the host, and a record with counter gaps is recognised (:meth:`LiveBalance.samples_missing_in_rows`).
:meth:`LiveBalance.measure` averages the next ``record_s`` of full-rate rows (a wind-off tare) and, while
recording, names the rows it used, so a manual tare or measurement becomes a set point of the run exactly as a
sweep's would. Every row is flagged for the recorder: saturated (the board's over-range status bit, or an analog
channel at its ADC limit) and over the sensor's rated load (the calibration file's ``max`` per axis, from the raw
gauge volts); the recorder counts them per set point. Link health (CRC failures, garbage bytes and resyncs, lost
samples) and clipping are counted here for a status display.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ornitail.acquisition.balance_interface import BalanceStream
from ornitail.acquisition.counter_gaps import CounterGap, find_counter_gaps
from ornitail.acquisition.daq_protocol import ANALOG_CHANNEL_COUNT, CHANNEL_NAMES
from ornitail.acquisition.recorder import DisplayFeed, Recorder
from ornitail.acquisition.recording_layout import (
    ROW_FLAG_OVER_RATED_RANGE,
    ROW_FLAG_SATURATED,
    ChannelSpec,
    StreamLayout,
)
from ornitail.acquisition.rig import Rig
from ornitail.core.errors import UserInputError

GET_BLOCK_TIMEOUT_S = 0.1
RECENT_BLOCKS_KEPT = 2000
"""Recorded blocks whose counters are remembered to find where a set point begins (the driver delivers ~100 a
second: many seconds of backlog). Gaps are remembered for the whole recording."""


@dataclass(frozen=True)
class LinkHealth:
    """Counts since the stream started: CRC failures, samples lost on the link, blocks the driver dropped,
    samples the recorder's writer queue dropped, clipped samples per analog channel (``CHANNEL_NAMES[:8]``),
    bytes outside valid frames and the stretches of them (resyncs), and rows flagged saturated or over the
    sensor's rated load.

    ``recording_lost_samples`` is the one count of lost samples of the current (or last) recording,
    ``recording_run_id``: the samples its counters say are missing in its file, which is what ``ornitail runs``
    and the sweep report show for that run (link, driver-queue and recorder-queue losses each counted once).
    """

    crc_errors: int
    link_lost_samples: int
    driver_dropped_blocks: int
    recorder_lost_samples: int
    clipped_samples: tuple[int, ...]
    garbage_bytes: int = 0
    resyncs: int = 0
    saturated_samples: int = 0
    over_range_samples: int = 0
    recording_run_id: str | None = None
    recording_lost_samples: int = 0

    @property
    def saturated_channels(self) -> list[str]:
        """Names of the analog channels that clipped at the ADC range at least once."""
        return [
            name for name, count in zip(CHANNEL_NAMES, self.clipped_samples, strict=False) if count
        ]


@dataclass(frozen=True)
class MeasuredRows:
    """What :meth:`LiveBalance.measure` saw: mean of each channel (V, ``CHANNEL_NAMES`` order), the row count,
    and the first and last recorder row index (None when no recorder was attached)."""

    mean_volts: np.ndarray
    rows: int
    first_row_index: int | None
    last_row_index: int | None


def balance_stream_layout(sample_rate_hz: float) -> StreamLayout:
    """The recorded layout of the DAQ board's nine channels (V), as a sweep records them."""
    return StreamLayout(
        channels=[ChannelSpec(name, "V") for name in CHANNEL_NAMES],
        sample_rate_hz=sample_rate_hz,
        sample_dtype="float32",
        counter_dtype="uint32",
    )


class _Measurement:
    """Sums of ``rows`` rows, from the first the board took at or after ``first_counter`` (None: the next one
    to arrive)."""

    def __init__(self, rows: int, recorder: Recorder | None, first_counter: int | None) -> None:
        self.rows_wanted = rows
        self.recorder = recorder
        self.first_counter = first_counter
        self.sums = np.zeros(len(CHANNEL_NAMES))
        self.rows = 0
        self.first_row_index: int | None = None
        self.done = threading.Event()

    def add(self, counters: np.ndarray, volts: np.ndarray, first_row_index: int | None) -> None:
        start = 0
        if self.rows == 0:
            if self.first_counter is not None:
                start = int(np.searchsorted(counters, self.first_counter))
                if start == len(counters):
                    return  # sampled before the measurement was asked for (still in transit then)
            self.first_row_index = None if first_row_index is None else first_row_index + start
        take = min(len(volts) - start, self.rows_wanted - self.rows)
        self.sums += volts[start : start + take].sum(axis=0)
        self.rows += take
        if self.rows >= self.rows_wanted:
            self.done.set()


class LiveBalance:
    """Stream the rig's balance for a display, and into a recorder while one is attached.

    Parameters
    ----------
    rig : Rig
        A connected rig whose balance stream carries the Hall line, hot-wire and thermocouple with the gauges (the
        ORNI-DAQ9 route, or a CAN balance with ``[balance.aux_daq]``).
    display_decimation : int
        Every n-th row goes to :attr:`display_feed` (display only; the recorder gets every row).
    display_capacity_blocks : int
        Blocks the display feed keeps before dropping the oldest.
    """

    def __init__(
        self,
        rig: Rig,
        display_decimation: int = 10,
        display_capacity_blocks: int = 512,
        sample_rate_hz: float | None = None,
    ):
        if rig.balance is None or not rig.balance.carries_flap_channels:
            raise UserInputError(
                f"{rig.description.path}: [balance].route",
                "the live view streams the Hall line and hot-wire with the balance; use route = "
                '"serial_daq", or add the serial board beside the CAN or Net F/T balance as [balance.aux_daq]',
            )
        self.rig = rig
        self.driver: BalanceStream = rig.balance
        self.display_feed = DisplayFeed(display_decimation, display_capacity_blocks)
        self.sample_rate_hz = float(sample_rate_hz or rig.description.balance_sample_rate_hz())
        self.error: BaseException | None = None
        self._recorder: Recorder | None = None
        self._measurement: _Measurement | None = None
        self._lock = threading.Lock()
        self._report_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._rows_seen = 0
        self._reported = (0, 0, 0, 0)  # crc, lost, garbage bytes, resyncs already reported
        self._recorder_lost_before = 0
        self._last_recorder: Recorder | None = None
        self._saturated_samples = 0
        self._over_range_samples = 0
        calibration = rig.calibration
        self._gauge_volts_to_load = np.asarray(calibration.sensor_matrix_si, dtype=float)
        self._rated_load = np.asarray(calibration.ranges_si, dtype=float)
        self._clipped = np.zeros(ANALOG_CHANNEL_COUNT, dtype=np.int64)
        self._clip_low_v = self._clip_high_v = np.zeros(ANALOG_CHANNEL_COUNT)
        self._first_counter: int | None = None
        self._recent_rows: deque[tuple[int, np.ndarray]] = deque(maxlen=RECENT_BLOCKS_KEPT)
        self._recorded_gaps: list[
            CounterGap
        ] = []  # in the attached recorder's rows, however long ago
        self._last_recorded_counter: int | None = None
        self._last_counter_delivered: int | None = None  # recorded or not

    # -- stream -----------------------------------------------------------------------------
    def start(self, sample_rate_hz: float | None = None) -> None:
        """Start the board's stream (at ``sample_rate_hz``, default: as constructed) and the pump thread."""
        if sample_rate_hz is not None:
            self.sample_rate_hz = float(sample_rate_hz)
        self.error = None
        self._first_counter = None
        self.rig.start_balance(self.sample_rate_hz)
        self._clip_low_v, self._clip_high_v = self.driver.adc_limits_v()
        self._stop.clear()
        self._thread = threading.Thread(target=self._pump, name="live-balance", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the pump and the board's stream (the attached recorder, if any, stays open)."""
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join(timeout=2.0)
        self._thread = None
        self.rig.stop_balance()

    @property
    def running(self) -> bool:
        """True while the pump thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def _pump(self) -> None:
        try:
            while not self._stop.is_set():
                block = self.driver.read_block(timeout_s=GET_BLOCK_TIMEOUT_S)
                if block is None:
                    continue
                self._deliver(block.counters, block.volts, block.saturated)
        except BaseException as error:  # reported by health(); the display shows it
            self.error = error

    def row_flags(
        self,
        volts: np.ndarray,
        saturated: np.ndarray | None,
        clipped: np.ndarray | None = None,
    ) -> np.ndarray:
        """(n,) uint8 flags of rows: ``ROW_FLAG_SATURATED`` from the board's status (or, without it, a channel
        at its ADC limit; ``clipped``: (n, 8) bool, if already known) and ``ROW_FLAG_OVER_RATED_RANGE`` where a
        sensor-frame load from the raw gauge volts exceeds the calibration's rated load (no bias removed: the
        gauges' zero offsets, typically under 0.1 V, shift the check by a few percent of the rating)."""
        if saturated is None:
            if clipped is None:
                analog = volts[:, :ANALOG_CHANNEL_COUNT]
                clipped = (analog <= self._clip_low_v) | (analog >= self._clip_high_v)
            saturated = clipped.any(axis=1)
        loads = volts[:, :6] @ self._gauge_volts_to_load.T
        over_range = (np.abs(loads) > self._rated_load).any(axis=1)
        flags = saturated.astype(np.uint8) * np.uint8(ROW_FLAG_SATURATED)
        flags |= over_range.astype(np.uint8) * np.uint8(ROW_FLAG_OVER_RATED_RANGE)
        return flags

    def _deliver(
        self, counters: np.ndarray, volts: np.ndarray, saturated: np.ndarray | None = None
    ) -> None:
        analog = volts[:, :ANALOG_CHANNEL_COUNT]
        clipped = (analog <= self._clip_low_v) | (analog >= self._clip_high_v)
        self._clipped += clipped.sum(axis=0)
        flags = self.row_flags(volts, saturated, clipped)
        self._saturated_samples += int(np.count_nonzero(flags & ROW_FLAG_SATURATED))
        self._over_range_samples += int(np.count_nonzero(flags & ROW_FLAG_OVER_RATED_RANGE))
        with self._lock:
            recorder, measurement = self._recorder, self._measurement
        if self._first_counter is None:
            self._first_counter = int(counters[0])
        first_row: int | None = None
        if recorder is not None:
            first_row = recorder.next_sample_index
            if recorder.put_block(counters, volts, flags):
                if self._last_recorded_counter is None:
                    self._exclude_loss_before_first_row(int(counters[0]))
                gaps = find_counter_gaps(counters, self._last_recorded_counter, first_row)
                with self._lock:
                    self._recent_rows.append((first_row, counters))
                    self._recorded_gaps += gaps
                self._last_recorded_counter = int(counters[-1])
                self._report_link_health(recorder)
            else:
                first_row = None
        if measurement is not None and (measurement.recorder is None or first_row is not None):
            measurement.add(counters, volts, first_row)
        self.display_feed.offer(counters, volts, self._rows_seen)
        self._rows_seen += len(counters)
        self._last_counter_delivered = int(counters[-1])

    def _exclude_loss_before_first_row(self, first_counter: int) -> None:
        """Samples lost just before a recording's first row are not the recording's (its file cannot show them):
        keep them out of the link losses reported to it, so its link losses stay part of its lost samples."""
        if self._last_counter_delivered is None:
            return
        gaps = find_counter_gaps(
            np.array([first_counter], dtype=np.uint32), self._last_counter_delivered
        )
        leading = sum(gap.missing_samples for gap in gaps)
        if leading:
            with self._report_lock:
                crc, lost, garbage, resyncs = self._reported
                newly_lost = self.driver.link_counts().lost_samples - lost
                self._reported = (crc, lost + min(leading, max(0, newly_lost)), garbage, resyncs)

    def _report_link_health(self, recorder: Recorder) -> None:
        with self._report_lock:  # the pump and detach() both report; each increment exactly once
            counts = self._link_counts()
            if counts != self._reported:
                crc, lost, garbage, resyncs = (
                    max(0, now - before) for now, before in zip(counts, self._reported, strict=True)
                )
                recorder.report_link_health(
                    crc_errors=crc, lost_samples=lost, garbage_bytes=garbage, resyncs=resyncs
                )
                self._reported = counts

    def _link_counts(self) -> tuple[int, int, int, int]:
        statistics = self.driver.link_counts()
        return (
            statistics.crc_failures,
            statistics.lost_samples,
            statistics.garbage_bytes,
            statistics.resyncs,
        )

    # -- recording --------------------------------------------------------------------------
    def attach(self, recorder: Recorder) -> None:
        """Send every following block to ``recorder`` (an entered :class:`Recorder`)."""
        with self._lock, self._report_lock:
            self._reported = self._link_counts()
            self._recent_rows.clear()  # row indices belong to one recorder
            self._recorded_gaps = []
            self._last_recorded_counter = None
            self._recorder = recorder

    def detach(self) -> Recorder | None:
        """Stop sending blocks to the recorder; return it (the caller closes it)."""
        with self._lock:
            recorder, self._recorder = self._recorder, None
        if recorder is not None:
            self._report_link_health(recorder)  # what arrived since the last block counts too
            self._recorder_lost_before += recorder.queue_lost_samples
            self._last_recorder = recorder
        return recorder

    @property
    def recorder(self) -> Recorder | None:
        """The attached recorder, if any."""
        return self._recorder

    def raise_if_failed(self) -> None:
        """Raise the pump's error (an unplugged board, a failed recorder), if it ended with one."""
        if self.error is not None:
            raise self.error

    def row_sampled_at(self, samples_since_start: int) -> tuple[int, int] | None:
        """Row index (in the attached recorder) of the first recorded sample the board took at least
        ``samples_since_start`` samples after the stream's first (counters continue across streams), and the
        samples the board took from ``samples_since_start`` up to that row which the link lost (0 unless the sample
        fell into a counter gap); None until such a sample has been recorded."""
        with self._lock:
            if self._first_counter is None:
                return None
            counter = self._first_counter + samples_since_start
            blocks = list(self._recent_rows)
        for first_row, counters in blocks:
            if counters[-1] >= counter:
                position = int(np.searchsorted(counters, counter))
                return first_row + position, max(0, int(counters[position]) - counter)
        return None

    def samples_missing_in_rows(self, first_row: int, row_count: int) -> int:
        """Samples the counters say were lost between recorded rows ``first_row`` and ``first_row + row_count - 1``
        (on the link, or in a block the recorder's full queue refused)."""
        last_row = first_row + row_count - 1
        with self._lock:
            gaps = list(self._recorded_gaps)
        return sum(gap.missing_samples for gap in gaps if first_row < gap.row_index <= last_row)

    @contextmanager
    def alignment_held(self) -> Iterator[None]:
        """While the block runs, the stream places every device's samples on the host clock as it does now
        (:meth:`BalanceStream.hold_alignment`): a record's rows are all aligned alike."""
        self.driver.hold_alignment()
        try:
            yield
        finally:
            self.driver.release_alignment()  # the move it kept out is in alignment_values()

    def measure(self, record_s: float, timeout_s: float) -> MeasuredRows:
        """Average the ``record_s`` of full-rate rows the board takes from now on (chosen by sample counter, as a
        sweep's set point is); blocks until they arrived (wall ``timeout_s``).

        While a recorder is attached, only rows it accepted count and their row indices are returned, so the
        caller can journal them as a set point.
        """
        if not self.running:
            raise RuntimeError("the balance is not streaming: start() first")
        rows = max(1, int(round(record_s * self.sample_rate_hz)))
        with self.alignment_held():  # the rows are taken from now on
            with self._lock:
                first_counter = (
                    None
                    if self._first_counter is None
                    else self._first_counter + self.rig.balance_samples_since_start()
                )
                measurement = _Measurement(rows, self._recorder, first_counter)
                self._measurement = measurement
            try:
                if not measurement.done.wait(timeout_s):
                    if self.error is not None:
                        raise self.error
                    raise TimeoutError(
                        f"{self.driver.name}: {rows} rows did not arrive within {timeout_s:g} s"
                    )
            finally:
                with self._lock:
                    self._measurement = None
        first = measurement.first_row_index
        return MeasuredRows(
            mean_volts=measurement.sums / measurement.rows,
            rows=measurement.rows,
            first_row_index=first,
            last_row_index=None if first is None else first + measurement.rows - 1,
        )

    def alignment_values(self) -> dict[str, float | int]:
        """The balance stream's alignment of its devices now, for a set point's journal entry (empty for one
        device)."""
        return self.driver.alignment_values()

    # -- status -----------------------------------------------------------------------------
    def health(self) -> LinkHealth:
        """Link health and clipping since the stream started (recorder losses over every recording)."""
        statistics = self.driver.link_counts()
        recorder = self._recorder
        recorder_lost = self._recorder_lost_before + (
            recorder.queue_lost_samples if recorder is not None else 0
        )
        recording = recorder if recorder is not None else self._last_recorder
        return LinkHealth(
            crc_errors=statistics.crc_failures,
            link_lost_samples=statistics.lost_samples,
            driver_dropped_blocks=self.driver.blocks_dropped,
            recorder_lost_samples=recorder_lost,
            clipped_samples=tuple(int(count) for count in self._clipped),
            garbage_bytes=statistics.garbage_bytes,
            resyncs=statistics.resyncs,
            saturated_samples=self._saturated_samples,
            over_range_samples=self._over_range_samples,
            recording_run_id=None if recording is None else recording.run_id,
            recording_lost_samples=0 if recording is None else recording.lost_samples,
        )
