"""The run catalog: an SQLite index (WAL mode, one commit per change) of the runs under a data root.

The run directories are the truth; the catalog is an index that :meth:`RunCatalog.reconcile` can
rebuild from them. Reading never waits for another process's write lock (WAL); a write that finds the
catalog locked fails after ``busy_timeout_s`` and the run directory stays the truth until the next
reconcile. Layout and fields: ``docs/catalog.md``.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
from collections.abc import Iterator
from contextlib import closing, contextmanager
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ornitail.acquisition.recording_layout import (
    ALL_EXIT_STATUSES,
    EXIT_STATUS_CRASHED,
    EXIT_STATUS_RUNNING,
    RUN_METADATA_FILE_NAME,
    RUNS_FOLDER_NAME,
    SAMPLES_FILE_NAME,
)
from ornitail.acquisition.run_files import read_json_file, run_is_live
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file

CATALOG_FILE_NAME = "catalog.sqlite"
DATA_ROOT_ENVIRONMENT_VARIABLE = "ORNITAIL_DATA"
DEFAULT_DATA_ROOT_NAME = "ornitail-data"
CATALOG_SCHEMA_VERSION = 2
DEFAULT_BUSY_TIMEOUT_S = 30.0
"""How long a write waits for another process's lock before it fails, s (reads never wait: WAL)."""
RECONCILE_WRITE_TIMEOUT_S = 2.0
"""How long :meth:`RunCatalog.reconcile` waits for a locked catalog before it reports the rows it could not
write (``ornitail runs`` then lists them from the run directories), s."""
# Tail positions are set by hand to the millimetre; 0.05 mm is far below any meaningful difference
# and far above float rounding of a value converted between mm and m.
X_H_MATCH_TOLERANCE_M = 0.05e-3

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    run_id TEXT PRIMARY KEY,
    run_directory TEXT NOT NULL,
    tail_id TEXT,
    x_h_m REAL,
    tailed INTEGER NOT NULL,
    plan_name TEXT NOT NULL,
    resumed_from_run_id TEXT,
    start_time_utc TEXT NOT NULL,
    stop_time_utc TEXT,
    exit_status TEXT NOT NULL,
    failure_reason TEXT,
    software_version TEXT NOT NULL,
    calibration_hashes TEXT NOT NULL,
    sample_count INTEGER NOT NULL,
    set_point_count INTEGER NOT NULL,
    set_point_summary TEXT NOT NULL,
    queue_lost_samples INTEGER NOT NULL,
    link_lost_samples INTEGER NOT NULL,
    crc_errors INTEGER NOT NULL,
    counter_gap_count INTEGER NOT NULL,
    counter_missing_samples INTEGER NOT NULL,
    garbage_bytes INTEGER NOT NULL DEFAULT 0,
    resyncs INTEGER NOT NULL DEFAULT 0,
    foreign_frames INTEGER NOT NULL DEFAULT 0,
    saturated_samples INTEGER NOT NULL DEFAULT 0,
    over_range_samples INTEGER NOT NULL DEFAULT 0,
    saturated_set_points INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX IF NOT EXISTS runs_by_start ON runs (start_time_utc);
"""
_COLUMNS_ADDED_IN_VERSION_2 = (
    "garbage_bytes",
    "resyncs",
    "foreign_frames",
    "saturated_samples",
    "over_range_samples",
    "saturated_set_points",
)
_JSON_COLUMNS = ("calibration_hashes", "set_point_summary")


def default_data_root() -> Path:
    """Return ``$ORNITAIL_DATA`` if set, else ``./ornitail-data``."""
    from_environment = os.environ.get(DATA_ROOT_ENVIRONMENT_VARIABLE, "").strip()
    return Path(from_environment) if from_environment else Path(DEFAULT_DATA_ROOT_NAME)


def is_lock_error(error: BaseException) -> bool:
    """True for SQLite's "database is locked" / "busy": another process holds the write lock."""
    text = str(error).lower()
    return isinstance(error, sqlite3.OperationalError) and ("locked" in text or "busy" in text)


