"""The recorder: raw sample blocks from a driver thread to a flushed HDF5 file, without silent loss.

Data path: driver thread -> :meth:`Recorder.put_block` -> bounded queue -> writer thread -> HDF5
(flushed after every write). A full queue drops the block and counts it as lost; it never blocks the
driver. An optional drop-oldest :class:`DisplayFeed` gives a GUI a decimated copy that can never
slow the writer. Completed set points go through the same queue (so they are journaled only after
their samples are flushed and ``samples.h5`` is fsynced), into the HDF5 set-point table and an fsynced
journal line. Rows a driver flags (saturated, over the sensor's rated load) are counted per set point.

The writer thread waits on nothing but the disk. The recorder does not know the catalog: whoever runs the
run subscribes a :class:`~ornitail.acquisition.catalog_subscriber.CatalogSubscriber` to the run's documents
(:func:`ornitail.acquisition.run_engine.open_run`), which carry :meth:`Recorder.metadata_snapshot`.

Use it as a context manager: ``__exit__`` always writes the stop record (``completed``,
``incomplete``, ``aborted`` or ``failed`` with the exception text) to ``run.json``. File layout:
``docs/recordings.md``.
"""

from __future__ import annotations

import bisect
import collections
import copy
import importlib.metadata
import json
import math
import os
import queue
import re
import secrets
import socket
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import numpy as np

from ornitail.acquisition.calibration_copies import (
    calibration_copy_names,
    write_calibration_copies,
)
from ornitail.acquisition.catalog import utc_now_iso
from ornitail.acquisition.counter_gaps import find_counter_gaps
from ornitail.acquisition.recording_layout import (
    EXIT_STATUS_ABORTED,
    EXIT_STATUS_COMPLETED,
    EXIT_STATUS_FAILED,
    EXIT_STATUS_INCOMPLETE,
    EXIT_STATUS_RUNNING,
    HDF5_RAW_SAMPLES_PATH,
    HDF5_SAMPLE_COUNTER_PATH,
    HDF5_SET_POINT_COLUMNS,
    HDF5_SET_POINTS_GROUP,
    RECORDING_FORMAT_NAME,
    RECORDING_FORMAT_VERSION,
    ROW_FLAG_OVER_RATED_RANGE,
    ROW_FLAG_SATURATED,
    RUN_METADATA_FILE_NAME,
    RUNS_FOLDER_NAME,
    SAMPLES_FILE_NAME,
    SET_POINT_KIND_TARE,
    RunAborted,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
    summarize_set_points,
)
from ornitail.acquisition.recording_reader import MAX_STORED_GAP_POSITIONS, set_point_saturation
from ornitail.acquisition.run_files import RunLock, append_journal_line, write_json_atomically
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_bytes
from ornitail.core.input_files import read_input_bytes

TARGET_CHUNK_BYTES = 256 * 1024
WRITER_STOP_TIMEOUT_S = 60.0
SET_POINT_QUEUE_TIMEOUT_S = 10.0
WRITE_INTERVAL_S = 0.1
"""The writer gathers about this much data (s) before each write and flush; a crash loses at most this much
more than what the queue holds."""


class RecorderFailed(RuntimeError):
    """The writer thread stopped with an error; no further samples can be recorded."""


class FlaggedRows:
    """Rows carrying one flag, kept as merged half-open row intervals ``[start, end)`` (a channel held at its
    limit for an hour is one interval)."""

    def __init__(self) -> None:
        self._starts: list[int] = []
        self._ends: list[int] = []
        self.total = 0

    def add(self, first_row: int, mask: np.ndarray) -> None:
        """Add the rows ``first_row + i`` where ``mask[i]`` is true (rows come in increasing order)."""
        if not mask.any():
            return
        edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
        for start, end in zip(edges[0::2].tolist(), edges[1::2].tolist(), strict=True):
            start, end = start + first_row, end + first_row
            if self._ends and self._ends[-1] == start:
                self._ends[-1] = end
            else:
                self._starts.append(start)
                self._ends.append(end)
            self.total += end - start

    def count_in(self, first_row: int, last_row: int) -> int:
        """Flagged rows among ``first_row .. last_row`` (inclusive)."""
        count = 0
        index = bisect.bisect_right(self._ends, first_row)
        while index < len(self._starts) and self._starts[index] <= last_row:
            count += min(self._ends[index], last_row + 1) - max(self._starts[index], first_row)
            index += 1
        return count


