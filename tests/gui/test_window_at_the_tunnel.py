"""The window driving the simulated rig: connect, limits, tare, manual recording, cycle view, frozen window; and
what the window shows of the run documents alone."""

import math
import time

import numpy as np

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import PlanProgress
from ornitail.acquisition.run_engine import open_run


def test_connect_shows_status_live_values_and_refuses_a_pitch_outside_the_limits(connected, qtbot):
    window = connected
    qtbot.waitUntil(lambda: "pitch" in window.live_view.readout.text(), timeout=5_000)
    assert "simulated DelFly tunnel rig" in window.status.instruments.text()
    assert "CRC errors 0" in window.status.link.text()
    assert window.status.saturation.text() == "no saturation"
    # The rig's limits bound the spin box; a value typed past them is clamped to the limit.
    window.controls.pitch.setValue(80.0)
    assert window.controls.pitch.value() == 45.0
    # A set point the rig refuses arrives as a message in the window, not a traceback.
    window.session.set_pitch_deg(60.0)
    qtbot.waitUntil(lambda: bool(window.log.problems), timeout=5_000)
    assert "60 deg is outside the rig limit -10..45 deg" in window.log.problems[-1]
    assert "Input problem" in window.log.toPlainText()


def test_tare_record_and_cycle_view_make_a_processable_manual_run(
    connected, qtbot, tmp_path, drive_to
):
    window = connected
    documents = []
    window.session.documents.subscribe(lambda name, document: documents.append((name, document)))
    controls = window.controls
    controls.pitch.setValue(25.0)
    controls.set_buttons["pitch"].click()
    controls.tail_id.setText("S3")
    controls.x_h_mm.setValue(98.0)
    controls.start_button.click()
    qtbot.waitUntil(lambda: window.session.recording is not None, timeout=10_000)
    qtbot.waitUntil(
        lambda: abs(math.degrees(window.session.readings.pitch_rad) - 25) < 0.2, timeout=20_000
    )
    controls.record_s.setValue(0.5)
    # A point before the run has a tare at this pitch is refused, saying why (processing could not use it).
    controls.point_button.click()
    qtbot.waitUntil(lambda: bool(window.log.problems), timeout=10_000)
    assert "no wind-off tare at theta = 25.00 deg" in window.log.problems[-1]
    assert window.session.recording.points == 0
    # A strut that is not where it was sent (halted mid-move) refuses the record, naming both angles.
    window.session.commanded["pitch_rad"] = math.radians(30.0)
    controls.tare_button.click()
    qtbot.waitUntil(lambda: "not at its set point" in window.log.problems[-1], timeout=20_000)
    assert "pitch reads 25.00 deg, set 30.00 deg" in window.log.problems[-1]
    window.session.commanded["pitch_rad"] = math.radians(25.0)
    controls.tare_button.click()
    qtbot.waitUntil(lambda: "samples (in run" in window.log.toPlainText(), timeout=20_000)
    assert window.session.tare_volts.shape == (6,)
    assert "over 5000 samples" in window.log.toPlainText()  # 0.5 s at 10 kHz
    drive_to(window, 25.0, 0.8, 13.5)
    # Phase-averaged loads appear once cycles arrive: many cycles, 2 sigma band, the current (tailed) state.
    updates = window.cycle_view.updates
    qtbot.waitUntil(lambda: window.cycle_view.updates >= updates + 3, timeout=10_000)
    tailed = window.cycle_view.latest[True]
    assert tailed.cycle_count >= 10
    assert abs(tailed.flapping_frequency_hz - 13.5) < 0.3
    assert np.all(tailed.spread >= 0) and np.ptp(tailed.load("x_n")[0]) > 0
    controls.record_s.setValue(0.6)
    controls.point_button.click()
    qtbot.waitUntil(lambda: window.session.recording.points == 2, timeout=20_000)
    controls.stop_button.click()
    qtbot.waitUntil(lambda: window.session.recording is None, timeout=10_000)
    (run,) = RunCatalog(tmp_path).find_runs()
    assert (run.exit_status, run.tail_id, run.tailed, run.set_point_count) == (
        "completed",
        "S3",
        True,
        2,
    )
    recording = load_recording(tmp_path / run.run_directory)
    frame = recording.set_points_frame()
    assert list(frame["kind"]) == ["tare", "measurement"]
    assert list(frame["last_sample_index"] - frame["first_sample_index"] + 1) == [5000, 6000]
    assert abs(math.degrees(frame["pitch_rad"].iloc[0]) - 25.0) < 0.2
    assert abs(frame["tunnel_velocity_m_s"].iloc[1] - 0.8) < 0.02
    # The manual run is a documented run like a sweep's: start, a set point per record kept (the refused ones
    # emit nothing), stop.
    assert [name for name, _ in documents] == ["start", "set_point", "set_point", "stop"]
    start, tare, point, stop = (document for _, document in documents)
    assert (start.run_id, start.plan_name, start.set_points_planned) == (run.run_id, "manual", 0)
    assert [tare.kind, point.kind] == ["tare", "measurement"]
    assert [tare.sequence, point.sequence] == [1, 2]
    assert start.progress is tare.progress is point.progress is None  # no plan: no plan's progress
    assert point.first_sample_index == frame["first_sample_index"].iloc[1]
    assert abs(point.tunnel_velocity_m_s - 0.8) < 1e-9
    assert (stop.exit_status, stop.reason, stop.set_points_recorded) == ("completed", None, 2)
    assert stop.run_metadata["set_point_count"] == 2
    # The runs tab lists it.
    qtbot.waitUntil(lambda: window.runs_tab.table.rowCount() == 1, timeout=5_000)
    assert window.runs_tab.table.item(0, 1).text() == "completed"


