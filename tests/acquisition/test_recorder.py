"""Recorder and reader: round trip, exit statuses, loss accounting, display feed, bad input."""

from __future__ import annotations

import json
import math
import time
from contextlib import nullcontext
from pathlib import Path

import h5py
import numpy as np
import pytest

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    HDF5_SET_POINTS_GROUP,
    JOURNAL_FILE_NAME,
    RUN_METADATA_FILE_NAME,
    SAMPLES_FILE_NAME,
    ChannelSpec,
    RunAborted,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.run_engine import open_run
from ornitail.core.errors import UserInputError

CALIBRATION_FILE = Path(__file__).parents[1] / "data" / "calibration" / "FT8884.cal"
GAUGE_CHANNELS = [ChannelSpec(f"gauge_{index}", "V") for index in range(6)]
NINE_CHANNELS = GAUGE_CHANNELS + [
    ChannelSpec("hall_sensor", "V"),
    ChannelSpec("hot_wire", "V"),
    ChannelSpec("thermocouple", "V"),
]


def synthetic_samples(counters: np.ndarray, channel_count: int) -> np.ndarray:
    """Deterministic raw volts as a function of the counter, so a reader can check every value."""
    phase = counters.astype(np.float64)[:, None] * 1e-3 + np.arange(channel_count)[None, :]
    return np.sin(phase)


def tailed_configuration() -> RunConfiguration:
    return RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="steady_state")


def nine_channel_layout(counter_dtype: str = "uint64") -> StreamLayout:
    return StreamLayout(NINE_CHANNELS, sample_rate_hz=10_000.0, counter_dtype=counter_dtype)


def measurement(plan_point_index: int, first: int, last: int, **values) -> SetPointRecord:
    defaults = dict(
        pitch_rad=math.radians(15.0),
        tunnel_velocity_m_s=1.3,
        flapping_frequency_hz=12.0,
        tail_attached=True,
        motor_rpm_mean=3010.5,
        settle_time_s=1.0,
    )
    defaults.update(values)
    return SetPointRecord(plan_point_index, "measurement", first, last, **defaults)


def test_round_trip_keeps_every_raw_value_counter_set_point_and_metadata(tmp_path):
    with Recorder(
        tmp_path,
        tailed_configuration(),
        nine_channel_layout(),
        rig_description={"daq": "simulated"},
        calibration_files={"nano17": CALIBRATION_FILE},
        bias_voltages_v={"gauge_0": 0.0125},
    ) as recorder:
        for block_index in range(20):  # 20 blocks of 0.1 s at 10 kHz
            counters = np.arange(block_index * 1000, (block_index + 1) * 1000) + 5000
            recorder.put_block(counters, synthetic_samples(counters, 9))
        recorder.complete_set_point(
            SetPointRecord(0, "tare", 0, 4999, math.radians(15.0), 0.0, 0.0, True)
        )
        recorder.complete_set_point(measurement(1, 5000, 19999, extra={"hot_wire_m_s": 1.31}))
        recorder.update_bias_voltages({"gauge_1": -0.003})  # a wind-off tare measured mid-run
        during_run = json.loads((recorder.run_directory / RUN_METADATA_FILE_NAME).read_text())
        assert during_run["bias_voltages_v"] == {"gauge_0": 0.0125, "gauge_1": -0.003}
        assert during_run["exit_status"] == "running"
        recorder.report_link_health(crc_errors=3, lost_samples=7)
        recorder.report_link_health(crc_errors=1)

    recording = load_recording(recorder.run_directory)
    assert recording.status == "completed"
    assert recording.sample_count == 20_000
    frame = recording.samples_frame()
    assert list(frame.columns) == ["sample_counter", "time_s"] + [c.name for c in NINE_CHANNELS]
    expected_counters = np.arange(20_000) + 5000
    np.testing.assert_array_equal(frame["sample_counter"].to_numpy(), expected_counters)
    # Values are stored as delivered (float64): exact equality is required, no tolerance.
    np.testing.assert_array_equal(
        frame[[c.name for c in NINE_CHANNELS]].to_numpy(), synthetic_samples(expected_counters, 9)
    )
    # time_s counts from the run's first counter: row k is k / 10 kHz (float rounding only).
    np.testing.assert_allclose(frame["time_s"].to_numpy(), np.arange(20_000) / 10_000.0, atol=1e-12)

    assert [record.kind for record in recording.set_points] == ["tare", "measurement"]
    assert [record.set_point_index for record in recording.set_points] == [0, 1]
    measured = recording.set_point_frame(1)
    assert (measured.index[0], measured.index[-1]) == (5000, 19999)
    assert recording.set_points[1].extra == {"hot_wire_m_s": 1.31}
    assert recording.set_points_frame()["motor_rpm_mean"].iloc[1] == 3010.5

    metadata = json.loads((recorder.run_directory / RUN_METADATA_FILE_NAME).read_text())
    assert metadata["configuration"]["tail_id"] == "S3"
    assert metadata["configuration"]["x_h_m"] == 0.098
    assert metadata["stream"]["channels"][6] == {"name": "hall_sensor", "unit": "V"}
    assert metadata["bias_voltages_v"] == {"gauge_0": 0.0125, "gauge_1": -0.003}
    assert metadata["calibration_files"]["nano17"]["hash"].startswith("sha256:")
    assert metadata["link_health"] == {
        "crc_errors": 4,
        "lost_samples": 7,
        "garbage_bytes": 0,
        "resyncs": 0,
        "foreign_frames": 0,
        "report_count": 2,
    }
    assert metadata["counter_gaps"]["count"] == 0
    assert metadata["stop_time_utc"] >= metadata["start_time_utc"]
    assert metadata["set_point_summary"]["tare_count"] == 1
    assert metadata["writer_cpu_s"] > 0.0


