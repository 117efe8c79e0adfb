"""What a recording holds: file names, HDF5 paths, run configuration, channels, set points.

One recording is one run directory (see ``docs/recordings.md``)::

    <data_root>/runs/<run_id>/
        run.json        run metadata, written atomically at start and at stop
        samples.h5      raw samples, sample counters, per-set-point table (HDF5)
        journal.jsonl   one JSON line per completed set point, fsynced (what a resume reads)
        run.lock        held (flock) by the recording process while it lives
        calibration/    copies of the calibration files the run was recorded with

All values are SI; angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from ornitail.core.errors import UserInputError

RECORDING_FORMAT_NAME = "ornitail-recording"
RECORDING_FORMAT_VERSION = 1

RUNS_FOLDER_NAME = "runs"
RUN_METADATA_FILE_NAME = "run.json"
SAMPLES_FILE_NAME = "samples.h5"
JOURNAL_FILE_NAME = "journal.jsonl"
RUN_LOCK_FILE_NAME = "run.lock"
CALIBRATION_FOLDER_NAME = "calibration"

HDF5_RAW_SAMPLES_PATH = "/samples/raw"
HDF5_SAMPLE_COUNTER_PATH = "/samples/counter"
HDF5_SET_POINTS_GROUP = "/set_points"

EXIT_STATUS_RUNNING = "running"
EXIT_STATUS_COMPLETED = "completed"
EXIT_STATUS_ABORTED = "aborted"
EXIT_STATUS_FAILED = "failed"
EXIT_STATUS_CRASHED = "crashed"
EXIT_STATUS_INCOMPLETE = "incomplete"
"""Every planned set point was visited, but some record still lost samples after its retakes (named in
``failure_reason``); ``ornitail sweep --resume`` records those points again."""
ALL_EXIT_STATUSES = (
    EXIT_STATUS_RUNNING,
    EXIT_STATUS_COMPLETED,
    EXIT_STATUS_INCOMPLETE,
    EXIT_STATUS_ABORTED,
    EXIT_STATUS_FAILED,
    EXIT_STATUS_CRASHED,
)

SET_POINT_KIND_MEASUREMENT = "measurement"
SET_POINT_KIND_TARE = "tare"
SET_POINT_KINDS = (SET_POINT_KIND_MEASUREMENT, SET_POINT_KIND_TARE)

# Per-row flags a driver may hand to the recorder with each block (bitmask, uint8):
ROW_FLAG_SATURATED = 0x01
"""The row holds a channel at the ADC range limit (clipped), or the device flagged it over-range."""
ROW_FLAG_OVER_RATED_RANGE = 0x02
"""The load of the row exceeds the sensor's rated range (the calibration file's ``max`` per axis)."""

# Numeric columns of the HDF5 per-set-point table, in order, with their dtypes.
HDF5_SET_POINT_COLUMNS: dict[str, str] = {
    "set_point_index": "int64",
    "plan_point_index": "int64",
    "first_sample_index": "int64",
    "last_sample_index": "int64",
    "is_tare": "uint8",
    "pitch_rad": "float64",
    "tunnel_velocity_m_s": "float64",
    "flapping_frequency_hz": "float64",
    "tail_attached": "uint8",
    "repeat_index": "int64",
    "settle_time_s": "float64",
    "settled": "uint8",
    "motor_rpm_mean": "float64",
    "saturated_samples": "int64",
    "over_range_samples": "int64",
}
"""``saturated_samples`` and ``over_range_samples`` are -1 where the recording did not check (no row flags)."""


class RunAborted(Exception):
    """Raise inside a recording's ``with`` block when the user stops; the run ends ``aborted``."""


@dataclass
class RunConfiguration:
    """The model configuration a run measures.

    Parameters
    ----------
    tail_id : str or None
        Tail name, e.g. ``"S3"``; may be ``None`` for a tailless run.
    x_h_m : float or None
        Tail position x_h in metres; may be ``None`` for a tailless run.
    tailed : bool
        True if the tail is mounted for this run.
    plan_name : str
        Name of the sweep plan that drives the run.
    note : str
        Free text from the operator.
    resumed_from_run_id : str or None
        The run this one continues (its journal told the sweep which set points were done).
    """

    tail_id: str | None
    x_h_m: float | None
    tailed: bool
    plan_name: str = ""
    note: str = ""
    resumed_from_run_id: str | None = None

    def validate(self) -> None:
        """Raise :class:`UserInputError` for a missing tail, non-finite x_h or empty tail id."""
        if self.x_h_m is not None and not math.isfinite(float(self.x_h_m)):
            raise UserInputError("run configuration: x_h_m", f"value {self.x_h_m!r} is not finite")
        if self.tail_id is not None and not str(self.tail_id).strip():
            raise UserInputError("run configuration: tail_id", "empty tail id")
        if self.tailed and (self.tail_id is None or self.x_h_m is None):
            raise UserInputError("run configuration", "a tailed run needs both tail_id and x_h_m")


@dataclass
class ChannelSpec:
    """One recorded channel: its name and the unit of the raw value (``"V"`` or ``"count"``)."""

    name: str
    unit: str


