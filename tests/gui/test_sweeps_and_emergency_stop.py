"""Sweeps from the window: abort, pause, resume to the end and process; emergency stops; the design tab."""

import math

import pytest

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.recording_reader import load_recording

SHORT_PLAN = """
[plan]
name = "short"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[sweeps]
theta_deg = [3.0]
v_m_s = [-0.2, 0.2]
[protocol]
steady_state_repeats = 1
record_s = 0.6
tailless_points = "steady_state"
sample_rate_hz = 2000.0
[settle]
stable_for_s = 0.3
timeout_s = 60
"""
TOTAL_POINTS = (
    8  # tailed: tare 25, steady, 2 V points, tare 28, theta point; tailless: tare 25, steady
)


def _run_plan(window, qtbot, tmp_path, button):
    plan = tmp_path / "short.toml"
    plan.write_text(SHORT_PLAN)
    window.sweep_panel.plan_file.edit.setText(str(plan))
    button.click()
    qtbot.waitUntil(lambda: window.session.sweep_running, timeout=10_000)


def _wait_done(window, qtbot, timeout_ms=90_000):
    qtbot.waitUntil(
        lambda: not window.session.sweep_running and window.sweep_panel.last_result is not None,
        timeout=timeout_ms,
    )
    return window.sweep_panel.last_result


def _motor_and_fan_at_rest(window):
    readings = window.session.readings
    return readings.flapping_frequency_hz < 0.2 and readings.tunnel_velocity_m_s < 0.3


def _restart(window, qtbot, button):
    window.sweep_panel.last_result = None
    button.click()
    try:
        qtbot.waitUntil(lambda: window.session.sweep_running, timeout=10_000)
    except qtbot.TimeoutError:
        pytest.fail(f"the sweep did not start again; the window's log:\n{window.log.toPlainText()}")


def test_abort_pause_resume_complete_and_process_a_sweep(connected_at_2_khz, qtbot, tmp_path):
    window = connected_at_2_khz
    panel = window.sweep_panel
    _run_plan(window, qtbot, tmp_path, panel.run_button)
    qtbot.waitUntil(lambda: panel.progress.value() >= 2, timeout=60_000)
    # Count and ETA come from the run documents' plan progress (the window subscribes to them).
    assert panel.progress.maximum() == TOTAL_POINTS and panel.eta.text() != "ETA -"
    assert panel.eta.text().startswith("ETA ") and "SWEEP RUNNING" in window.status.recording.text()
    # The sweep records through the window's balance stream: the live view keeps moving while it runs (200 rows: 1 s
    # of rig time at the display's 200 Hz, a tenth of the 2 kHz stream).
    rows = window.data.rows_received
    qtbot.waitUntil(lambda: window.data.rows_received > rows + 200, timeout=10_000)
    assert window.session.sweep_running
    panel.abort_button.click()  # now: the point in progress is dropped
    aborted = _wait_done(window, qtbot)
    assert aborted.status == "aborted" and 2 <= aborted.completed_points < TOTAL_POINTS
    qtbot.waitUntil(lambda: _motor_and_fan_at_rest(window), timeout=20_000)
    assert [run.exit_status for run in RunCatalog(tmp_path).find_runs()] == ["aborted"]
    _restart(window, qtbot, panel.resume_button)
    qtbot.waitUntil(lambda: panel.progress.value() > aborted.completed_points, timeout=60_000)
    panel.pause_button.click()  # after the point in progress
    paused = _wait_done(window, qtbot)
    assert paused.status == "aborted" and aborted.completed_points < paused.completed_points
    _restart(window, qtbot, panel.resume_button)
    result = _wait_done(window, qtbot)
    assert (result.status, result.completed_points, result.total_points) == (
        "completed",
        TOTAL_POINTS,
        TOTAL_POINTS,
    )
    assert panel.progress.value() == TOTAL_POINTS
    # Every measurement once, none repeated; a point whose record still lost samples on a loaded machine is kept as
    # it was (journalled with its loss, the run incomplete) and recorded again by the resume: only such a point
    # repeats. A resume records the tares that zero the points it records again in their run, so tares may repeat.
    recorded = [
        (int(record.plan_point_index), record.kind, record.samples_missing_in_record > 0)
        for directory in result.run_directories
        for record in load_recording(directory).set_points
    ]
    whole = [(index, kind) for index, kind, lossy in recorded if not lossy]
    assert sorted({index for index, _ in whole}) == list(range(TOTAL_POINTS))
    measurements = [index for index, kind in whole if kind != "tare"]
    assert len(measurements) == len(set(measurements))
    # The live view still streams after the sweep.
    rows = window.data.rows_received
    qtbot.waitUntil(lambda: window.data.rows_received > rows + 200, timeout=10_000)
    runs_tab = window.runs_tab
    qtbot.waitUntil(lambda: runs_tab.table.rowCount() == len(result.run_directories), timeout=5_000)
    runs_tab.table.selectAll()
    runs_tab.process_button.click()
    qtbot.waitUntil(lambda: runs_tab.derivatives.rowCount() > 0, timeout=60_000)
    names = [
        runs_tab.derivatives.item(row, 0).text() for row in range(runs_tab.derivatives.rowCount())
    ]
    assert "Xu" in names and "X0" in names
    row = names.index("Xu")
    value = float(runs_tab.derivatives.item(row, 1).text())
    low, high = (float(x) for x in runs_tab.derivatives.item(row, 2).text().strip("[]").split(","))
    assert low < value < high
    # The drift fit's and the derivative fit's checks are said in the tab, one line each.
    details = runs_tab.details.toPlainText()
    assert "Balance drift" in details and "Derivative fit: the records" in details, details
    # The processed figures can be looked at in the tab (every PNG processing wrote, one shown).
    figures = [runs_tab.figure_choice.itemText(i) for i in range(runs_tab.figure_choice.count())]
    assert any(name.endswith("-sweep-fits") for name in figures), figures
    assert runs_tab.figure.pixmap is not None and not runs_tab.figure.pixmap.isNull()
    # Opening a run lists its set points with units and draws its raw signals; a set point zooms to its record.
    runs_tab.table.selectRow(0)
    runs_tab.open_button.click()
    browser = runs_tab.browser
    qtbot.waitUntil(lambda: browser.picture.pixmap is not None, timeout=60_000)
    assert browser.table.rowCount() == len(browser.opened.recording.set_points)
    header = [browser.table.horizontalHeaderItem(i).text() for i in range(3, 6)]
    assert header == ["theta (deg)", "V (m/s)", "f (Hz)"]
    whole = browser.picture.pixmap.cacheKey()
    browser.table.selectRow(1)
    qtbot.waitUntil(lambda: browser.picture.pixmap.cacheKey() != whole, timeout=60_000)