def test_hdf5_file_holds_plain_numeric_datasets_and_string_attributes_for_matlab(tmp_path):
    with Recorder(tmp_path, tailed_configuration(), nine_channel_layout()) as recorder:
        counters = np.arange(3000)
        recorder.put_block(counters, synthetic_samples(counters, 9))
        recorder.complete_set_point(measurement(0, 100, 2999))
    with h5py.File(recorder.run_directory / SAMPLES_FILE_NAME, "r") as samples_file:
        datasets = {}
        samples_file.visititems(
            lambda name, item: (
                datasets.update({name: item}) if isinstance(item, h5py.Dataset) else None
            )
        )
        assert all(dataset.dtype.kind in "fiu" for dataset in datasets.values())
        assert datasets["samples/raw"].shape == (3000, 9)
        assert datasets["samples/counter"].dtype == np.uint64
        assert list(datasets["samples/raw"].attrs["channel_names"])[6] == "hall_sensor"
        table = samples_file[HDF5_SET_POINTS_GROUP]
        assert table["first_sample_index"][0] == 100
        assert table["last_sample_index"][0] == 2999
        assert table["pitch_rad"][0] == math.radians(15.0)
        assert table["is_tare"][0] == 0


@pytest.mark.parametrize(
    ("ending", "expected_status", "expected_reason"),
    [
        ("normal", "completed", None),
        ("mark_aborted", "aborted", "operator pressed stop"),
        ("run_aborted", "aborted", "stop button"),
        ("keyboard_interrupt", "aborted", "stopped by the user (KeyboardInterrupt)"),
        ("exception", "failed", "ValueError: strut actuator jammed"),
    ],
)
def test_exit_status_is_always_written_to_run_json_and_catalog(
    tmp_path, ending, expected_status, expected_reason
):
    recorder = Recorder(tmp_path, tailed_configuration(), nine_channel_layout())
    endings = {
        "run_aborted": RunAborted("stop button"),
        "keyboard_interrupt": KeyboardInterrupt(),
        "exception": ValueError("strut actuator jammed"),
    }
    expected_exception = type(endings[ending]) if ending in endings else None
    with (
        pytest.raises(expected_exception) if expected_exception else nullcontext(),
        open_run(recorder, DocumentDispatcher(), set_points_planned=0),
    ):
        counters = np.arange(1000)
        recorder.put_block(counters, synthetic_samples(counters, 9))
        if ending == "mark_aborted":
            recorder.mark_aborted("operator pressed stop")
        if ending in endings:
            raise endings[ending]
    recording = load_recording(recorder.run_directory)
    assert recording.status == expected_status
    assert recording.failure_reason == expected_reason
    assert recording.sample_count == 1000  # samples put before the exception are all kept
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert (entry.exit_status, entry.failure_reason) == (expected_status, expected_reason)
    assert entry.sample_count == 1000