@dataclass
class StreamLayout:
    """The shape of the raw sample stream a driver delivers.

    Parameters
    ----------
    channels : list of ChannelSpec
        Column order of the sample blocks.
    sample_rate_hz : float
        Nominal sample rate in Hz.
    sample_dtype : str
        numpy dtype the samples are stored in (``"float64"``, ``"float32"`` for volts, an
        integer type for ADC counts). Incoming blocks must cast to it with ``same_kind`` casting.
    counter_dtype : str
        ``"uint32"`` or ``"uint64"``: the driver's sample counter; it wraps modulo 2**bits.
    """

    channels: list[ChannelSpec]
    sample_rate_hz: float
    sample_dtype: str = "float64"
    counter_dtype: str = "uint64"

    def validate(self) -> None:
        """Raise :class:`UserInputError` for no channels, duplicate names or a bad rate or dtype."""
        names = [channel.name for channel in self.channels]
        if not names:
            raise UserInputError("stream layout: channels", "no channels given")
        if len(set(names)) != len(names):
            raise UserInputError("stream layout: channels", f"duplicate channel names in {names}")
        if "sample_counter" in names or "time_s" in names:
            raise UserInputError(
                "stream layout: channels", "'sample_counter' and 'time_s' are reserved names"
            )
        rate = float(self.sample_rate_hz)
        if not math.isfinite(rate) or rate <= 0.0:
            raise UserInputError(
                "stream layout: sample_rate_hz", f"{self.sample_rate_hz!r} is not a positive number"
            )
        if self.counter_dtype not in ("uint32", "uint64"):
            raise UserInputError(
                "stream layout: counter_dtype", f"{self.counter_dtype!r} is not uint32 or uint64"
            )


@dataclass
class SetPointRecord:
    """One completed set point: where its samples are and what the rig was set to.

    Sample indices are 0-based row indices into ``/samples/raw`` (inclusive at both ends). The
    recorder fills ``set_point_index`` (0, 1, ... in completion order), ``completed_utc`` and
    ``link_health`` (cumulative link-health counts when the set point completed), and
    ``saturated_samples`` / ``over_range_samples``: rows of the record flagged saturated (a channel at the ADC
    range limit, or the device's over-range status) and over the sensor's rated load (None: not checked, e.g. a
    journal written before ornitail counted them). ``extra`` holds further JSON-serialisable values (e.g. a
    hot-wire mean velocity).
    """

    plan_point_index: int
    kind: str
    first_sample_index: int
    last_sample_index: int
    pitch_rad: float
    tunnel_velocity_m_s: float
    flapping_frequency_hz: float
    tail_attached: bool
    repeat_index: int = 0
    settle_time_s: float = 0.0
    settled: bool = True
    motor_rpm_mean: float | None = None
    saturated_samples: int | None = None
    over_range_samples: int | None = None
    set_point_index: int = -1
    completed_utc: str = ""
    link_health: dict[str, int] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def validate(self) -> None:
        """Raise ``ValueError`` for an unknown kind, non-finite values or a bad sample range."""
        if self.kind not in SET_POINT_KINDS:
            raise ValueError(f"set point kind {self.kind!r} is not one of {SET_POINT_KINDS}")
        values = (self.pitch_rad, self.tunnel_velocity_m_s, self.flapping_frequency_hz)
        if not all(math.isfinite(float(value)) for value in values):
            raise ValueError(f"set point values {values} are not all finite")
        if not 0 <= self.first_sample_index <= self.last_sample_index:
            raise ValueError(
                f"sample range {self.first_sample_index}..{self.last_sample_index} is not ordered"
            )
        if self.motor_rpm_mean is not None and not math.isfinite(float(self.motor_rpm_mean)):
            raise ValueError("motor_rpm_mean must be finite or None")

    def to_json_dict(self) -> dict[str, Any]:
        """Return the record as a JSON-serialisable dictionary (one journal line)."""
        return asdict(self)

    @property
    def samples_missing_in_record(self) -> int:
        """Samples the sample counter says are missing inside this record (``extra``; 0 if not journalled)."""
        return int(self.extra.get("samples_missing_in_record") or 0)

    @property
    def is_flagged(self) -> bool:
        """True if rows of the record were flagged saturated or over the rated range."""
        return bool(self.saturated_samples) or bool(self.over_range_samples)

    @classmethod
    def from_json_dict(cls, values: dict[str, Any]) -> SetPointRecord:
        """Build a record from a journal line's dictionary (unknown keys go to ``extra``)."""
        known = set(cls.__dataclass_fields__)
        record = cls(**{key: value for key, value in values.items() if key in known})
        record.extra.update({key: value for key, value in values.items() if key not in known})
        return record


def summarize_set_points(records: list[SetPointRecord]) -> dict[str, Any]:
    """Return counts and value ranges of a run's set points (for the catalog and ``run.json``)."""
    summary: dict[str, Any] = {
        "count": len(records),
        "measurement_count": sum(r.kind == SET_POINT_KIND_MEASUREMENT for r in records),
        "tare_count": sum(r.kind == SET_POINT_KIND_TARE for r in records),
    }
    for name in ("pitch_rad", "tunnel_velocity_m_s", "flapping_frequency_hz"):
        values = [float(getattr(record, name)) for record in records]
        summary[name] = [min(values), max(values)] if values else None
    return summary