@dataclass
class _SampleBlock:
    counters: np.ndarray
    samples: np.ndarray


@dataclass
class _CompletedSetPoint:
    record: SetPointRecord


_STOP_WRITER = object()


def software_version() -> str:
    """Installed version of ornitail (``"unknown"`` when run from an uninstalled tree)."""
    try:
        return importlib.metadata.version("ornitail")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def new_run_id(configuration: RunConfiguration, start: datetime) -> str:
    """Return a unique, readable run id such as ``20240607T101530Z-S3-tailed-4f9a2c``."""
    tail = re.sub(r"[^A-Za-z0-9_.-]", "_", configuration.tail_id or "notail")
    tailed = "tailed" if configuration.tailed else "tailless"
    return f"{start:%Y%m%dT%H%M%SZ}-{tail}-{tailed}-{secrets.token_hex(3)}"


class DisplayFeed:
    """A drop-oldest queue of decimated sample blocks for a live display.

    Every ``decimation``-th row of the recording (row index divisible by ``decimation``) is kept.
    When ``capacity_blocks`` blocks wait, the oldest is dropped: the display never slows the writer.
    """

    def __init__(self, decimation: int, capacity_blocks: int) -> None:
        if decimation < 1 or capacity_blocks < 1:
            raise ValueError("decimation and capacity_blocks must be at least 1")
        self.decimation = decimation
        self._blocks: collections.deque[tuple[np.ndarray, np.ndarray]] = collections.deque(
            maxlen=capacity_blocks
        )
        self.dropped_blocks = 0

    def offer(self, counters: np.ndarray, samples: np.ndarray, first_row_index: int) -> None:
        """Add the decimated rows of one block (called by the recorder in the driver thread)."""
        first_kept = (-first_row_index) % self.decimation
        if first_kept >= len(counters):
            return
        if len(self._blocks) == self._blocks.maxlen:
            self.dropped_blocks += 1
        self._blocks.append(
            (counters[first_kept :: self.decimation], samples[first_kept :: self.decimation])
        )

    def take_all(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Remove and return the waiting ``(counters, samples)`` blocks, oldest first."""
        taken = []
        while True:
            try:
                taken.append(self._blocks.popleft())
            except IndexError:
                return taken


class Recorder:
    """Record one run into a new run directory under ``<data_root>/runs/``.

    Parameters
    ----------
    data_root : pathlib.Path
        Folder of runs and ``catalog.sqlite``; created if missing.
    configuration : RunConfiguration
        Tail, x_h (m), tailed/tailless, plan name.
    stream : StreamLayout
        Channels (raw units), sample rate (Hz), sample and counter dtypes.
    rig_description : mapping, optional
        JSON-serialisable description of the rig (devices, ports, firmware, ...).
    calibration_files : mapping of str to path, optional
        Label -> calibration file; each is hashed (sha256) into the metadata and copied into
        ``<run>/calibration/`` at start (``docs/recordings.md``, "Calibration files").
    bias_voltages_v : mapping of str to float, optional
        Channel name -> bias voltage (V) known at start; see :meth:`update_bias_voltages`.
    queue_capacity_blocks : int
        Blocks the writer queue holds before new blocks are dropped and counted as lost.
    display_decimation : int or None
        If given, :attr:`display_feed` receives every n-th row.
    display_capacity_blocks : int
        Blocks the display feed keeps (drop-oldest).
    """

    def __init__(
        self,
        data_root: Path,
        configuration: RunConfiguration,
        stream: StreamLayout,
        *,
        rig_description: Mapping[str, Any] | None = None,
        calibration_files: Mapping[str, Path | str] | None = None,
        bias_voltages_v: Mapping[str, float] | None = None,
        queue_capacity_blocks: int = 64,
        display_decimation: int | None = None,
        display_capacity_blocks: int = 64,
    ) -> None:
        configuration.validate()
        stream.validate()
        if queue_capacity_blocks < 1:
            raise ValueError("queue_capacity_blocks must be at least 1")
        self.data_root = Path(data_root)
        self.configuration = configuration
        self.stream = stream
        self._channel_names = [channel.name for channel in stream.channels]
        self._sample_dtype = np.dtype(stream.sample_dtype)
        self._counter_dtype = np.dtype(stream.counter_dtype)
        self._rig_description = dict(rig_description or {})
        _require_json_serialisable("rig_description", self._rig_description)
        calibration_paths = {label: Path(path) for label, path in (calibration_files or {}).items()}
        copy_names = calibration_copy_names(calibration_paths)
        self._calibration_copies: dict[str, bytes] = {}
        self._calibration_files: dict[str, dict[str, str]] = {}
        for label, path in calibration_paths.items():
            content = read_input_bytes(path)  # read once: the copy is exactly what was hashed
            self._calibration_copies[copy_names[label]] = content
            self._calibration_files[label] = {
                "path": str(path.resolve()),
                "hash": content_hash_of_bytes(content),
                "copy": copy_names[label],
            }
        self._metadata_lock = threading.Lock()
        self._bias_voltages_v: dict[str, float] = {}
        if bias_voltages_v:
            self._set_bias(bias_voltages_v)
        self._start_time = datetime.now(UTC)
        self.run_id = new_run_id(configuration, self._start_time)
        self.run_directory = self.data_root / RUNS_FOLDER_NAME / self.run_id
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=queue_capacity_blocks)
        self.display_feed = (
            DisplayFeed(display_decimation, display_capacity_blocks) if display_decimation else None
        )
        self.exit_status: str | None = None
        """After the run: its exit status as written in the stop record (None while it runs)."""
        self.exit_reason: str | None = None
        """After the run: why it did not complete, as written in the stop record."""
        self._current_metadata: dict[str, Any] = {}
        self._run_lock = RunLock(self.run_directory)
        self._samples_file: h5py.File | None = None
        self._writer_thread: threading.Thread | None = None
        self._writer_error: BaseException | None = None
        self._writer_cpu_s: float | None = None
        self._accepting_blocks = False
        self._abort_reason: str | None = None
        self._incomplete_reason: str | None = None
        # Counted in the driver thread (put_block) and by report_link_health:
        self._next_sample_index = 0
        self._queue_lost_blocks = 0
        self._queue_lost_samples = 0
        self._queue_loss_positions: list[dict[str, int]] = []
        self._link_crc_errors = 0
        self._link_lost_samples = 0
        self._link_garbage_bytes = 0
        self._link_resyncs = 0
        self._link_foreign_frames = 0
        self._link_report_count = 0
        # Rows flagged by the driver (put_block), read by complete_set_point in the caller's thread:
        self._flag_lock = threading.Lock()
        self._flags_checked = False
        self._flagged_rows = {
            ROW_FLAG_SATURATED: FlaggedRows(),
            ROW_FLAG_OVER_RATED_RANGE: FlaggedRows(),
        }
        # Written only by the writer thread:
        self._rows_written = 0
        self._last_counter: int | None = None
        self._gap_count = 0
        self._gap_missing_samples = 0
        self._gap_positions: list[dict[str, Any]] = []
        self._set_points: list[SetPointRecord] = []

    # ----- driver side -------------------------------------------------------------------------

    @property
    def next_sample_index(self) -> int:
        """Row index the next accepted sample will get (= samples accepted so far)."""
        return self._next_sample_index

    @property
    def queue_lost_samples(self) -> int:
        """Samples dropped because the writer queue was full (0 while the writer keeps up)."""
        return self._queue_lost_samples

    @property
    def flushed_sample_count(self) -> int:
        """Samples written to ``samples.h5`` and flushed so far (they survive a crash)."""
        return self._rows_written

    @property
    def lost_samples(self) -> int:
        """Samples lost so far, each counted once: those the sample counters say are missing among the rows
        written (link, driver or recorder-queue losses alike; ``run.json``'s ``counter_gaps.missing_samples``)."""
        return self._gap_missing_samples

    @property
    def rig_description(self) -> dict[str, Any]:
        """The rig's description as ``run.json`` holds it (a copy)."""
        return copy.deepcopy(self._rig_description)

    def metadata_snapshot(self) -> dict[str, Any]:
        """A copy of the run's metadata as it stands (``run.json``'s content, with the counts of the set points
        journalled so far): the stop record once the run has ended."""
        with self._metadata_lock:
            return copy.deepcopy(self._current_metadata)

    def put_block(
        self, counters: np.ndarray, samples: np.ndarray, flags: np.ndarray | None = None
    ) -> bool:
        """Hand one block of raw samples to the writer; never blocks (call from one thread).

        Parameters
        ----------
        counters : numpy.ndarray
            Shape ``(n,)``, non-negative integers: the driver's sample counter of each row.
        samples : numpy.ndarray
            Shape ``(n, n_channels)``: raw values (V or ADC counts) in the layout's channel order.
        flags : numpy.ndarray, optional
            Shape ``(n,)`` uint8 bitmask per row: ``ROW_FLAG_SATURATED`` (a channel at the ADC limit or the
            device's over-range status), ``ROW_FLAG_OVER_RATED_RANGE`` (load beyond the sensor's rating).
            Giving flags (even all zero) marks the run as checked; rows are counted per set point.

        Returns
        -------
        bool
            True if queued; False if the queue was full and the block was counted as lost (do
            not retry it: a retried block would be counted twice).
        """
        if self._writer_error is not None:
            raise RecorderFailed(f"the writer stopped: {self._writer_error!r}")
        if not self._accepting_blocks:
            raise RuntimeError("put_block called outside the recorder's with-block")
        counters_copy, samples_copy = self._checked_copies(counters, samples)
        row_count = len(counters_copy)
        if flags is not None:
            flags = np.asarray(flags)
            if flags.shape != (row_count,) or flags.dtype.kind not in "iub":
                raise ValueError(
                    f"flags must be ({row_count},) integers, got {flags.shape} {flags.dtype}"
                )
        try:
            self._queue.put_nowait(_SampleBlock(counters_copy, samples_copy))
        except queue.Full:
            self._queue_lost_blocks += 1
            self._queue_lost_samples += row_count
            if len(self._queue_loss_positions) < MAX_STORED_GAP_POSITIONS:
                self._queue_loss_positions.append(
                    {
                        "before_row_index": self._next_sample_index,
                        "first_counter": int(counters_copy[0]),
                        "samples": row_count,
                    }
                )
            return False
        if self.display_feed is not None:
            self.display_feed.offer(counters_copy, samples_copy, self._next_sample_index)
        if flags is not None:
            with self._flag_lock:
                self._flags_checked = True
                for bit, rows in self._flagged_rows.items():
                    rows.add(self._next_sample_index, (flags.astype(np.uint8) & bit) != 0)
        self._next_sample_index += row_count
        return True

    def _checked_copies(
        self, counters: np.ndarray, samples: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        counters = np.asarray(counters)
        samples = np.asarray(samples)
        channel_count = len(self._channel_names)
        if samples.ndim != 2 or samples.shape[1] != channel_count or samples.shape[0] == 0:
            raise ValueError(
                f"samples must have shape (n >= 1, {channel_count}), got {samples.shape}"
            )
        if counters.shape != (samples.shape[0],):
            raise ValueError(
                f"counters must have shape ({samples.shape[0]},), got {counters.shape}"
            )
        if counters.dtype.kind not in "iu":
            raise ValueError(f"counters must be integers, got dtype {counters.dtype}")
        if counters.dtype.kind == "i" and counters.min() < 0:
            raise ValueError("counters must be non-negative")
        if not np.can_cast(samples.dtype, self._sample_dtype, casting="same_kind"):
            raise ValueError(f"samples of dtype {samples.dtype} do not fit {self._sample_dtype}")
        return counters.astype(self._counter_dtype), samples.astype(self._sample_dtype)

    def report_link_health(
        self,
        crc_errors: int = 0,
        lost_samples: int = 0,
        *,
        garbage_bytes: int = 0,
        resyncs: int = 0,
        foreign_frames: int = 0,
    ) -> None:
        """Add what the driver detected since its last report: CRC failures, lost samples (its counter gaps),
        bytes outside valid frames, stretches of them (resynchronisations), and frames from another node that
        used the device's identifiers."""
        counts = (crc_errors, lost_samples, garbage_bytes, resyncs, foreign_frames)
        if min(counts) < 0:
            raise ValueError("link health counts must be non-negative")
        with self._metadata_lock:
            self._link_crc_errors += int(crc_errors)
            self._link_lost_samples += int(lost_samples)
            self._link_garbage_bytes += int(garbage_bytes)
            self._link_resyncs += int(resyncs)
            self._link_foreign_frames += int(foreign_frames)
            self._link_report_count += 1

    # ----- sweep side --------------------------------------------------------------------------

    def complete_set_point(self, record: SetPointRecord) -> None:
        """Record a completed set point; it is journaled after its samples are flushed.

        ``record.first_sample_index``/``last_sample_index`` are row indices from
        :attr:`next_sample_index`; the recorder fills ``set_point_index``, ``completed_utc``,
        ``link_health`` and, when the driver flags rows, ``saturated_samples`` and
        ``over_range_samples`` (at once: the caller can warn about them).
        """
        record.validate()
        _require_json_serialisable("set point", record.to_json_dict())
        if record.last_sample_index >= self._next_sample_index:
            raise ValueError(
                f"set point ends at row {record.last_sample_index} but only "
                f"{self._next_sample_index} rows were accepted"
            )
        if self._writer_error is not None:
            raise RecorderFailed(f"the writer stopped: {self._writer_error!r}")
        with self._metadata_lock:
            record.link_health = self._link_health_snapshot()
        with self._flag_lock:
            if self._flags_checked:
                first, last = record.first_sample_index, record.last_sample_index
                saturated = self._flagged_rows[ROW_FLAG_SATURATED]
                over_range = self._flagged_rows[ROW_FLAG_OVER_RATED_RANGE]
                record.saturated_samples = saturated.count_in(first, last)
                record.over_range_samples = over_range.count_in(first, last)
        try:
            self._queue.put(_CompletedSetPoint(record), timeout=SET_POINT_QUEUE_TIMEOUT_S)
        except queue.Full:
            raise RecorderFailed("the writer queue stayed full; set point not recorded") from None

    def update_bias_voltages(self, bias_voltages_v: Mapping[str, float]) -> None:
        """Store new bias voltages (channel name -> V) and rewrite ``run.json`` at once."""
        self._set_bias(bias_voltages_v)
        self._write_metadata(EXIT_STATUS_RUNNING, None, None)

    def mark_aborted(self, reason: str) -> None:
        """Record that the user stopped the run; it ends as ``aborted`` with ``reason``."""
        self._abort_reason = reason

    def mark_incomplete(self, reason: str) -> None:
        """Record that some set points are not usable (e.g. lossy after retakes, named in ``reason``); a run
        that otherwise completes ends as ``incomplete`` with ``reason``."""
        self._incomplete_reason = reason

    def _set_bias(self, bias_voltages_v: Mapping[str, float]) -> None:
        for name, value in bias_voltages_v.items():
            if name not in self._channel_names:
                raise UserInputError(f"bias_voltages_v: {name}", "no such channel")
            if not math.isfinite(float(value)):
                raise UserInputError(f"bias_voltages_v: {name}", f"value {value!r} is not finite")
        with self._metadata_lock:
            self._bias_voltages_v.update({k: float(v) for k, v in bias_voltages_v.items()})

    # ----- start and stop ----------------------------------------------------------------------

    def __enter__(self) -> Recorder:
        self.run_directory.mkdir(parents=True, exist_ok=False)
        self._run_lock.acquire()
        try:
            write_calibration_copies(self.run_directory, self._calibration_copies)
            self._write_metadata(EXIT_STATUS_RUNNING, None, None)
            self._create_samples_file()
            self._writer_thread = threading.Thread(
                target=self._writer_loop, name=f"recorder-{self.run_id}", daemon=True
            )
            self._writer_thread.start()
            self._accepting_blocks = True
        except BaseException as error:
            self._finish(EXIT_STATUS_FAILED, f"{type(error).__name__}: {error}")
            raise
        return self

    def __exit__(
        self,
        exception_type: type[BaseException] | None,
        exception: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if exception is None:
            status, reason = EXIT_STATUS_COMPLETED, None
            if self._abort_reason is not None:
                status, reason = EXIT_STATUS_ABORTED, self._abort_reason
            elif self._incomplete_reason is not None:
                status, reason = EXIT_STATUS_INCOMPLETE, self._incomplete_reason
        elif isinstance(exception, RunAborted | KeyboardInterrupt):
            status = EXIT_STATUS_ABORTED
            reason = str(exception) or f"stopped by the user ({type(exception).__name__})"
        else:
            status, reason = EXIT_STATUS_FAILED, f"{type(exception).__name__}: {exception}"
        self._finish(status, reason)

    def _finish(self, status: str, reason: str | None) -> None:
        """Stop the writer, close the file, write the stop record; the record is always written."""
        self._accepting_blocks = False
        try:
            self._stop_writer()
        except BaseException as error:
            status, reason = EXIT_STATUS_FAILED, _joined(reason, f"stopping the writer: {error!r}")
            raise
        finally:
            if self._writer_error is not None:
                writer_text = f"writer: {type(self._writer_error).__name__}: {self._writer_error}"
                status, reason = EXIT_STATUS_FAILED, _joined(reason, writer_text)
            self.exit_status, self.exit_reason = status, reason
            try:
                self._write_metadata(status, reason, utc_now_iso())
            finally:
                self._run_lock.release()

    def _stop_writer(self) -> None:
        thread = self._writer_thread
        if thread is not None and thread.is_alive():
            self._queue.put(_STOP_WRITER, timeout=WRITER_STOP_TIMEOUT_S)
            thread.join(WRITER_STOP_TIMEOUT_S)
            if thread.is_alive():
                raise RecorderFailed(f"writer did not stop within {WRITER_STOP_TIMEOUT_S} s")
        if self._samples_file is not None:
            self._samples_file.close()
            self._samples_file = None
            _fsync_path(self.run_directory / SAMPLES_FILE_NAME)

    # ----- metadata ----------------------------------------------------------------------------

    def _link_health_snapshot(self) -> dict[str, int]:
        return {
            "crc_errors": self._link_crc_errors,
            "link_lost_samples": self._link_lost_samples,
            "queue_lost_samples": self._queue_lost_samples,
            "garbage_bytes": self._link_garbage_bytes,
            "resyncs": self._link_resyncs,
            "foreign_frames": self._link_foreign_frames,
        }

    def _counter_gap_summary(self) -> dict[str, Any]:
        return {
            "count": self._gap_count,
            "missing_samples": self._gap_missing_samples,
            "positions": list(self._gap_positions),
            "positions_truncated": self._gap_count > len(self._gap_positions),
        }

    def _saturation_summary(self) -> dict[str, Any]:
        """Flagged rows of the set points journalled so far, and of the whole stream (``run.json``)."""
        with self._flag_lock:
            checked = self._flags_checked
            stream_saturated = self._flagged_rows[ROW_FLAG_SATURATED].total
            stream_over_range = self._flagged_rows[ROW_FLAG_OVER_RATED_RANGE].total
        return {
            "checked": checked,
            **set_point_saturation(self._set_points),
            "stream_saturated_samples": stream_saturated,
            "stream_over_range_samples": stream_over_range,
        }

    def _metadata(self, status: str, reason: str | None, stop_time: str | None) -> dict[str, Any]:
        return {
            "format": RECORDING_FORMAT_NAME,
            "format_version": RECORDING_FORMAT_VERSION,
            "run_id": self.run_id,
            "configuration": asdict(self.configuration),
            "rig": self._rig_description,
            "stream": {
                "channels": [asdict(channel) for channel in self.stream.channels],
                "sample_rate_hz": float(self.stream.sample_rate_hz),
                "sample_dtype": self._sample_dtype.name,
                "counter_dtype": self._counter_dtype.name,
            },
            "bias_voltages_v": dict(self._bias_voltages_v),
            "calibration_files": self._calibration_files,
            "software": {
                "name": "ornitail",
                "version": software_version(),
                "python": sys.version.split()[0],
                "h5py": h5py.version.version,
                "hdf5": h5py.version.hdf5_version,
            },
            "process": {"hostname": socket.gethostname(), "pid": os.getpid()},
            "start_time_utc": self._start_time.isoformat(timespec="microseconds"),
            "stop_time_utc": stop_time,
            "exit_status": status,
            "failure_reason": reason,
            "sample_count": self._rows_written,
            "set_point_count": len(self._set_points),
            "set_point_summary": summarize_set_points(self._set_points),
            "queue_overflow": {
                "lost_blocks": self._queue_lost_blocks,
                "lost_samples": self._queue_lost_samples,
                "positions": list(self._queue_loss_positions),
            },
            "counter_gaps": self._counter_gap_summary(),
            "link_health": {
                "crc_errors": self._link_crc_errors,
                "lost_samples": self._link_lost_samples,
                "garbage_bytes": self._link_garbage_bytes,
                "resyncs": self._link_resyncs,
                "foreign_frames": self._link_foreign_frames,
                "report_count": self._link_report_count,
            },
            "saturation": self._saturation_summary(),
            "display_feed": None
            if self.display_feed is None
            else {
                "decimation": self.display_feed.decimation,
                "dropped_blocks": self.display_feed.dropped_blocks,
            },
            "writer_cpu_s": self._writer_cpu_s,
        }

    def _write_metadata(self, status: str, reason: str | None, stop_time: str | None) -> None:
        with self._metadata_lock:
            self._current_metadata = self._metadata(status, reason, stop_time)
            write_json_atomically(
                self.run_directory / RUN_METADATA_FILE_NAME, self._current_metadata
            )

    # ----- writer thread -----------------------------------------------------------------------

    def _create_samples_file(self) -> None:
        channel_count = len(self._channel_names)
        row_bytes = channel_count * self._sample_dtype.itemsize
        chunk_rows = max(1024, TARGET_CHUNK_BYTES // row_bytes)
        # locking=False: run.lock guards the run; readers (also in this process) open without locks.
        # libver up to v108: readable by any HDF5 >= 1.8 (older MATLAB releases included). No SWMR:
        # a killed SWMR file opens only in SWMR mode; this one opens in any reader.
        samples_file = h5py.File(
            self.run_directory / SAMPLES_FILE_NAME, "w", locking=False, libver=("earliest", "v108")
        )
        samples_file.attrs["format"] = RECORDING_FORMAT_NAME
        samples_file.attrs["format_version"] = RECORDING_FORMAT_VERSION
        samples_file.attrs["run_id"] = self.run_id
        raw = samples_file.create_dataset(
            HDF5_RAW_SAMPLES_PATH,
            shape=(0, channel_count),
            maxshape=(None, channel_count),
            chunks=(chunk_rows, channel_count),
            dtype=self._sample_dtype,
        )
        raw.attrs["channel_names"] = self._channel_names
        raw.attrs["channel_units"] = [channel.unit for channel in self.stream.channels]
        raw.attrs["sample_rate_hz"] = float(self.stream.sample_rate_hz)
        counter = samples_file.create_dataset(
            HDF5_SAMPLE_COUNTER_PATH,
            shape=(0,),
            maxshape=(None,),
            chunks=(chunk_rows,),
            dtype=self._counter_dtype,
        )
        counter.attrs["description"] = "driver sample counter, wraps modulo 2**bits"
        set_points = samples_file.create_group(HDF5_SET_POINTS_GROUP)
        for name, dtype in HDF5_SET_POINT_COLUMNS.items():
            set_points.create_dataset(
                name, shape=(0,), maxshape=(None,), chunks=(256,), dtype=dtype
            )
        samples_file.flush()
        self._samples_file = samples_file

    def _writer_loop(self) -> None:
        cpu_at_start = time.thread_time()
        max_rows_per_write = max(1, int(self.stream.sample_rate_hz))  # coalesce at most ~1 s
        min_rows_per_write = max(1, int(self.stream.sample_rate_hz * WRITE_INTERVAL_S))
        try:
            while True:
                item = self._queue.get()
                blocks = []
                rows = 0
                deadline = time.monotonic() + WRITE_INTERVAL_S
                while isinstance(item, _SampleBlock):
                    blocks.append(item)
                    rows += len(item.counters)
                    if rows >= max_rows_per_write:
                        item = None
                        break
                    # Wait for about WRITE_INTERVAL_S of data before writing: one resize, write and flush
                    # per 0.1 s instead of per driver block (~10 ms) costs a tenth of the CPU.
                    wait_s = deadline - time.monotonic() if rows < min_rows_per_write else 0.0
                    try:
                        item = (
                            self._queue.get(timeout=wait_s)
                            if wait_s > 0
                            else self._queue.get_nowait()
                        )
                    except queue.Empty:
                        item = None
                if blocks:
                    self._write_sample_blocks(blocks)
                if item is _STOP_WRITER:
                    return
                if isinstance(item, _CompletedSetPoint):
                    self._write_set_point(item.record)
        except BaseException as error:
            self._writer_error = error
        finally:
            self._writer_cpu_s = time.thread_time() - cpu_at_start

    def _write_sample_blocks(self, blocks: list[_SampleBlock]) -> None:
        counters = np.concatenate([block.counters for block in blocks])
        samples = np.concatenate([block.samples for block in blocks])
        first_row = self._rows_written
        end_row = first_row + len(counters)
        raw = self._samples_file[HDF5_RAW_SAMPLES_PATH]
        counter = self._samples_file[HDF5_SAMPLE_COUNTER_PATH]
        raw.resize(end_row, axis=0)
        raw[first_row:end_row] = samples
        counter.resize(end_row, axis=0)
        counter[first_row:end_row] = counters
        self._samples_file.flush()
        self._rows_written = end_row
        for gap in find_counter_gaps(counters, self._last_counter, first_row):
            self._gap_count += 1
            self._gap_missing_samples += gap.missing_samples
            if len(self._gap_positions) < MAX_STORED_GAP_POSITIONS:
                self._gap_positions.append(gap.to_json_dict())
        self._last_counter = int(counters[-1])

    def _write_set_point(self, record: SetPointRecord) -> None:
        record.set_point_index = len(self._set_points)
        record.completed_utc = utc_now_iso()
        table = self._samples_file[HDF5_SET_POINTS_GROUP]
        values = record.to_json_dict()
        values["is_tare"] = record.kind == SET_POINT_KIND_TARE
        values["motor_rpm_mean"] = (
            math.nan if record.motor_rpm_mean is None else record.motor_rpm_mean
        )
        for name in ("saturated_samples", "over_range_samples"):
            values[name] = -1 if values[name] is None else values[name]
        for name in HDF5_SET_POINT_COLUMNS:
            dataset = table[name]
            dataset.resize(record.set_point_index + 1, axis=0)
            dataset[record.set_point_index] = values[name]
        self._samples_file.flush()
        # The journal line points into samples.h5: its rows must be on disk before the line is.
        os.fsync(self._samples_file.id.get_vfd_handle())
        append_journal_line(self.run_directory, record)
        self._set_points.append(record)
        with self._metadata_lock:
            self._current_metadata["set_point_count"] = len(self._set_points)
            self._current_metadata["set_point_summary"] = summarize_set_points(self._set_points)
            self._current_metadata["sample_count"] = self._rows_written
            self._current_metadata["saturation"] = self._saturation_summary()
            self._current_metadata["counter_gaps"] = self._counter_gap_summary()
            self._current_metadata["link_health"].update(
                {
                    "crc_errors": self._link_crc_errors,
                    "lost_samples": self._link_lost_samples,
                    "garbage_bytes": self._link_garbage_bytes,
                    "resyncs": self._link_resyncs,
                    "foreign_frames": self._link_foreign_frames,
                    "report_count": self._link_report_count,
                }
            )


def _fsync_path(path: Path) -> None:
    """fsync a closed file's content to disk."""
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _require_json_serialisable(what: str, values: dict[str, Any]) -> None:
    try:
        json.dumps(values, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{what} is not JSON-serialisable without NaN: {error}") from None


def _joined(first: str | None, second: str) -> str:
    return second if not first else f"{first}; {second}"