def test_full_queue_drops_blocks_counts_them_and_the_counter_gaps_account_for_every_one(tmp_path):
    block_rows = 100
    with Recorder(
        tmp_path, tailed_configuration(), nine_channel_layout(), queue_capacity_blocks=1
    ) as recorder:
        accepted_rows = 0
        for block_index in range(400):  # a tight loop outruns a writer that flushes every write
            counters = np.arange(block_index * block_rows, (block_index + 1) * block_rows)
            accepted_rows += block_rows * recorder.put_block(
                counters, synthetic_samples(counters, 9)
            )
        while recorder.flushed_sample_count < accepted_rows:  # let the writer empty the queue,
            time.sleep(0.01)  # so the final block is accepted and every loss lies inside a gap
        final = np.arange(400 * block_rows, 401 * block_rows)
        assert recorder.put_block(final, synthetic_samples(final, 9))
        accepted_rows += block_rows
    metadata = load_recording(recorder.run_directory).metadata
    lost = metadata["queue_overflow"]["lost_samples"]
    assert lost > 0
    assert lost + accepted_rows == 401 * block_rows
    assert metadata["sample_count"] == accepted_rows
    assert metadata["counter_gaps"]["missing_samples"] == lost
    assert metadata["queue_overflow"]["lost_blocks"] * block_rows == lost
    frame = load_recording(recorder.run_directory).samples_frame()
    np.testing.assert_array_equal(
        frame[[c.name for c in NINE_CHANNELS]].to_numpy(),
        synthetic_samples(frame["sample_counter"].to_numpy(), 9),
    )


GAP_FIELDS = ("row_index", "counter_before", "counter_after", "missing_samples", "kind")


@pytest.mark.parametrize(
    ("counter_dtype", "counters", "expected_gaps"),
    [
        ("uint64", [np.arange(0, 1000), np.arange(1500, 2500)], [(1000, 999, 1500, 500, "jump")]),
        ("uint64", [np.arange(0, 10), np.arange(4, 10)], [(10, 9, 4, 0, "backward")]),
        ("uint32", [np.arange(2**32 - 5, 2**32), np.arange(0, 5)], []),  # wrap is continuous
        ("uint32", [np.arange(2**32 - 5, 2**32), np.arange(3, 8)], [(5, 2**32 - 1, 3, 3, "jump")]),
    ],
)
def test_counter_gaps_are_found_with_their_row_positions(
    tmp_path, counter_dtype, counters, expected_gaps
):
    with Recorder(tmp_path, tailed_configuration(), nine_channel_layout(counter_dtype)) as recorder:
        for block in counters:
            recorder.put_block(block, synthetic_samples(block, 9))
    recording = load_recording(recorder.run_directory)
    stored = recording.metadata["counter_gaps"]["positions"]
    expected = [dict(zip(GAP_FIELDS, gap, strict=True)) for gap in expected_gaps]
    assert stored == expected
    assert [gap.to_json_dict() for gap in recording.counter_gaps()] == expected


def test_display_feed_keeps_every_nth_row_and_drops_oldest_blocks(tmp_path):
    with Recorder(
        tmp_path,
        tailed_configuration(),
        nine_channel_layout(),
        display_decimation=7,
        display_capacity_blocks=3,
    ) as recorder:
        for block_index in range(10):
            counters = np.arange(block_index * 1000, (block_index + 1) * 1000)
            recorder.put_block(counters, synthetic_samples(counters, 9))
        waiting = recorder.display_feed.take_all()
    assert len(waiting) == 3  # 10 blocks offered, capacity 3: the 7 oldest dropped
    kept_counters = np.concatenate([counters for counters, _ in waiting])
    # No samples were lost, so counters equal row indices: every kept row is a multiple of 7.
    assert np.all(kept_counters % 7 == 0)
    np.testing.assert_array_equal(
        kept_counters, np.arange(7000, 10000)[np.arange(7000, 10000) % 7 == 0]
    )
    assert load_recording(recorder.run_directory).metadata["display_feed"]["dropped_blocks"] == 7
    assert recorder.display_feed.take_all() == []