def utc_now_iso() -> str:
    """Current UTC time as ISO 8601 with microseconds and ``+00:00`` (sorts as text)."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


@dataclass
class CatalogEntry:
    """One run as the catalog lists it (``run_directory`` is relative to the data root).

    Sample counts: ``counter_missing_samples`` are the samples the sample counters say are missing in the
    run's file, whatever lost them (:attr:`lost_samples`); ``queue_lost_samples`` (recorder queue full) and
    ``link_lost_samples`` (counter gaps the driver saw) say why, and are part of it, not added to it.
    ``saturated_samples`` / ``over_range_samples`` are rows of the run's set-point records at the ADC limit
    (or flagged over-range by the device) / over the sensor's rated load; ``saturated_set_points`` counts the
    set points with either. ``garbage_bytes``, ``resyncs`` and ``foreign_frames`` are link health: bytes
    outside valid frames, stretches of them, CAN frames with the board's ids that were not its replies.
    """

    run_id: str
    run_directory: str
    tail_id: str | None
    x_h_m: float | None
    tailed: bool
    plan_name: str
    resumed_from_run_id: str | None
    start_time_utc: str
    stop_time_utc: str | None
    exit_status: str
    failure_reason: str | None
    software_version: str
    calibration_hashes: dict[str, str] = field(default_factory=dict)
    sample_count: int = 0
    set_point_count: int = 0
    set_point_summary: dict[str, Any] = field(default_factory=dict)
    queue_lost_samples: int = 0
    link_lost_samples: int = 0
    crc_errors: int = 0
    counter_gap_count: int = 0
    counter_missing_samples: int = 0
    garbage_bytes: int = 0
    resyncs: int = 0
    foreign_frames: int = 0
    saturated_samples: int = 0
    over_range_samples: int = 0
    saturated_set_points: int = 0

    @property
    def lost_samples(self) -> int:
        """Samples lost in the run, each counted once: those the sample counters say are missing in its file."""
        return self.counter_missing_samples

    def to_json_dict(self) -> dict[str, Any]:
        """Return the entry as a JSON-serialisable dictionary, with ``lost_samples``."""
        return {**asdict(self), "lost_samples": self.lost_samples}


def catalog_entry_from_run_metadata(metadata: dict[str, Any], run_directory: str) -> CatalogEntry:
    """Build a catalog entry from a run's metadata dictionary (the content of ``run.json``)."""
    configuration = metadata["configuration"]
    link_health = metadata["link_health"]
    saturation = metadata.get("saturation") or {}
    return CatalogEntry(
        run_id=metadata["run_id"],
        run_directory=run_directory,
        tail_id=configuration["tail_id"],
        x_h_m=configuration["x_h_m"],
        tailed=bool(configuration["tailed"]),
        plan_name=configuration.get("plan_name", ""),
        resumed_from_run_id=configuration.get("resumed_from_run_id"),
        start_time_utc=metadata["start_time_utc"],
        stop_time_utc=metadata.get("stop_time_utc"),
        exit_status=metadata["exit_status"],
        failure_reason=metadata.get("failure_reason"),
        software_version=metadata["software"]["version"],
        calibration_hashes={
            label: entry["hash"] for label, entry in metadata["calibration_files"].items()
        },
        sample_count=int(metadata.get("sample_count") or 0),
        set_point_count=int(metadata.get("set_point_count") or 0),
        set_point_summary=metadata.get("set_point_summary") or {},
        queue_lost_samples=int(metadata["queue_overflow"]["lost_samples"]),
        link_lost_samples=int(link_health["lost_samples"]),
        crc_errors=int(link_health["crc_errors"]),
        counter_gap_count=int(metadata["counter_gaps"]["count"]),
        counter_missing_samples=int(metadata["counter_gaps"]["missing_samples"]),
        garbage_bytes=int(link_health.get("garbage_bytes", 0)),
        resyncs=int(link_health.get("resyncs", 0)),
        foreign_frames=int(link_health.get("foreign_frames", 0)),
        saturated_samples=int(saturation.get("saturated_samples", 0)),
        over_range_samples=int(saturation.get("over_range_samples", 0)),
        saturated_set_points=int(
            saturation.get(
                "affected_set_point_count", len(saturation.get("affected_set_points") or [])
            )
        ),
    )


