"""The recorder counts flagged rows per set point, fsyncs samples.h5 before the journal points into it, ends a
run incomplete when told, and never lets a locked catalog touch its writer thread."""

from __future__ import annotations

import json
import math
import os
import sqlite3
import threading
from contextlib import AbstractContextManager
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.acquisition import catalog_sync
from ornitail.acquisition.catalog import CATALOG_FILE_NAME, RunCatalog
from ornitail.acquisition.recorder import FlaggedRows, Recorder
from ornitail.acquisition.recording_layout import (
    HDF5_SET_POINTS_GROUP,
    JOURNAL_FILE_NAME,
    ROW_FLAG_OVER_RATED_RANGE,
    ROW_FLAG_SATURATED,
    RUN_METADATA_FILE_NAME,
    SAMPLES_FILE_NAME,
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.run_engine import OpenRun, open_run
from ornitail.acquisition.run_files import read_journal
from ornitail.app.cli import main

LAYOUT = StreamLayout([ChannelSpec(f"gauge_{index}", "V") for index in range(6)], 10_000.0)
CONFIGURATION = RunConfiguration("S3", 0.098, True, "flags")


def point(
    plan_point_index: int, first: int, last: int, kind: str = "measurement"
) -> SetPointRecord:
    return SetPointRecord(plan_point_index, kind, first, last, math.radians(20.0), 0.8, 13.5, True)


def catalogued_run(data_root: Path) -> AbstractContextManager[OpenRun]:
    """A run of ``CONFIGURATION`` with its catalog subscriber, opened as sweeps and the window open theirs."""
    return open_run(
        Recorder(data_root, CONFIGURATION, LAYOUT), DocumentDispatcher(), set_points_planned=0
    )


def put_rows(recorder: Recorder, first: int, count: int, flags: np.ndarray | None = None) -> None:
    counters = np.arange(first, first + count, dtype=np.uint64)
    assert recorder.put_block(counters, np.zeros((count, 6)), flags)


def test_flagged_rows_merge_across_blocks_and_are_counted_in_any_range():
    rows = FlaggedRows()
    rows.add(0, np.array([0, 1, 1, 0], dtype=bool))  # rows 1, 2
    rows.add(4, np.array([1, 1, 0, 1], dtype=bool))  # rows 4, 5 (not adjacent to 2), 7
    rows.add(8, np.array([1, 1], dtype=bool))  # rows 8, 9 continue 7
    assert rows.total == 7
    assert rows._starts == [1, 4, 7] and rows._ends == [3, 6, 10]
    assert [rows.count_in(a, b) for a, b in [(0, 9), (2, 4), (3, 3), (6, 7), (9, 100)]] == [
        7,
        2,
        0,
        1,
        1,
    ]


def test_flagged_rows_are_counted_per_set_point_in_journal_hdf5_run_json_and_catalog(tmp_path):
    with catalogued_run(tmp_path) as run:
        recorder = run.recorder
        flags = np.zeros(1000, dtype=np.uint8)
        flags[100:350] |= ROW_FLAG_SATURATED  # rows 100..349, across the block boundary at 300
        flags[300:400] |= ROW_FLAG_OVER_RATED_RANGE
        put_rows(recorder, 0, 300, flags[:300])
        put_rows(recorder, 300, 700, flags[300:])
        put_rows(recorder, 1000, 500)  # no flags given: nothing flagged in these rows
        recorder.complete_set_point(point(0, 0, 199, "tare"))
        recorder.complete_set_point(point(1, 200, 499))
        recorder.complete_set_point(point(2, 500, 1499))
        assert run.catalog.wait_up_to_date(timeout_s=30)
    journal = read_journal(recorder.run_directory)
    counts = [(record.saturated_samples, record.over_range_samples) for record in journal]
    assert counts == [(100, 0), (150, 100), (0, 0)]
    with h5py.File(recorder.run_directory / SAMPLES_FILE_NAME, "r") as samples:
        table = samples[HDF5_SET_POINTS_GROUP]
        assert table["saturated_samples"][:].tolist() == [100, 150, 0]
        assert table["over_range_samples"][:].tolist() == [0, 100, 0]
    saturation = json.loads((recorder.run_directory / RUN_METADATA_FILE_NAME).read_text())[
        "saturation"
    ]
    assert saturation == {
        "checked": True,
        "saturated_samples": 250,
        "over_range_samples": 100,
        "affected_set_points": [
            {
                "set_point_index": 0,
                "plan_point_index": 0,
                "kind": "tare",
                "saturated_samples": 100,
                "over_range_samples": 0,
            },
            {
                "set_point_index": 1,
                "plan_point_index": 1,
                "kind": "measurement",
                "saturated_samples": 150,
                "over_range_samples": 100,
            },
        ],
        "affected_set_point_count": 2,
        "stream_saturated_samples": 250,
        "stream_over_range_samples": 100,
    }
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert (entry.saturated_samples, entry.over_range_samples, entry.saturated_set_points) == (
        250,
        100,
        2,
    )


def test_a_run_without_row_flags_says_it_was_not_checked(tmp_path):
    with Recorder(tmp_path, CONFIGURATION, LAYOUT) as recorder:
        put_rows(recorder, 0, 100)
        recorder.complete_set_point(point(0, 0, 99))
    (record,) = read_journal(recorder.run_directory)
    assert (record.saturated_samples, record.over_range_samples) == (None, None)
    metadata = load_recording(recorder.run_directory).metadata
    assert metadata["saturation"]["checked"] is False
    with h5py.File(recorder.run_directory / SAMPLES_FILE_NAME, "r") as samples:
        assert samples[HDF5_SET_POINTS_GROUP]["saturated_samples"][:].tolist() == [-1]


def test_samples_file_is_fsynced_before_each_journal_line_that_points_into_it(
    tmp_path, monkeypatch
):
    synced: list[str] = []
    real_fsync = os.fsync

    def recording_fsync(descriptor: int) -> None:
        synced.append(Path(os.readlink(f"/proc/self/fd/{descriptor}")).name)
        real_fsync(descriptor)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    with Recorder(tmp_path, CONFIGURATION, LAYOUT) as recorder:
        put_rows(recorder, 0, 2000)
        recorder.complete_set_point(point(0, 0, 999))
        put_rows(recorder, 2000, 1000)
        recorder.complete_set_point(point(1, 1000, 2999))
    relevant = [name for name in synced if name in (SAMPLES_FILE_NAME, JOURNAL_FILE_NAME)]
    # each journal line follows an fsync of samples.h5; the closed file is fsynced once more at stop
    assert relevant == [SAMPLES_FILE_NAME, JOURNAL_FILE_NAME] * 2 + [SAMPLES_FILE_NAME]


def test_a_run_marked_incomplete_ends_incomplete_with_the_reason(tmp_path):
    with catalogued_run(tmp_path) as run:
        recorder = run.recorder
        put_rows(recorder, 0, 100)
        recorder.complete_set_point(point(4, 0, 99))
        recorder.mark_incomplete("set point #4 lost 30 samples inside its record after 3 retakes")
    recording = load_recording(recorder.run_directory)
    assert recording.status == "incomplete"
    assert recording.failure_reason.startswith("set point #4 lost 30 samples")
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert (entry.exit_status, entry.failure_reason) == ("incomplete", recording.failure_reason)


@pytest.fixture
def locked_catalog(tmp_path):
    """Another process's connection holding the catalog's write lock (BEGIN EXCLUSIVE) until released."""
    RunCatalog(tmp_path)  # an existing, up-to-date catalog
    holder = sqlite3.connect(tmp_path / CATALOG_FILE_NAME, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    yield holder
    if holder.in_transaction:
        holder.execute("ROLLBACK")
    holder.close()


def test_a_locked_catalog_never_reaches_the_writer_and_is_reconciled_after_release(
    tmp_path, locked_catalog, monkeypatch
):
    monkeypatch.setattr(catalog_sync, "FINAL_WAIT_S", 0.5)
    monkeypatch.setattr(catalog_sync, "RETRY_INTERVAL_S", 0.05)
    writing_threads: list[str] = []
    real_upsert = RunCatalog.upsert_run

    def watched_upsert(self, entry, busy_timeout_s=None):
        writing_threads.append(threading.current_thread().name)
        return real_upsert(self, entry, busy_timeout_s)

    monkeypatch.setattr(RunCatalog, "upsert_run", watched_upsert)
    with catalogued_run(tmp_path) as run:  # held at start: no traceback
        recorder = run.recorder
        for index in range(5):
            put_rows(recorder, index * 1000, 1000)
            recorder.complete_set_point(point(index, index * 1000, index * 1000 + 999))
    recording = load_recording(recorder.run_directory)
    assert recording.status == "completed"
    assert len(recording.set_points) == 5 and recording.sample_count == 5000
    assert recording.metadata["queue_overflow"]["lost_samples"] == 0
    assert writing_threads and set(writing_threads) == {f"catalog-{recorder.run_id}"}
    assert run.catalog.synced is False  # the row waits for the next reconcile
    assert all("locked" in error for error in recording.metadata["catalog_errors"])
    assert recording.metadata["catalog_errors"]

    # Still locked: `ornitail runs` lists the run as its directory says, with a note; exit code 0.
    listed = CliRunner().invoke(main, ["runs", "--data-root", str(tmp_path), "--json"])
    assert listed.exit_code == 0, listed.output
    (run,) = json.loads(listed.stdout)["runs"]
    assert (run["run_id"], run["exit_status"], run["set_point_count"]) == (
        recorder.run_id,
        "completed",
        5,
    )
    assert "is locked by another process" in listed.stderr
    assert RunCatalog(tmp_path).get_run(recorder.run_id) is None

    locked_catalog.execute("ROLLBACK")
    report = RunCatalog(tmp_path).reconcile()
    assert report.registered_run_ids == [recorder.run_id] and report.write_error is None
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert (entry.exit_status, entry.sample_count, entry.set_point_count) == ("completed", 5000, 5)


def test_a_stale_catalog_row_is_rewritten_from_run_json(tmp_path, monkeypatch):
    """A row left at "running" (the stop record never reached the catalog) is brought up to date."""
    with catalogued_run(tmp_path) as run:
        recorder = run.recorder
        assert run.catalog.wait_up_to_date(timeout_s=30)
        stale = RunCatalog(tmp_path).get_run(recorder.run_id)
        put_rows(recorder, 0, 100)
        recorder.complete_set_point(point(0, 0, 99))
    catalog = RunCatalog(tmp_path)
    catalog.upsert_run(stale)
    assert catalog.get_run(recorder.run_id).exit_status == "running"
    report = catalog.reconcile()
    assert report.updated_run_ids == [recorder.run_id]
    entry = catalog.get_run(recorder.run_id)
    assert (entry.exit_status, entry.set_point_count) == ("completed", 1)
    assert catalog.reconcile().updated_run_ids == []  # nothing stale any more


def test_a_version_1_catalog_gains_the_new_columns(tmp_path):
    with sqlite3.connect(tmp_path / CATALOG_FILE_NAME) as connection:
        connection.execute("PRAGMA journal_mode = WAL")
        connection.execute(
            "CREATE TABLE runs (run_id TEXT PRIMARY KEY, run_directory TEXT NOT NULL, tail_id TEXT, "
            "x_h_m REAL, tailed INTEGER NOT NULL, plan_name TEXT NOT NULL, resumed_from_run_id TEXT, "
            "start_time_utc TEXT NOT NULL, stop_time_utc TEXT, exit_status TEXT NOT NULL, "
            "failure_reason TEXT, software_version TEXT NOT NULL, calibration_hashes TEXT NOT NULL, "
            "sample_count INTEGER NOT NULL, set_point_count INTEGER NOT NULL, "
            "set_point_summary TEXT NOT NULL, queue_lost_samples INTEGER NOT NULL, "
            "link_lost_samples INTEGER NOT NULL, crc_errors INTEGER NOT NULL, "
            "counter_gap_count INTEGER NOT NULL, counter_missing_samples INTEGER NOT NULL)"
        )
        connection.execute(
            "INSERT INTO runs VALUES ('old', 'runs/old', 'S3', 0.098, 1, 'p', NULL, "
            "'2024-01-01T00:00:00.000000+00:00', NULL, 'completed', NULL, '0.1.0', '{}', 10, 1, "
            "'{}', 0, 3, 0, 1, 3)"
        )
        connection.execute("PRAGMA user_version = 1")
    entry = RunCatalog(tmp_path).get_run("old")
    assert (entry.counter_missing_samples, entry.lost_samples, entry.saturated_set_points) == (
        3,
        3,
        0,
    )
