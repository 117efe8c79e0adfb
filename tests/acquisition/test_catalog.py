"""Run catalog: WAL mode, registration at start and stop, filters, rescan, the `runs` command."""

from __future__ import annotations

import json
import shutil
import sqlite3
import subprocess
import sys
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.acquisition.catalog import (
    CATALOG_FILE_NAME,
    CATALOG_SCHEMA_VERSION,
    RunCatalog,
    RunFilter,
)
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.run_engine import open_run
from ornitail.app.cli import main
from ornitail.core.errors import UserInputError

CALIBRATION_FILE = Path(__file__).parents[1] / "data" / "calibration" / "FT8884.cal"
LAYOUT = StreamLayout([ChannelSpec(f"gauge_{index}", "V") for index in range(6)], 10_000.0)

# (tail_id, x_h_m, tailed, how the run ends)
RUN_CONFIGURATIONS = [
    ("S3", 0.098, True, "completed"),
    ("S3", 0.098, False, "completed"),
    ("S3", 0.120, True, "failed"),
    ("L1", 0.098, True, "aborted"),
    (None, None, False, "completed"),
]


def record_run(data_root: Path, tail_id, x_h_m, tailed, ending: str, sample_blocks: int = 2):
    """Record a short real run that ends as ``ending``, registered by its catalog subscriber; return its
    recorder."""
    recorder = Recorder(data_root, RunConfiguration(tail_id, x_h_m, tailed, "steady"), LAYOUT)
    try:
        with open_run(recorder, DocumentDispatcher(), set_points_planned=1):
            for block_index in range(sample_blocks):
                counters = np.arange(block_index * 500, (block_index + 1) * 500)
                recorder.put_block(counters, np.zeros((500, 6)))
            recorder.complete_set_point(
                SetPointRecord(0, "measurement", 0, 499, 0.26, 1.3, 12.0, bool(tailed))
            )
            if ending == "aborted":
                recorder.mark_aborted("operator stop")
            if ending == "failed":
                raise RuntimeError("tunnel fan tripped")
    except RuntimeError:
        pass
    return recorder


@pytest.fixture(scope="module")
def populated_data_root(tmp_path_factory) -> Path:
    data_root = tmp_path_factory.mktemp("data_root")
    for tail_id, x_h_m, tailed, ending in RUN_CONFIGURATIONS:
        record_run(data_root, tail_id, x_h_m, tailed, ending)
    return data_root


@pytest.fixture(scope="module")
def cli_main():
    """The ornitail root command (it registers `runs`)."""
    return main


def test_catalog_is_in_wal_mode_and_schema_is_versioned(tmp_path):
    catalog = RunCatalog(tmp_path)
    assert catalog.journal_mode() == "wal"
    with sqlite3.connect(tmp_path / CATALOG_FILE_NAME) as connection:
        assert connection.execute("PRAGMA user_version").fetchone()[0] == CATALOG_SCHEMA_VERSION


def test_run_is_registered_at_start_updated_per_set_point_and_at_stop(tmp_path):
    recorder = Recorder(
        tmp_path,
        RunConfiguration("S3", 0.098, True, "steady"),
        LAYOUT,
        calibration_files={"nano17": CALIBRATION_FILE},
    )
    with open_run(recorder, DocumentDispatcher(), set_points_planned=1) as run:
        assert run.catalog.wait_up_to_date(timeout_s=30)  # the row is written from its own thread
        at_start = RunCatalog(tmp_path).get_run(recorder.run_id)
        assert (at_start.exit_status, at_start.sample_count, at_start.set_point_count) == (
            "running",
            0,
            0,
        )
        recorder.put_block(np.arange(1000), np.zeros((1000, 6)))
        recorder.complete_set_point(SetPointRecord(0, "tare", 0, 999, 0.26, 0.0, 0.0, True))
        recorder.report_link_health(crc_errors=2, lost_samples=5)
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert entry.exit_status == "completed"
    assert entry.run_directory == f"runs/{recorder.run_id}"
    assert (entry.tail_id, entry.x_h_m, entry.tailed, entry.plan_name) == (
        "S3",
        0.098,
        True,
        "steady",
    )
    assert (entry.sample_count, entry.set_point_count) == (1000, 1)
    assert entry.set_point_summary["tare_count"] == 1
    assert (entry.crc_errors, entry.link_lost_samples) == (2, 5)
    assert entry.calibration_hashes["nano17"].startswith("sha256:")
    assert entry.software_version == "0.1.0"
    assert entry.stop_time_utc > entry.start_time_utc


@pytest.mark.parametrize(
    ("run_filter", "expected_configurations"),
    [
        (RunFilter(), RUN_CONFIGURATIONS),
        (RunFilter(tail_id="s3"), RUN_CONFIGURATIONS[:3]),
        (RunFilter(x_h_m=0.098), [RUN_CONFIGURATIONS[i] for i in (0, 1, 3)]),
        (RunFilter(x_h_m=0.09804), [RUN_CONFIGURATIONS[i] for i in (0, 1, 3)]),  # within 0.05 mm
        (RunFilter(x_h_m=0.0981), []),  # 0.1 mm away: another position
        (RunFilter(tailed=False), [RUN_CONFIGURATIONS[i] for i in (1, 4)]),
        (RunFilter(tail_id="S3", tailed=True, x_h_m=0.098), RUN_CONFIGURATIONS[:1]),
        (RunFilter(exit_status="failed"), RUN_CONFIGURATIONS[2:3]),
        (RunFilter(exit_status="aborted"), RUN_CONFIGURATIONS[3:4]),
        (RunFilter(started_since_utc=datetime.now(UTC) + timedelta(hours=1)), []),
        (RunFilter(started_since_utc=datetime.now(UTC) - timedelta(days=1)), RUN_CONFIGURATIONS),
    ],
)
def test_filters_select_the_matching_runs(populated_data_root, run_filter, expected_configurations):
    runs = RunCatalog(populated_data_root).find_runs(run_filter)
    found = [(run.tail_id, run.x_h_m, run.tailed, run.exit_status) for run in runs]
    assert found == expected_configurations