@dataclass
class RunFilter:
    """Which runs to list; ``None`` means any. ``started_since_utc`` is timezone-aware."""

    tail_id: str | None = None
    x_h_m: float | None = None
    tailed: bool | None = None
    exit_status: str | None = None
    started_since_utc: datetime | None = None

    def validate(self) -> None:
        """Raise :class:`UserInputError` for an unknown status, a non-finite x_h or a naive time."""
        if self.exit_status is not None and self.exit_status not in ALL_EXIT_STATUSES:
            raise UserInputError(
                "exit_status",
                f"{self.exit_status!r} is not one of {', '.join(ALL_EXIT_STATUSES)}",
            )
        if self.x_h_m is not None and not math.isfinite(self.x_h_m):
            raise UserInputError("x_h_mm", f"value {self.x_h_m * 1e3!r} is not a finite number")
        if self.started_since_utc is not None and self.started_since_utc.tzinfo is None:
            raise ValueError("started_since_utc must be timezone-aware")

    def matches(self, entry: CatalogEntry) -> bool:
        """True if ``entry`` passes the filter (as :meth:`RunCatalog.find_runs` selects in SQL)."""
        if self.tail_id is not None and (entry.tail_id or "").lower() != self.tail_id.lower():
            return False
        if self.x_h_m is not None and (
            entry.x_h_m is None or abs(entry.x_h_m - self.x_h_m) > X_H_MATCH_TOLERANCE_M
        ):
            return False
        if self.tailed is not None and entry.tailed != self.tailed:
            return False
        if self.exit_status is not None and entry.exit_status != self.exit_status:
            return False
        if self.started_since_utc is not None:
            since = self.started_since_utc.astimezone(UTC).isoformat(timespec="microseconds")
            if entry.start_time_utc < since:
                return False
        return True


@dataclass
class ReconcileReport:
    """What :meth:`RunCatalog.reconcile` found: runs found crashed, runs newly registered, rows brought up to
    date from their run directory, and (when the catalog stayed locked) the entries it could not write."""

    crashed_run_ids: list[str] = field(default_factory=list)
    registered_run_ids: list[str] = field(default_factory=list)
    updated_run_ids: list[str] = field(default_factory=list)
    unreadable_run_directories: list[str] = field(default_factory=list)
    unreadable_reasons: dict[str, str] = field(default_factory=dict)
    unwritten_entries: list[CatalogEntry] = field(default_factory=list)
    write_error: str | None = None