def test_a_frozen_window_loses_no_recorded_sample(connected, qtbot, tmp_path):
    window = connected
    window.controls.start_button.click()
    qtbot.waitUntil(lambda: window.session.recording is not None, timeout=10_000)
    window.controls.record_s.setValue(1.0)
    window.controls.tare_button.click()  # a tare is recorded into the run like any point
    time.sleep(1.5)  # the GUI thread is blocked: no redraw, no event handling
    qtbot.waitUntil(lambda: window.session.recording.points == 1, timeout=20_000)
    assert window.session.live.health().recorder_lost_samples == 0
    window.controls.stop_button.click()
    qtbot.waitUntil(lambda: window.session.recording is None, timeout=10_000)
    (run,) = RunCatalog(tmp_path).find_runs()
    recording = load_recording(tmp_path / run.run_directory)
    assert recording.metadata["queue_overflow"]["lost_samples"] == 0
    frame = recording.set_points_frame()
    assert (
        int(frame["last_sample_index"].iloc[0] - frame["first_sample_index"].iloc[0] + 1) == 10_000
    )


def test_the_window_shows_progress_warnings_and_stopped_runs_from_the_documents_alone(
    window, tmp_path
):
    recorder = Recorder(
        tmp_path,
        RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="short"),
        StreamLayout([ChannelSpec("gauge_0", "V")], sample_rate_hz=1000.0),
    )
    panel, line = (
        window.sweep_panel,
        "warning: set point #1 (measurement): 100 of 100 samples saturated",
    )
    with open_run(
        recorder, window.session.documents, set_points_planned=2, progress=PlanProgress(0, 2, 30.0)
    ) as run:
        window.tick()
        assert (panel.progress.value(), panel.progress.maximum()) == (0, 2)
        recorder.put_block(np.arange(100), np.zeros((100, 1)))
        record = SetPointRecord(1, "measurement", 0, 99, 0.44, 0.8, 13.5, True)
        recorder.complete_set_point(record)
        run.documents.set_point(record, PlanProgress(1, 2, 15.0), [line])
        window.tick()
        assert (panel.progress.value(), panel.progress.maximum()) == (1, 2)
        assert panel.eta.text() == "ETA 0:15 (m:ss)"  # no rig: rig time is wall time
        assert line in window.log.toPlainText()
        assert "recorded measurement #1 (1/2)" in window.log.toPlainText()
        assert window.runs_tab.table.rowCount() == 0  # nothing listed it yet
    window.tick()
    # The stop document lists the run as its stop record says, whether or not the catalog has it yet.
    assert window.runs_tab.table.rowCount() == 1
    assert window.runs_tab.table.item(0, 0).text() == recorder.run_id
    assert window.runs_tab.table.item(0, 1).text() == "completed"