def test_rescan_rebuilds_a_lost_catalog_from_the_run_directories(populated_data_root, tmp_path):
    copied_root = tmp_path / "copy"
    shutil.copytree(populated_data_root / "runs", copied_root / "runs")
    catalog = RunCatalog(copied_root)
    report = catalog.reconcile()
    assert len(report.registered_run_ids) == len(RUN_CONFIGURATIONS)
    assert report.crashed_run_ids == []
    original = RunCatalog(populated_data_root).find_runs()
    assert catalog.find_runs() == original


@pytest.mark.parametrize(
    ("run_filter", "where"),
    [
        (RunFilter(exit_status="finished"), "exit_status"),  # the parameter; the CLI shows --status
        (RunFilter(x_h_m=float("nan")), "x_h_mm"),
    ],
)
def test_bad_filters_are_user_errors(tmp_path, run_filter, where):
    with pytest.raises(UserInputError, match=where):
        RunCatalog(tmp_path).find_runs(run_filter)


def test_a_file_that_is_not_a_catalog_is_a_user_error(tmp_path):
    (tmp_path / CATALOG_FILE_NAME).write_text("this is not SQLite")
    with pytest.raises(UserInputError, match="not a usable catalog"):
        RunCatalog(tmp_path)


def test_runs_command_prints_one_json_object_with_the_filtered_runs(populated_data_root, cli_main):
    result = CliRunner().invoke(
        cli_main,
        [
            "runs",
            "--data-root",
            str(populated_data_root),
            "--tail",
            "S3",
            "--x-h-mm",
            "98",
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert list(payload) == ["runs"]
    assert [(run["tailed"], run["exit_status"]) for run in payload["runs"]] == [
        (True, "completed"),
        (False, "completed"),
    ]
    assert payload["runs"][0]["x_h_m"] == 0.098
    assert payload["runs"][0]["set_point_summary"]["count"] == 1


def test_runs_command_table_lists_runs_and_failure_reasons(populated_data_root, cli_main):
    result = CliRunner().invoke(
        cli_main, ["runs", "--data-root", str(populated_data_root), "--status", "failed"]
    )
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].split()[:3] == ["run_id", "status", "tail"]
    assert lines[2].split()[1:5] == ["failed", "S3", "120.0", "tailed"]
    assert lines[3].strip() == "reason: RuntimeError: tunnel fan tripped"


def test_runs_command_reads_the_data_root_from_the_environment(populated_data_root, cli_main):
    result = CliRunner(env={"ORNITAIL_DATA": str(populated_data_root)}).invoke(
        cli_main, ["runs", "--tailless", "--json"]
    )
    assert result.exit_code == 0, result.output
    assert len(json.loads(result.stdout)["runs"]) == 2


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--status", "finished"], "--status: 'finished' is not one of"),
        (["--x-h-mm", "nan"], "--x-h-mm: value 'nan' is not a finite number"),
        (["--x-h-mm", "98mm"], "--x-h-mm: '98mm' is not a number of millimetres"),
        (["--since", "yesterday"], "--since: 'yesterday' is not an ISO 8601 date"),
    ],
)
def test_runs_command_bad_input_is_one_line_and_exit_2(
    populated_data_root, cli_main, arguments, message
):
    result = CliRunner().invoke(
        cli_main, ["runs", "--data-root", str(populated_data_root), *arguments]
    )
    assert result.exit_code == 2
    stderr_lines = result.stderr.splitlines()
    assert len(stderr_lines) == 1
    assert stderr_lines[0].startswith(f"ornitail: error: {message}")
    assert result.stdout == ""


def _ornitail_subprocess_command() -> list[str]:
    """The console script."""
    return [shutil.which("ornitail") or str(Path(sys.executable).parent / "ornitail")]


def test_runs_command_through_a_real_process(populated_data_root):
    command = _ornitail_subprocess_command()
    listed = subprocess.run(
        [
            *command,
            "runs",
            "--data-root",
            str(populated_data_root),
            "--since",
            "2000-01-01",
            "--json",
        ],
        capture_output=True,
        text=True,
    )
    assert listed.returncode == 0, listed.stderr
    assert len(json.loads(listed.stdout)["runs"]) == len(RUN_CONFIGURATIONS)
    missing_root = populated_data_root / "no_such_folder"
    failed = subprocess.run(
        [*command, "runs", "--data-root", str(missing_root)], capture_output=True, text=True
    )
    assert failed.returncode == 2
    assert failed.stderr.splitlines() == [
        f"ornitail: error: {missing_root}: data root folder does not exist"
    ]
