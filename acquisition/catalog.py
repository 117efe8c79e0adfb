"""The run catalog: an SQLite index (WAL mode, one commit per change) of the runs under a data root.

The run directories are the truth; the catalog is an index that :meth:`RunCatalog.reconcile` can
rebuild from them. Layout and fields: ``docs/catalog.md``.
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
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.core.errors import UserInputError

CATALOG_FILE_NAME = "catalog.sqlite"
DATA_ROOT_ENVIRONMENT_VARIABLE = "ORNITAIL_DATA"
DEFAULT_DATA_ROOT_NAME = "ornitail-data"
CATALOG_SCHEMA_VERSION = 1
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
    counter_missing_samples INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_by_start ON runs (start_time_utc);
"""
_JSON_COLUMNS = ("calibration_hashes", "set_point_summary")


def default_data_root() -> Path:
    """Return ``$ORNITAIL_DATA`` if set, else ``./ornitail-data``."""
    from_environment = os.environ.get(DATA_ROOT_ENVIRONMENT_VARIABLE, "").strip()
    return Path(from_environment) if from_environment else Path(DEFAULT_DATA_ROOT_NAME)


def utc_now_iso() -> str:
    """Current UTC time as ISO 8601 with microseconds and ``+00:00`` (sorts as text)."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


@dataclass
class CatalogEntry:
    """One run as the catalog lists it (``run_directory`` is relative to the data root)."""

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

    def to_json_dict(self) -> dict[str, Any]:
        """Return the entry as a JSON-serialisable dictionary."""
        return asdict(self)


def catalog_entry_from_run_metadata(metadata: dict[str, Any], run_directory: str) -> CatalogEntry:
    """Build a catalog entry from a run's metadata dictionary (the content of ``run.json``)."""
    configuration = metadata["configuration"]
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
        link_lost_samples=int(metadata["link_health"]["lost_samples"]),
        crc_errors=int(metadata["link_health"]["crc_errors"]),
        counter_gap_count=int(metadata["counter_gaps"]["count"]),
        counter_missing_samples=int(metadata["counter_gaps"]["missing_samples"]),
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
                "--status",
                f"{self.exit_status!r} is not one of {', '.join(ALL_EXIT_STATUSES)}",
            )
        if self.x_h_m is not None and not math.isfinite(self.x_h_m):
            raise UserInputError("--x-h-mm", f"value {self.x_h_m * 1e3!r} is not a finite number")
        if self.started_since_utc is not None and self.started_since_utc.tzinfo is None:
            raise ValueError("started_since_utc must be timezone-aware")


@dataclass
class ReconcileReport:
    """What :meth:`RunCatalog.reconcile` changed: runs found crashed, runs newly registered."""

    crashed_run_ids: list[str] = field(default_factory=list)
    registered_run_ids: list[str] = field(default_factory=list)
    unreadable_run_directories: list[str] = field(default_factory=list)


class RunCatalog:
    """The SQLite catalog ``<data_root>/catalog.sqlite`` (WAL mode; every change is one commit).

    Parameters
    ----------
    data_root : pathlib.Path
        Existing folder holding ``catalog.sqlite`` and ``runs/``.
    """

    def __init__(self, data_root: Path) -> None:
        self.data_root = Path(data_root)
        if not self.data_root.is_dir():
            raise UserInputError(str(self.data_root), "data root folder does not exist")
        self.path = self.data_root / CATALOG_FILE_NAME
        with self._connection() as connection:
            connection.executescript(_SCHEMA)
            connection.execute(f"PRAGMA user_version = {CATALOG_SCHEMA_VERSION}")

    @contextmanager
    def _connection(self) -> Iterator[sqlite3.Connection]:
        try:
            with closing(sqlite3.connect(self.path, timeout=30.0)) as connection:
                connection.execute("PRAGMA journal_mode = WAL")
                connection.execute("PRAGMA synchronous = FULL")
                with connection:  # one transaction, committed on success
                    yield connection
        except sqlite3.DatabaseError as error:
            if isinstance(error, sqlite3.OperationalError) and "locked" in str(error):
                raise
            raise UserInputError(str(self.path), f"not a usable catalog ({error})") from None

    def journal_mode(self) -> str:
        """Return SQLite's journal mode of the catalog (``"wal"``)."""
        with self._connection() as connection:
            return connection.execute("PRAGMA journal_mode").fetchone()[0]

    def upsert_run(self, entry: CatalogEntry) -> None:
        """Insert the run or replace its row, and commit."""
        row = entry.to_json_dict()
        for column in _JSON_COLUMNS:
            row[column] = json.dumps(row[column], allow_nan=False)
        row["tailed"] = int(row["tailed"])
        columns = ", ".join(row)
        placeholders = ", ".join(f":{name}" for name in row)
        with self._connection() as connection:
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

    def reconcile(self) -> ReconcileReport:
        """Bring the catalog in line with the run directories.

        Runs listed as ``running`` whose process no longer holds the run lock are marked
        ``crashed`` (with sample and set-point counts read from their files); run directories the
        catalog does not know are registered from their ``run.json``.
        """
        report = ReconcileReport()
        with self._connection() as connection:
            known = dict(connection.execute("SELECT run_id, exit_status FROM runs").fetchall())
        runs_folder = self.data_root / RUNS_FOLDER_NAME
        run_directories = sorted(runs_folder.iterdir()) if runs_folder.is_dir() else []
        for run_directory in run_directories:
            if not (run_directory / RUN_METADATA_FILE_NAME).is_file():
                continue
            status_in_catalog = known.get(run_directory.name)
            if status_in_catalog is not None and status_in_catalog != EXIT_STATUS_RUNNING:
                continue
            try:
                recording = load_recording(run_directory)
            except UserInputError:
                report.unreadable_run_directories.append(str(run_directory))
                continue
            if recording.status == EXIT_STATUS_RUNNING and status_in_catalog is not None:
                continue
            relative = f"{RUNS_FOLDER_NAME}/{run_directory.name}"
            self.upsert_run(catalog_entry_from_run_metadata(recording.effective_metadata, relative))
            if recording.status == EXIT_STATUS_CRASHED:
                report.crashed_run_ids.append(recording.run_id)
            if status_in_catalog is None:
                report.registered_run_ids.append(recording.run_id)
        return report


def _entry_from_row(row: sqlite3.Row) -> CatalogEntry:
    values = dict(row)
    for column in _JSON_COLUMNS:
        values[column] = json.loads(values[column])
    values["tailed"] = bool(values["tailed"])
    return CatalogEntry(**values)
