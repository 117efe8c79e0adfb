"""Reading a recorded run: metadata, set points and raw samples as pandas tables.

Works on completed, aborted, failed and crashed runs alike, and on a run still being recorded (a
best-effort snapshot of what has been flushed). A run whose process died without writing its stop
record is reported with status ``crashed``; every flushed sample is still readable.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from ornitail.acquisition.counter_gaps import CounterGap, find_counter_gaps
from ornitail.acquisition.recording_layout import (
    EXIT_STATUS_CRASHED,
    EXIT_STATUS_RUNNING,
    HDF5_RAW_SAMPLES_PATH,
    HDF5_SAMPLE_COUNTER_PATH,
    RECORDING_FORMAT_NAME,
    RUN_METADATA_FILE_NAME,
    SAMPLES_FILE_NAME,
    ChannelSpec,
    SetPointRecord,
    summarize_set_points,
)
from ornitail.acquisition.run_files import read_journal, read_json_file, run_is_live
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file

MAX_STORED_GAP_POSITIONS = 1000
_COUNTER_READ_ROWS = 1 << 20
CRASH_FAILURE_REASON = (
    "the recording process ended without a stop record (crash, kill or power loss)"
)


def _open_samples_file(path: Path) -> h5py.File:
    # locking=False: a reader must not need (or take) the writer's lock; it reads flushed data only.
    if path.exists():
        check_input_file(path, limit=None)  # a FIFO or device would block h5py
    try:
        return h5py.File(path, "r", locking=False)
    except FileNotFoundError:
        raise UserInputError(str(path), "samples file not found") from None
    except OSError as error:
        raise UserInputError(str(path), f"not a readable HDF5 file ({error})") from None


@dataclass
class Recording:
    """One run directory, loaded.

    Attributes
    ----------
    run_directory : pathlib.Path
        The run's folder.
    metadata : dict
        ``run.json`` exactly as written.
    status : str
        ``completed``, ``aborted``, ``failed``, ``crashed`` or ``running``.
    set_points : list of SetPointRecord
        Completed set points from the journal, in completion order.
    sample_count : int
        Rows in ``/samples/raw`` (flushed samples).
    effective_metadata : dict
        ``metadata`` with the status, counts and counter gaps of a crashed run filled in from its
        files; equal to ``metadata`` for a run that wrote its stop record.
    """

    run_directory: Path
    metadata: dict[str, Any]
    status: str
    set_points: list[SetPointRecord]
    sample_count: int
    effective_metadata: dict[str, Any]

    @property
    def run_id(self) -> str:
        """The run's id (its folder name)."""
        return self.metadata["run_id"]

    @property
    def failure_reason(self) -> str | None:
        """Why the run failed or crashed, else ``None``."""
        return self.effective_metadata.get("failure_reason")

    @property
    def channels(self) -> list[ChannelSpec]:
        """Recorded channels in column order, with raw units (``V`` or ``count``)."""
        return [ChannelSpec(**channel) for channel in self.metadata["stream"]["channels"]]

    @property
    def sample_rate_hz(self) -> float:
        """Nominal sample rate in Hz."""
        return float(self.metadata["stream"]["sample_rate_hz"])

    @property
    def samples_path(self) -> Path:
        """Path of ``samples.h5``."""
        return self.run_directory / SAMPLES_FILE_NAME

    def read_raw(
        self, first_sample_index: int = 0, last_sample_index: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(counters, samples)`` of rows ``first..last`` (inclusive; default: to end)."""
        last = self.sample_count - 1 if last_sample_index is None else last_sample_index
        if not self.samples_path.exists():
            raise UserInputError(str(self.samples_path), "samples file not found")
        if not 0 <= first_sample_index <= last + 1 or last >= self.sample_count:
            raise UserInputError(
                str(self.samples_path),
                f"sample range {first_sample_index}..{last} outside 0..{self.sample_count - 1}",
            )
        with _open_samples_file(self.samples_path) as samples_file:
            counters = samples_file[HDF5_SAMPLE_COUNTER_PATH][first_sample_index : last + 1]
            samples = samples_file[HDF5_RAW_SAMPLES_PATH][first_sample_index : last + 1]
        return counters, samples

    def samples_frame(
        self, first_sample_index: int = 0, last_sample_index: int | None = None
    ) -> pd.DataFrame:
        """Raw samples as a DataFrame.

        The index is the sample (row) index; columns are ``sample_counter``, ``time_s`` (counter
        relative to the run's first counter divided by the sample rate, so gaps show as jumps in
        time) and one column per channel in its raw unit.
        """
        counters, samples = self.read_raw(first_sample_index, last_sample_index)
        first_counter = self._first_counter() if self.sample_count else 0
        elapsed_counts = (counters - counters.dtype.type(first_counter)).astype(np.float64)
        columns: dict[str, Any] = {
            "sample_counter": counters,
            "time_s": elapsed_counts / self.sample_rate_hz,
        }
        for column, channel in enumerate(self.channels):
            columns[channel.name] = samples[:, column]
        index = pd.RangeIndex(
            first_sample_index, first_sample_index + len(counters), name="sample_index"
        )
        return pd.DataFrame(columns, index=index)

    def set_point_frame(self, set_point_index: int) -> pd.DataFrame:
        """Raw samples of one set point (see :meth:`samples_frame`)."""
        matches = [r for r in self.set_points if r.set_point_index == set_point_index]
        if not matches:
            raise UserInputError(
                str(self.run_directory), f"no completed set point with index {set_point_index}"
            )
        return self.samples_frame(matches[0].first_sample_index, matches[0].last_sample_index)

    def set_points_frame(self) -> pd.DataFrame:
        """The per-set-point table as a DataFrame, one row per completed set point."""
        rows = []
        for record in self.set_points:
            row = record.to_json_dict()
            link_health = row.pop("link_health")
            row.update({f"link_health_{key}": value for key, value in link_health.items()})
            row.update(row.pop("extra"))
            rows.append(row)
        return pd.DataFrame(rows)

    def counter_gaps(self) -> list[CounterGap]:
        """Every counter discontinuity in the flushed samples, recomputed from the file."""
        gaps: list[CounterGap] = []
        if not self.sample_count:
            return gaps
        with _open_samples_file(self.samples_path) as samples_file:
            counter_dataset = samples_file[HDF5_SAMPLE_COUNTER_PATH]
            previous = None
            for start in range(0, self.sample_count, _COUNTER_READ_ROWS):
                counters = counter_dataset[
                    start : min(start + _COUNTER_READ_ROWS, self.sample_count)
                ]
                gaps += find_counter_gaps(counters, previous, start)
                previous = int(counters[-1])
        return gaps

    def _first_counter(self) -> int:
        with _open_samples_file(self.samples_path) as samples_file:
            return int(samples_file[HDF5_SAMPLE_COUNTER_PATH][0])


def _flushed_sample_count(samples_path: Path) -> int:
    if not samples_path.exists():
        return 0
    with _open_samples_file(samples_path) as samples_file:
        raw_count = samples_file[HDF5_RAW_SAMPLES_PATH].shape[0]
        counter_count = samples_file[HDF5_SAMPLE_COUNTER_PATH].shape[0]
    return min(raw_count, counter_count)


def load_recording(run_directory: Path | str) -> Recording:
    """Load a run directory; a missing folder or bad ``run.json`` is a :class:`UserInputError`."""
    run_directory = Path(run_directory)
    if not run_directory.is_dir():
        raise UserInputError(str(run_directory), "run directory not found")
    metadata = read_json_file(run_directory / RUN_METADATA_FILE_NAME)
    if metadata.get("format") != RECORDING_FORMAT_NAME:
        raise UserInputError(
            str(run_directory / RUN_METADATA_FILE_NAME), "not an ornitail recording's run.json"
        )
    set_points = read_journal(run_directory)
    sample_count = _flushed_sample_count(run_directory / SAMPLES_FILE_NAME)
    status = metadata["exit_status"]
    if status == EXIT_STATUS_RUNNING and not run_is_live(run_directory):
        status = EXIT_STATUS_CRASHED
    recording = Recording(
        run_directory=run_directory,
        metadata=metadata,
        status=status,
        set_points=set_points,
        sample_count=sample_count,
        effective_metadata=metadata,
    )
    if status in (EXIT_STATUS_CRASHED, EXIT_STATUS_RUNNING):
        recording.effective_metadata = _metadata_from_files(recording)
    return recording


def _metadata_from_files(recording: Recording) -> dict[str, Any]:
    """Fill the counts a run without a stop record could not write, from its files."""
    metadata = copy.deepcopy(recording.metadata)
    metadata["exit_status"] = recording.status
    metadata["sample_count"] = recording.sample_count
    metadata["set_point_count"] = len(recording.set_points)
    metadata["set_point_summary"] = summarize_set_points(recording.set_points)
    if recording.status == EXIT_STATUS_RUNNING:
        return metadata
    metadata["failure_reason"] = CRASH_FAILURE_REASON
    samples_path = recording.samples_path
    if samples_path.exists():
        last_write = datetime.fromtimestamp(samples_path.stat().st_mtime, UTC)
        metadata["stop_time_utc"] = last_write.isoformat(timespec="microseconds")
        metadata["stop_time_is_last_write"] = True
    gaps = recording.counter_gaps()
    metadata["counter_gaps"] = {
        "count": len(gaps),
        "missing_samples": sum(gap.missing_samples for gap in gaps),
        "positions": [gap.to_json_dict() for gap in gaps[:MAX_STORED_GAP_POSITIONS]],
        "positions_truncated": len(gaps) > MAX_STORED_GAP_POSITIONS,
    }
    if recording.set_points:  # the last journal line holds the cumulative link health
        last_health = recording.set_points[-1].link_health
        metadata["link_health"]["crc_errors"] = last_health.get("crc_errors", 0)
        metadata["link_health"]["lost_samples"] = last_health.get("link_lost_samples", 0)
        for name in ("garbage_bytes", "resyncs", "foreign_frames"):
            metadata["link_health"][name] = last_health.get(name, 0)
        metadata["queue_overflow"]["lost_samples"] = last_health.get("queue_lost_samples", 0)
    metadata["saturation"] = _saturation_from_journal(
        recording.set_points, metadata.get("saturation") or {}
    )
    return metadata


def set_point_saturation(set_points: list[SetPointRecord]) -> dict[str, Any]:
    """Flagged rows summed over ``set_points`` and the flagged set points (at most
    MAX_STORED_GAP_POSITIONS listed): the per-set-point part of ``run.json``'s ``saturation``."""
    affected = [
        {
            "set_point_index": record.set_point_index,
            "plan_point_index": record.plan_point_index,
            "kind": record.kind,
            "saturated_samples": record.saturated_samples,
            "over_range_samples": record.over_range_samples,
        }
        for record in set_points
        if record.is_flagged
    ]
    return {
        "saturated_samples": sum(int(record.saturated_samples or 0) for record in set_points),
        "over_range_samples": sum(int(record.over_range_samples or 0) for record in set_points),
        "affected_set_points": affected[:MAX_STORED_GAP_POSITIONS],
        "affected_set_point_count": len(affected),
    }


def _saturation_from_journal(
    set_points: list[SetPointRecord], at_start: dict[str, Any]
) -> dict[str, Any]:
    """The ``saturation`` block of a run without a stop record, from its journalled set points (the stream
    totals were last written at start and are kept as they were)."""
    return {
        **at_start,
        "checked": bool(at_start.get("checked"))
        or any(record.saturated_samples is not None for record in set_points),
        **set_point_saturation(set_points),
    }