def test_live_run_reads_as_running_and_journal_torn_last_line_is_ignored(tmp_path):
    with Recorder(tmp_path, tailed_configuration(), nine_channel_layout()) as recorder:
        counters = np.arange(2000)
        recorder.put_block(counters, synthetic_samples(counters, 9))
        recorder.complete_set_point(measurement(0, 0, 999))
        recorder.complete_set_point(measurement(1, 1000, 1999, repeat_index=1))
        while (
            recorder.flushed_sample_count < 2000
            or len(load_recording(recorder.run_directory).set_points) < 2
        ):
            time.sleep(0.005)  # the writer thread journals the set points after the flush
        live = load_recording(recorder.run_directory)
        assert live.status == "running"
        assert live.sample_count == 2000
    journal = recorder.run_directory / JOURNAL_FILE_NAME
    with open(journal, "a") as stream:
        stream.write('{"plan_point_index": 2, "kind": "meas')  # a write cut short by a crash
    assert [r.plan_point_index for r in load_recording(recorder.run_directory).set_points] == [0, 1]
    lines = journal.read_text().split("\n")
    journal.write_text("\n".join([lines[0], "not json", lines[1]]) + "\n")
    with pytest.raises(UserInputError, match="line 2"):
        load_recording(recorder.run_directory)


@pytest.mark.parametrize(
    ("configuration", "field"),
    [
        (RunConfiguration("S3", float("nan"), True), "x_h_m"),
        (RunConfiguration(None, None, True), "run configuration"),
        (RunConfiguration("  ", 0.098, True), "tail_id"),
    ],
)
def test_bad_run_configuration_is_a_user_error_naming_the_field(tmp_path, configuration, field):
    with pytest.raises(UserInputError, match=field):
        Recorder(tmp_path, configuration, nine_channel_layout())
    assert not (tmp_path / "runs").exists()


def test_missing_calibration_file_and_unknown_bias_channel_are_user_errors(tmp_path):
    with pytest.raises(UserInputError, match="missing.cal"):
        Recorder(
            tmp_path,
            tailed_configuration(),
            nine_channel_layout(),
            calibration_files={"nano17": tmp_path / "missing.cal"},
        )
    with pytest.raises(UserInputError, match="bias_voltages_v: gauge_9"):
        Recorder(
            tmp_path,
            tailed_configuration(),
            nine_channel_layout(),
            bias_voltages_v={"gauge_9": 0.1},
        )


def test_driver_mistakes_in_blocks_and_set_points_raise_and_the_run_still_ends_failed(tmp_path):
    recorder = Recorder(
        tmp_path,
        tailed_configuration(),
        StreamLayout(NINE_CHANNELS, 10_000.0, sample_dtype="int16"),
    )
    with pytest.raises(ValueError, match="do not fit int16"), recorder:
        counters = np.arange(100)
        recorder.put_block(counters, np.zeros((100, 9), dtype=np.int16))
        with pytest.raises(ValueError, match="shape"):
            recorder.put_block(counters, np.zeros((100, 8), dtype=np.int16))
        with pytest.raises(ValueError, match="integers"):
            recorder.put_block(counters.astype(float), np.zeros((100, 9), dtype=np.int16))
        with pytest.raises(ValueError, match="only 100 rows"):
            recorder.complete_set_point(measurement(0, 0, 100))
        with pytest.raises(ValueError, match="not JSON-serialisable"):
            recorder.complete_set_point(measurement(0, 0, 99, extra={"hot_wire_m_s": math.nan}))
        recorder.put_block(counters + 100, np.zeros((100, 9), dtype=np.float64))
    recording = load_recording(recorder.run_directory)
    assert recording.status == "failed"
    assert "do not fit int16" in recording.failure_reason
    assert recording.sample_count == 100