class RunCatalog:
    """The SQLite catalog ``<data_root>/catalog.sqlite`` (WAL mode; every change is one commit).

    Parameters
    ----------
    data_root : pathlib.Path
        Existing folder holding ``catalog.sqlite`` and ``runs/``.
    busy_timeout_s : float
        How long a write waits for another process's write lock before ``sqlite3.OperationalError``
        ("database is locked"), s. Opening and reading never wait for it: an up-to-date catalog is opened
        without writing, and WAL readers are not blocked by a writer.
    """

    def __init__(self, data_root: Path, busy_timeout_s: float = DEFAULT_BUSY_TIMEOUT_S) -> None:
        self.data_root = Path(data_root)
        if not self.data_root.is_dir():
            raise UserInputError(str(self.data_root), "data root folder does not exist")
        self.path = self.data_root / CATALOG_FILE_NAME
        if self.path.exists():
            check_input_file(self.path, limit=None)  # a FIFO or device would block SQLite
        self.busy_timeout_s = float(busy_timeout_s)
        self._schema_ready = False
        try:
            self._ensure_schema()
        except sqlite3.OperationalError as error:
            if not is_lock_error(error):
                raise
            # locked while an older catalog needs its schema: reads work, writes retry the schema first

    def _ensure_schema(self) -> None:
        """Create the table or add the columns of a newer schema; writes only if something is missing."""
        if self._schema_ready:
            return
        with self._connection() as connection:
            version = connection.execute("PRAGMA user_version").fetchone()[0]
            columns = {row[1] for row in connection.execute("PRAGMA table_info(runs)")}
        if version == CATALOG_SCHEMA_VERSION and columns:
            self._schema_ready = True
            return
        with self._connection() as connection:
            connection.executescript(_SCHEMA)
            for column in _COLUMNS_ADDED_IN_VERSION_2:
                if columns and column not in columns:
                    connection.execute(
                        f"ALTER TABLE runs ADD COLUMN {column} INTEGER NOT NULL DEFAULT 0"
                    )
            connection.execute(f"PRAGMA user_version = {CATALOG_SCHEMA_VERSION}")
        self._schema_ready = True

    @contextmanager
    def _connection(self, busy_timeout_s: float | None = None) -> Iterator[sqlite3.Connection]:
        timeout_s = self.busy_timeout_s if busy_timeout_s is None else busy_timeout_s
        try:
            with closing(sqlite3.connect(self.path, timeout=timeout_s)) as connection:
                connection.execute("PRAGMA journal_mode = WAL")
                connection.execute("PRAGMA synchronous = FULL")
                with connection:  # one transaction, committed on success
                    yield connection
        except sqlite3.DatabaseError as error:
            if is_lock_error(error):
                raise
            raise UserInputError(str(self.path), f"not a usable catalog ({error})") from None

    def journal_mode(self) -> str:
        """Return SQLite's journal mode of the catalog (``"wal"``)."""
        with self._connection() as connection:
            return connection.execute("PRAGMA journal_mode").fetchone()[0]

    def upsert_run(self, entry: CatalogEntry, busy_timeout_s: float | None = None) -> None:
        """Insert the run or replace its row, and commit.

        Raises ``sqlite3.OperationalError`` ("database is locked") if another process holds the write lock
        for longer than ``busy_timeout_s`` (default: the catalog's).
        """
        self._ensure_schema()
        row = asdict(entry)
        for column in _JSON_COLUMNS:
            row[column] = json.dumps(row[column], allow_nan=False)
        row["tailed"] = int(row["tailed"])
        columns = ", ".join(row)
        placeholders = ", ".join(f":{name}" for name in row)
        with self._connection(busy_timeout_s) as connection:
            connection.execute(
                f"INSERT OR REPLACE INTO runs ({columns}) VALUES ({placeholders})", row
            )

    def get_run(self, run_id: str) -> CatalogEntry | None:
        """Return the entry of ``run_id`` or ``None``."""
        with self._connection() as connection:
            connection.row_factory = sqlite3.Row
            row = connection.execute("SELECT * FROM runs WHERE run_id = ?", (run_id,)).fetchone()
        return None if row is None else _entry_from_row(row)

    def find_runs(self, run_filter: RunFilter | None = None) -> list[CatalogEntry]:
        """Return the runs matching ``run_filter``, oldest first."""
        run_filter = run_filter or RunFilter()
        run_filter.validate()
        conditions, parameters = [], []
        if run_filter.tail_id is not None:
            conditions.append("tail_id = ? COLLATE NOCASE")
            parameters.append(run_filter.tail_id)
        if run_filter.x_h_m is not None:
            conditions.append("x_h_m IS NOT NULL AND abs(x_h_m - ?) <= ?")
            parameters += [run_filter.x_h_m, X_H_MATCH_TOLERANCE_M]
        if run_filter.tailed is not None:
            conditions.append("tailed = ?")
            parameters.append(int(run_filter.tailed))
        if run_filter.exit_status is not None:
            conditions.append("exit_status = ?")
            parameters.append(run_filter.exit_status)
        if run_filter.started_since_utc is not None:
            conditions.append("start_time_utc >= ?")
            since = run_filter.started_since_utc.astimezone(UTC)
            parameters.append(since.isoformat(timespec="microseconds"))
        where = f"WHERE {' AND '.join(conditions)}" if conditions else ""
        with self._connection() as connection:
            connection.row_factory = sqlite3.Row
            rows = connection.execute(
                f"SELECT * FROM runs {where} ORDER BY start_time_utc, run_id", parameters
            ).fetchall()
        return [_entry_from_row(row) for row in rows]

    def reconcile(self, write_timeout_s: float = RECONCILE_WRITE_TIMEOUT_S) -> ReconcileReport:
        """Bring the catalog in line with the run directories (the truth).

        Runs listed as ``running`` whose process no longer holds the run lock are marked ``crashed`` (with
        sample and set-point counts read from their files); run directories the catalog does not know are
        registered; rows that differ from their finished run's ``run.json`` (a catalog update that failed or
        was still pending when the recording ended) are rewritten. If the catalog stays locked by another
        process for ``write_timeout_s``, the entries not written are returned in
        ``unwritten_entries`` (with ``write_error``) and the next reconcile writes them.
        """
        report = ReconcileReport()
        known = {entry.run_id: entry for entry in self.find_runs()}
        runs_folder = self.data_root / RUNS_FOLDER_NAME
        run_directories = sorted(runs_folder.iterdir()) if runs_folder.is_dir() else []
        changed: list[tuple[CatalogEntry, bool]] = []
        for run_directory in run_directories:
            metadata_path = run_directory / RUN_METADATA_FILE_NAME
            if not run_directory.is_dir() or not (
                metadata_path.exists() or metadata_path.is_symlink()
            ):
                continue
            existing = known.get(run_directory.name)
            try:
                entry = self._entry_from_run_directory(run_directory, existing)
            except (UserInputError, KeyError, TypeError, ValueError, AttributeError) as error:
                report.unreadable_run_directories.append(str(run_directory))
                reason = error.problem if isinstance(error, UserInputError) else repr(error)
                report.unreadable_reasons[str(run_directory)] = f"run.json: {reason}"
                continue
            if entry is None or entry == existing:
                continue
            changed.append((entry, existing is None))
        for index, (entry, is_new) in enumerate(changed):
            try:
                self.upsert_run(entry, busy_timeout_s=write_timeout_s)
            except sqlite3.OperationalError as error:
                if not is_lock_error(error):
                    raise
                report.write_error = str(error)
                report.unwritten_entries = [item for item, _ in changed[index:]]
                break
            if entry.exit_status == EXIT_STATUS_CRASHED:
                report.crashed_run_ids.append(entry.run_id)
            if is_new:
                report.registered_run_ids.append(entry.run_id)
            else:
                report.updated_run_ids.append(entry.run_id)
        return report

    def _entry_from_run_directory(
        self, run_directory: Path, existing: CatalogEntry | None
    ) -> CatalogEntry | None:
        """The entry the run directory says, or None when the catalog's row needs no look (a live run it
        knows, a crash it already recorded)."""
        relative = f"{RUNS_FOLDER_NAME}/{run_directory.name}"
        metadata = read_json_file(run_directory / RUN_METADATA_FILE_NAME)
        if metadata.get("exit_status") != EXIT_STATUS_RUNNING:
            return catalog_entry_from_run_metadata(metadata, relative)
        if existing is not None and existing.exit_status == EXIT_STATUS_CRASHED:
            return None  # a crashed run is never reopened: its row is final
        if existing is not None and run_is_live(run_directory):
            return None
        # Imported here (h5py, pandas): listing runs and `ornitail --help` need neither.
        from ornitail.acquisition.recording_reader import load_recording

        recording = load_recording(run_directory)
        return catalog_entry_from_run_metadata(recording.effective_metadata, relative)

    def runs_reconciled(
        self, run_filter: RunFilter | None = None
    ) -> tuple[list[CatalogEntry], ReconcileReport]:
        """Reconcile, then return the matching runs, oldest first, as the run directories say them: entries
        a locked catalog could not take are listed from the run directories."""
        report = self.reconcile()
        run_filter = run_filter or RunFilter()
        entries = {entry.run_id: entry for entry in self.find_runs(run_filter)}
        for entry in report.unwritten_entries:
            if run_filter.matches(entry):
                entries[entry.run_id] = entry
            else:
                entries.pop(entry.run_id, None)
        ordered = sorted(entries.values(), key=lambda entry: (entry.start_time_utc, entry.run_id))
        return ordered, report


def run_file_problems(data_root: Path, entry: CatalogEntry) -> list[str]:
    """What is wrong with a listed run's files on disk (empty when nothing): a samples file that is gone
    or is not a regular file. Such a run is not what its ``run.json`` says (``ornitail runs`` flags it)."""
    samples_path = Path(data_root) / entry.run_directory / SAMPLES_FILE_NAME
    if not samples_path.exists():
        return [f"{SAMPLES_FILE_NAME} is missing"]
    if not samples_path.is_file():
        return [f"{SAMPLES_FILE_NAME} is not a regular file"]
    return []


def _entry_from_row(row: sqlite3.Row) -> CatalogEntry:
    values = dict(row)
    for column in _JSON_COLUMNS:
        values[column] = json.loads(values[column])
    values["tailed"] = bool(values["tailed"])
    return CatalogEntry(**values)
