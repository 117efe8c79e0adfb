"""End to end on the simulated rig: saturation reported from the board to `ornitail process`, a point lossy
through its retakes ending the sweep incomplete and recorded again by a resume, a catalog locked through a
sweep costing nothing, and lost samples counted once alike by `ornitail runs`, the sweep report and the GUI.

Faults are switched on and off from the sweep's own events (no sleeps): the board applies them to every sample
it has not yet sent, so a fault switched on when a point starts moving covers its whole record, and one switched
off at its "recorded" event covers nothing after it.
"""

import json
import sqlite3

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.acquisition import catalog_sync, set_point_recording
from ornitail.acquisition.catalog import CATALOG_FILE_NAME, RunCatalog
from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.set_point_recording import MAX_RETAKES
from ornitail.acquisition.sweep import run_sweep
from ornitail.acquisition.sweep_plan import plan_from_document, zero_references
from ornitail.app.cli import main
from ornitail.app.sweep_session import EXIT_INCOMPLETE, exit_code_of, sweep_result_record
from ornitail.balance.sweep_table import cycle_averaged_table

SHORT_PLAN = {
    "plan": {"name": "short-faults"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "sweeps": {"theta_deg": [3.0], "v_m_s": [0.2]},
    "protocol": {
        "steady_state_repeats": 1,
        "record_s": 0.6,
        "tailless_points": "steady_state",
        "sample_rate_hz": 2000.0,
    },
    "settle": {"stable_for_s": 0.3, "timeout_s": 300},  # 50 s of wall time at 6 x
}
RECORD_ROWS = 1200  # 0.6 s at 2 kHz


@pytest.fixture
def simulated_time_scale():
    # 2 kHz (the plan's rate) x 6 = 12 k frames/s on the pty: well below the 50 k/s of test_sweep.py, so that a
    # machine loaded by other work does not lose samples on the link (these tests count samples and lossy
    # points exactly); the low rate lets simulated time run faster than the wall clock at a light link load
    return 6.0


@pytest.fixture
def plan():
    return plan_from_document(SHORT_PLAN, "short.toml")


@pytest.fixture
def cli():
    """The `ornitail` group, run in-process."""
    return lambda *arguments: CliRunner().invoke(main, [str(argument) for argument in arguments])


def listed_runs(cli, data_root) -> dict[str, dict]:
    result = cli("runs", "--data-root", data_root, "--json")
    assert result.exit_code == 0, result.output
    return {run["run_id"]: run for run in json.loads(result.stdout)["runs"]}


def first_tailed_measurement(plan):
    return next(p for p in plan.set_points if p.kind == "measurement" and p.tail_attached)


def test_a_gauge_held_at_the_rail_is_reported_from_the_sweep_to_process(
    simulated_rig, plan, tmp_path, cli
):
    board = simulated_rig.simulators.daq_board
    target = first_tailed_measurement(plan)

    def on_event(event):
        if event.set_point is not None and event.set_point.index == target.index:
            if event.stage == "moving":
                board.hold_gauge_at_rail(1)  # +32767 counts: Fy = -84 N, beyond the 50 N rating
            elif event.stage == "recorded":
                board.release_gauge(1)

    documents = DocumentDispatcher()
    set_points = []
    documents.subscribe(
        lambda name, document: set_points.append(document) if name == "set_point" else None
    )
    data_root = tmp_path / "data"
    result = run_sweep(plan, simulated_rig, data_root, on_event=on_event, documents=documents)
    assert result.status == "completed" and exit_code_of(result) == 0

    # The sweep: one warning line, for that point only, in its set point document and in the result.
    warned = [document for document in set_points if document.warnings]
    assert [document.plan_point_index for document in warned] == [target.index]
    (line,) = warned[0].warnings
    assert result.warnings == [line]
    assert f"#{target.index} " in line
    assert f"{RECORD_ROWS} of {RECORD_ROWS} samples saturated" in line

    # The journal: the whole record saturated and over the rating; every other point clean.
    tailed = load_recording(result.run_directories[0])
    counts = {
        record.plan_point_index: (record.saturated_samples, record.over_range_samples)
        for record in tailed.set_points
    }
    assert counts.pop(target.index) == (RECORD_ROWS, RECORD_ROWS)
    assert set(counts.values()) == {(0, 0)}

    # run.json and the catalog.
    saturation = tailed.metadata["saturation"]
    assert (saturation["saturated_samples"], saturation["over_range_samples"]) == (
        RECORD_ROWS,
        RECORD_ROWS,
    )
    assert [item["plan_point_index"] for item in saturation["affected_set_points"]] == [
        target.index
    ]
    assert saturation["stream_saturated_samples"] >= RECORD_ROWS
    runs = listed_runs(cli, data_root)
    run = runs[tailed.run_id]
    assert (run["saturated_samples"], run["over_range_samples"], run["saturated_set_points"]) == (
        RECORD_ROWS,
        RECORD_ROWS,
        1,
    )
    tailless_run = runs[load_recording(result.run_directories[1]).run_id]
    assert tailless_run["saturated_set_points"] == 0
    table_text = cli("runs", "--data-root", data_root)
    assert "saturation: 1 set point(s)" in table_text.stdout

    # `ornitail process` refuses the point in one line naming run and set point ...
    refused = cli("process", *result.run_directories, "--out", tmp_path / "out")
    assert refused.exit_code == 2
    (line,) = refused.stderr.strip().splitlines()
    assert f"{result.run_directories[0]}: set point {target.index}:" in line
    assert "--keep-saturated" in line and "Traceback" not in refused.output
    # ... and keeps it, flagged, when asked.
    kept = cli(
        "process", *result.run_directories, "--out", tmp_path / "out", "--keep-saturated", "--json"
    )
    assert kept.exit_code == 0, kept.output
    record = json.loads(kept.stdout)
    flagged = [w for w in record["warnings"] if "kept with saturated samples" in w]
    assert len(flagged) == 1 and f"set point {target.index} " in flagged[0]
    table = cycle_averaged_table(result.run_directories, keep_saturated=True)
    row = table[table["plan_point_index"] == target.index].iloc[0]
    assert (row["saturated_samples"], row["over_range_samples"]) == (RECORD_ROWS, RECORD_ROWS)
    assert (table[table["plan_point_index"] != target.index]["saturated_samples"] == 0).all()


@pytest.mark.parametrize("kind", ["measurement", "tare"])
def test_a_point_lossy_through_its_retakes_ends_the_sweep_incomplete_and_resume_records_it(
    simulated_rig, plan, tmp_path, cli, kind, monkeypatch
):
    # fewer retakes than the default, so the messages must name the retakes taken, not the default's count
    retakes = MAX_RETAKES - 1
    monkeypatch.setattr(set_point_recording, "MAX_RETAKES", retakes)
    board = simulated_rig.simulators.daq_board
    target = next(p for p in plan.set_points if p.kind == kind and p.tail_attached)
    # What a resume must record again: the point, the tares that zero it in its run (this plan has no bracketing
    # tares: the one before it), and every measurement a lossy tare zeroes (their zero must come from their run).
    references = zero_references(plan.set_points, {target.index})
    dependents = {
        p.index
        for p in plan.set_points
        if p.kind == "measurement" and target.index in zero_references(plan.set_points, {p.index})
    }
    again_indices = sorted({target.index} | references | dependents)
    measurements = [index for index in again_indices if plan.set_points[index].kind != "tare"]
    assert measurements and len(again_indices) > len(measurements)

    def on_event(event):
        if event.set_point is not None and event.set_point.index == target.index:
            if event.stage == "settled":
                board.drop_periodically(every_samples=1000, drop_samples=5)
            elif event.stage == "recorded":
                board.stop_dropping()

    documents = DocumentDispatcher()
    set_points = []
    documents.subscribe(
        lambda name, document: set_points.append(document) if name == "set_point" else None
    )
    data_root = tmp_path / "data"
    result = run_sweep(plan, simulated_rig, data_root, on_event=on_event, documents=documents)
    assert result.status == "incomplete", result.message
    # The still lossy record's set point document carries the warning the operator sees; no other does.
    warned = [document for document in set_points if document.warnings]
    assert [document.plan_point_index for document in warned] == [target.index]
    (line,) = warned[0].warnings
    assert (
        result.warnings == [line]
        and f"still lost inside the record after {retakes} retakes" in line
    )
    assert exit_code_of(result) == EXIT_INCOMPLETE == 4
    assert result.incomplete_points == [target.index], result.message
    assert result.completed_points == len(plan.set_points) - 1
    assert f"#{target.index} " in result.message and "resume the sweep" in result.message
    assert f"inside its record after {retakes} retakes" in result.message
    tailed = load_recording(result.run_directories[0])
    assert tailed.status == "incomplete"
    assert f"#{target.index} " in tailed.failure_reason
    (kept,) = [r for r in tailed.set_points if r.plan_point_index == target.index]
    assert kept.extra["retakes"] == retakes and kept.samples_missing_in_record >= 5
    tailless = load_recording(result.run_directories[1])
    assert tailless.status == "completed", tailless.failure_reason
    runs = listed_runs(cli, data_root)
    assert runs[tailed.run_id]["exit_status"] == "incomplete"
    assert f"#{target.index} " in runs[tailed.run_id]["failure_reason"]
    assert "incomplete" in sweep_result_record(result)["status"]

    resumed = run_sweep(plan, simulated_rig, data_root, resume=True)
    assert resumed.status == "completed", resumed.message
    assert resumed.completed_points == resumed.total_points == len(plan.set_points)
    new_run = load_recording(resumed.run_directories[-1])
    assert [record.plan_point_index for record in new_run.set_points] == again_indices
    assert all(record.samples_missing_in_record == 0 for record in new_run.set_points)
    assert new_run.metadata["configuration"]["resumed_from_run_id"] == tailless.run_id
    # The chain processes: a measurement recorded again replaces its first record, zeroed by its own run's tare.
    table = cycle_averaged_table(resumed.run_directories)
    assert len(table) == 4
    for measurement in measurements:
        (again,) = table[table["plan_point_index"] == measurement].itertuples()
        assert again.run_id == new_run.run_id and again.tare_id.startswith(new_run.run_id)
    again = run_sweep(plan, simulated_rig, data_root, resume=True)
    assert "nothing to do" in again.message


def test_a_record_whose_start_fell_into_a_counter_gap_is_taken_again(simulated_rig, plan, tmp_path):
    # One host stall that overflowed the board's FIFO over a tare's start. The first row after the gap was
    # sampled a whole gap later than the record's window: under load in stop 43's CI such a gap spanned the next
    # point's start, and a tare's rows held the motor running (processing then found no Hall edge in the
    # measurement that shared them). The window's samples lost before its first row count as missing, so the
    # record is taken again. The gap (12 s of rig time, 2 s of wall time at 6 x) is long enough that the sweep
    # reads where the record begins inside it even on a slow host, and shorter than the 30 s after which a silent
    # stream counts as failed.
    board = simulated_rig.simulators.daq_board
    target = next(p for p in plan.set_points if p.kind == "tare" and p.tail_attached)
    gap_samples = 20 * RECORD_ROWS

    def on_event(event):
        point = event.set_point
        if point is not None and point.index == target.index and event.stage == "settled":
            board.overflow_fifo(gap_samples)

    result = run_sweep(plan, simulated_rig, tmp_path / "data", on_event=on_event)
    assert result.status == "completed", result.message
    tailed = load_recording(result.run_directories[0])
    assert sum(gap.missing_samples for gap in tailed.counter_gaps()) >= gap_samples
    (kept,) = [r for r in tailed.set_points if r.plan_point_index == target.index]
    assert kept.extra["retakes"] == 1 and kept.samples_missing_in_record == 0
    assert kept.last_sample_index - kept.first_sample_index + 1 == RECORD_ROWS


# 20 k frames/s (2 kHz x 10): no link loss on a loaded machine
@pytest.mark.parametrize("simulated_time_scale", [10.0])
def test_a_catalog_locked_through_the_whole_sweep_costs_no_sample_and_catches_up(
    simulated_rig, plan, tmp_path, cli, monkeypatch
):
    monkeypatch.setattr(catalog_sync, "FINAL_WAIT_S", 0.5)
    data_root = tmp_path / "data"
    data_root.mkdir()
    RunCatalog(data_root)
    holder = sqlite3.connect(data_root / CATALOG_FILE_NAME, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")  # held before the sweep starts and until it has ended
    try:
        result = run_sweep(plan, simulated_rig, data_root)
        assert result.status == "completed"
        assert RunCatalog(data_root).find_runs() == []  # nothing could be written
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    journalled = 0
    for directory in result.run_directories:
        recording = load_recording(directory)
        assert recording.status == "completed"
        # the writer never waited on SQLite: its queue never overflowed ...
        assert recording.metadata["queue_overflow"]["lost_samples"] == 0
        # ... and nothing at all was lost
        assert recording.metadata["link_health"]["lost_samples"] == 0
        assert recording.counter_gaps() == []
        journalled += len(recording.set_points)
    assert journalled == len(plan.set_points)
    runs = listed_runs(cli, data_root)  # reconciles from the run directories
    assert sorted(run["exit_status"] for run in runs.values()) == ["completed", "completed"]
    assert sum(run["set_point_count"] for run in runs.values()) == len(plan.set_points)
    assert {run["lost_samples"] for run in runs.values()} == {0}
    assert {entry.run_id for entry in RunCatalog(data_root).find_runs()} == set(runs)


@pytest.mark.parametrize("simulated_time_scale", [10.0])  # an exact count: no link loss from load
def test_lost_samples_are_counted_once_alike_by_runs_the_sweep_report_and_the_gui(
    simulated_rig, plan, tmp_path, cli
):
    from ornitail.gui import status_panel

    board = simulated_rig.simulators.daq_board
    first_tailless = next(p for p in plan.set_points if not p.tail_attached)
    garbage = np.random.default_rng(11).integers(0, 256, 1000, dtype=np.uint8).tobytes()

    def on_event(event):
        # after the tailless run's first point: its recorder has rows, so the gap lies inside its file
        if event.stage == "recorded" and event.set_point.index == first_tailless.index:
            board.drop_samples(25)  # 25 samples never sent
            board.inject_garbage(garbage)  # and 1000 random bytes between two frames

    live = LiveBalance(simulated_rig, sample_rate_hz=plan.sample_rate_hz)  # as the GUI streams it
    data_root = tmp_path / "data"
    try:
        result = run_sweep(plan, simulated_rig, data_root, on_event=on_event, balance_stream=live)
    finally:
        live.stop()
    assert result.status == "completed"
    tailed, tailless = (load_recording(directory) for directory in result.run_directories)
    runs = listed_runs(cli, data_root)
    report = {
        health["run_directory"]: health for health in sweep_result_record(result)["link_health"]
    }
    health = live.health()  # the GUI's status shows the current (here: last) recording
    assert health.recording_run_id == tailless.run_id
    text, warns = status_panel.link_health_text(health)
    assert f"lost samples 25 in {tailless.run_id}" in text and warns
    assert runs[tailless.run_id]["lost_samples"] == 25
    assert report[str(result.run_directories[1])]["samples_lost"] == 25
    assert health.recording_lost_samples == 25
    # The causes are recorded too, but are not added to it: the driver saw the 25 as a counter gap.
    assert runs[tailless.run_id]["link_lost_samples"] == 25
    assert runs[tailed.run_id]["lost_samples"] == 0
    assert report[str(result.run_directories[0])]["samples_lost"] == 0
    table = cli("runs", "--data-root", data_root).stdout.splitlines()
    row = next(line for line in table if line.startswith(tailless.run_id))
    header = table[0].split()
    assert row.split()[header.index("lost")] == "25"

    # The garbage left its trace in the run: run.json, the journal, the catalog, the sweep report.
    link = tailless.metadata["link_health"]
    assert (link["garbage_bytes"], link["resyncs"], link["crc_errors"]) == (1000, 1, 0)
    assert tailless.set_points[-1].link_health["garbage_bytes"] == 1000
    assert (runs[tailless.run_id]["garbage_bytes"], runs[tailless.run_id]["resyncs"]) == (1000, 1)
    assert report[str(result.run_directories[1])]["garbage_bytes"] == 1000
    assert tailed.metadata["link_health"]["garbage_bytes"] == 0
    assert table[table.index(row) + 1].strip() == (
        "link: 1000 garbage bytes in 1 resync(s), 0 foreign CAN frame(s)"
    )
    assert "garbage bytes 1000 in 1 resyncs" in text