def test_emergency_stop_mid_sweep_stops_motor_and_tunnel(connected, qtbot, tmp_path):
    window = connected
    _run_plan(window, qtbot, tmp_path, window.sweep_panel.run_button)
    qtbot.waitUntil(lambda: window.session.readings.flapping_frequency_hz > 13.0, timeout=60_000)
    window.emergency_button.click()
    result = _wait_done(window, qtbot)
    assert result.status == "aborted"
    qtbot.waitUntil(lambda: _motor_and_fan_at_rest(window), timeout=20_000)
    assert "EMERGENCY STOP" in window.log.toPlainText()
    assert window.session.rig.fan.read_target_rpm() == 0.0


def test_emergency_stop_without_a_sweep_stops_a_flapping_vehicle_and_aborts_the_manual_run(
    connected, qtbot, drive_to, tmp_path
):
    window = connected
    documents = []
    window.session.documents.subscribe(lambda name, document: documents.append((name, document)))
    window.controls.start_button.click()
    qtbot.waitUntil(lambda: window.session.recording is not None, timeout=10_000)
    drive_to(window, 20.0, 1.0, 12.0)
    window.emergency_button.click()
    qtbot.waitUntil(lambda: _motor_and_fan_at_rest(window), timeout=20_000)
    assert math.isfinite(window.session.readings.pitch_rad)
    qtbot.waitUntil(lambda: window.session.recording is None, timeout=10_000)
    assert [name for name, _ in documents] == ["start", "stop"]
    stop = documents[-1][1]
    assert (stop.exit_status, stop.reason, stop.set_points_recorded) == (
        "aborted",
        "emergency stop",
        0,
    )
    (run,) = RunCatalog(tmp_path).find_runs()
    assert (run.run_id, run.exit_status) == (stop.run_id, "aborted")


def test_design_tab_draws_a_proposed_tail_with_poles_and_damping(window, qtbot):
    design = window.design_tab
    design.theta.value.setValue(22.0)
    design.zeta.setValue(0.25)
    design.propose_button.click()
    qtbot.waitUntil(lambda: design.result is not None, timeout=60_000)
    text = design.summary.toPlainText()
    assert "damping ratio" in text and "poles (1/s)" in text and "steady state:" in text
    zeta = design.result["oscillatory_mode"]["damping_ratio"]["value"]
    assert zeta >= 0.25 - 1e-3
    assert len(design.planform.listDataItems()) == 2  # base tail and proposal
    assert len(design.result["poles"]) == len(design.poles.listDataItems()[0].xData)
