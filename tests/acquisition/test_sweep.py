"""Sweeps on the simulated rig: recording, limits checked first, stop and resume, unplugged instruments.

The sweeps here use a short plan (2 pitches, 1 velocity offset, 0.6 s records) at the plugin's time scale, so a
full tailed + tailless sweep takes a few seconds of wall time.
"""

import math
import threading

import numpy as np
import pytest

from ornitail.acquisition import live_balance, set_point_recording
from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.sweep import SweepStop, completed_plan_points, run_sweep
from ornitail.acquisition.sweep_plan import plan_from_document, zero_references
from ornitail.balance.sweep_table import cycle_averaged_table
from ornitail.core.errors import UserInputError

SHORT_PLAN = {
    "plan": {"name": "short"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "sweeps": {"theta_deg": [3.0], "v_m_s": [0.2]},
    "protocol": {
        "steady_state_repeats": 1,
        "record_s": 0.6,
        "tailless_points": "steady_state",
        "sample_rate_hz": 2000.0,
    },
    "settle": {"stable_for_s": 0.3, "timeout_s": 60},
}
RECORD_ROWS = 1200
"""Rows of one 0.6 s record at the plan's 2 kHz."""


def motor_spins_down(rig, within_rig_s=5.0):
    """True once the motor reads below 0.2 Hz flapping within ``within_rig_s`` of rig time (it coasts down)."""
    for _ in range(int(within_rig_s / 0.1)):
        if rig.read_flapping_frequency_hz() < 0.2:
            return True
        rig.wait_simulated_s(0.1)
    return False


def counting_documents():
    """A dispatcher and a list whose last item is the set points of the plan done, as the run documents say."""
    dispatcher, done = DocumentDispatcher(), [0]
    dispatcher.subscribe(
        lambda name, document: done.append(document.progress.done) if name == "set_point" else None
    )
    return dispatcher, done


def short_plan(**protocol):
    document = {key: dict(value) for key, value in SHORT_PLAN.items()}
    document["protocol"].update(protocol)
    return plan_from_document(document, "short.toml")


@pytest.fixture
def simulated_time_scale():
    # At the plan's 2 kHz x 10 the pty carries 20 k frames/s, which two busy cores sustain (10 kHz x 5, 50 k
    # frames/s, was the most they did).
    return 10.0


def test_sweep_records_every_point_in_two_runs_with_tares(simulated_rig, tmp_path):
    plan = short_plan()
    result = run_sweep(plan, simulated_rig, tmp_path)
    assert result.status == "completed"
    assert result.completed_points == result.total_points == len(plan.set_points) == 7
    assert len(result.run_directories) == 2
    tailed, tailless = (load_recording(directory) for directory in result.run_directories)
    assert tailed.status == tailless.status == "completed"
    assert tailless.metadata["configuration"]["resumed_from_run_id"] == tailed.run_id
    journal_indices = sorted(
        int(i)
        for recording in (tailed, tailless)
        for i in recording.set_points_frame()["plan_point_index"]
    )
    assert journal_indices == list(range(7))
    frame = tailed.set_points_frame()
    rows = frame["last_sample_index"] - frame["first_sample_index"] + 1
    assert (rows == RECORD_ROWS).all()
    # What processing needs from the rig travels with the run.
    assert tailed.metadata["rig"]["gear_ratio"] == 21.33
    # The stream never pauses: no counter gaps, nothing lost, on the simulated link.
    assert tailed.counter_gaps() == []
    # The rig reached each set point: pitch and velocity read during the record within the settle tolerances. The
    # readings come one per 0.1 s of rig time plus the round trip of two serial queries, which at 10x real time
    # costs a few hundredths of a second of rig time (a busy host: a tenth), so a 0.6 s record holds 3-6 of them:
    # at least two make a mean.
    for _, row in frame.iterrows():
        assert row["condition_readings"] >= 2
        assert abs(row["pitch_mean_rad"] - row["pitch_rad"]) <= math.radians(0.2)
        assert abs(row["tunnel_velocity_mean_m_s"] - row["tunnel_velocity_m_s"]) <= 0.02
    # The motor's starts and stops are journalled where they were read: it starts for each measurement after a
    # tare and stops (spinning down) before each tare's record ends.
    transitions = [
        (row["kind"], [kind for kind, _ in row["motor_transitions"]]) for _, row in frame.iterrows()
    ]
    for (kind, _), (next_kind, next_changes) in zip(transitions[:-1], transitions[1:], strict=True):
        if kind == "tare" and next_kind == "measurement":
            assert next_changes == ["started"], transitions
        if kind == "measurement" and next_kind == "tare":
            assert next_changes == ["stopped"], transitions
    # Motor and fan were left off.
    assert motor_spins_down(simulated_rig)
    assert simulated_rig.read_tunnel_velocity_m_s() < 0.8
    table = cycle_averaged_table(result.run_directories)
    assert len(table) == 4  # 2 tailed sweep points + 1 tailed and 1 tailless steady state
    # A 0.6 s record at 13.5 Hz holds 8 flap periods; at least 6 whole accepted cycles are expected.
    assert (table["cycles"] >= 6).all()
    np.testing.assert_allclose(table["f_hall_hz"], 13.5, atol=0.1)
    catalog_runs = RunCatalog(tmp_path).find_runs()
    assert sorted(run.exit_status for run in catalog_runs) == ["completed", "completed"]


def test_plan_outside_limits_is_refused_before_anything_moves(simulated_rig, tmp_path):
    plan = short_plan()
    document = {key: dict(value) for key, value in SHORT_PLAN.items()}
    document["sweeps"] = {
        "theta_deg": [30.0],
        "f_hz": [3.0],
    }  # 55 deg > 45 deg limit; 16.5 Hz > 16 Hz limit
    plan = plan_from_document(document, "short.toml")
    pitch_before = simulated_rig.read_pitch_rad()
    with pytest.raises(UserInputError) as raised:
        run_sweep(plan, simulated_rig, tmp_path)
    message = str(raised.value)
    assert (
        "3 set point(s) outside the rig's limits" in message
    )  # tare + point at 55 deg, 16.5 Hz point
    assert "theta = 55.000 deg" in message and "f = 16.500 Hz" in message
    assert simulated_rig.read_pitch_rad() == pytest.approx(pitch_before, abs=1e-9)
    assert not (tmp_path / "runs").exists()


def test_stop_request_finishes_the_point_and_resume_completes_the_rest(simulated_rig, tmp_path):
    plan = short_plan()
    stop = SweepStop()
    seen = []

    def on_event(event):
        seen.append(event.stage)
        if event.stage == "recorded" and seen.count("recorded") == 2:
            stop.request()

    first = run_sweep(plan, simulated_rig, tmp_path, stop=stop, on_event=on_event)
    assert first.status == "aborted"
    aborted = load_recording(first.run_directories[0])
    assert aborted.status == "aborted"
    assert list(aborted.set_points_frame()["plan_point_index"]) == [0, 1]
    # Whole records count (on a loaded machine a record may stay lossy through its retakes; the resume takes it).
    done = completed_plan_points(first.run_directories, plan)
    assert first.completed_points == len(done) and done <= {0, 1}
    resumed = run_sweep(plan, simulated_rig, tmp_path, resume=True)
    assert resumed.status == "completed"
    assert resumed.completed_points == 7
    new_runs = resumed.run_directories[1:]
    resumed_indices = sorted(
        int(i)
        for directory in new_runs
        for i in load_recording(directory).set_points_frame()["plan_point_index"]
    )
    # The points not recorded, and again the tares that zero them: each point's zero comes from its own run.
    missing = set(range(7)) - done
    references = zero_references(plan.set_points, missing)
    assert references and all(plan.set_points[index].kind == "tare" for index in references)
    assert resumed_indices == sorted(missing | references)
    table = cycle_averaged_table(resumed.run_directories)
    assert len(table) == 4
    resumed_runs = {load_recording(directory).run_id for directory in new_runs}
    for point in table[table["plan_point_index"] >= 2].itertuples():
        assert point.tare_id.split("#")[0] == point.run_id and point.run_id in resumed_runs
    again = run_sweep(plan, simulated_rig, tmp_path, resume=True)
    assert again.completed_points == 7 and "nothing to do" in again.message


def test_abort_drops_the_point_in_progress_and_leaves_the_rig_safe(simulated_rig, tmp_path):
    plan = short_plan()
    stop = SweepStop()
    documents, done = counting_documents()

    def on_event(event):  # abort while the third point settles: it is never journalled
        if event.stage == "moving" and done[-1] == 2:
            stop.abort()

    result = run_sweep(
        plan, simulated_rig, tmp_path, stop=stop, on_event=on_event, documents=documents
    )
    assert (result.status, result.completed_points) == ("aborted", 2)
    assert "aborted by the operator" in result.message
    run = load_recording(result.run_directories[0])
    assert run.status == "aborted"
    assert sorted(int(i) for i in run.set_points_frame()["plan_point_index"]) == [0, 1]
    assert simulated_rig.fan.read_target_rpm() == 0.0
    assert motor_spins_down(simulated_rig)


def test_unplugged_fan_fails_the_run_naming_it_and_keeps_what_was_recorded(simulated_rig, tmp_path):
    plan = short_plan()

    documents, done = counting_documents()

    def on_event(event):
        if event.stage == "recorded" and done[-1] == 2:
            threading.Timer(0.05, simulated_rig.simulators.fan.unplug).start()

    result = run_sweep(plan, simulated_rig, tmp_path, on_event=on_event, documents=documents)
    assert result.status == "failed"
    assert "fan" in result.message.lower()
    recording = load_recording(result.run_directories[0])
    assert recording.status == "failed"
    assert len(recording.set_points_frame()) == 2
    assert recording.sample_count >= 2 * RECORD_ROWS
    # Motor was still brought to rest although the fan is gone.
    assert motor_spins_down(simulated_rig)
    with pytest.raises(InstrumentError):
        simulated_rig.fan.read_rpm()
    simulated_rig.close(
        raise_errors=False
    )  # the fan is gone; the fixture's own close would report it again


def drops_after_the_first_point_settles(rig, kind="tare"):
    """An ``on_event`` that makes the board drop 25 samples every 0.1 s of rig time for 1.5 s of rig time once the
    first point of ``kind`` settles, and an event set when the drops are over. The end is read on the rig's clock,
    so a thread slowed by a busy host drops less often but never for longer."""
    board = rig.simulators.daq_board
    dropping_over = threading.Event()

    def drop_for_a_while():
        end_s = rig.now_s() + 1.5
        while rig.now_s() < end_s:
            board.drop_samples(25)
            rig.wait_simulated_s(0.1)
        dropping_over.set()

    started = threading.Event()

    def on_event(event):
        if event.stage == "settled" and event.set_point.kind == kind and not started.is_set():
            started.set()
            threading.Thread(target=drop_for_a_while, daemon=True).start()

    return on_event, dropping_over


def test_a_record_that_loses_samples_is_taken_again_and_the_kept_one_is_whole(
    simulated_rig, tmp_path
):
    """The board drops samples (an overloaded link) every 0.1 s of rig time for 1.5 s after the first point (a
    wind-off tare) settles: the first 0.6 s record is bound to contain a gap, so the point is recorded again
    until a record without one is kept (at most MAX_RETAKES = 3 times; the drops stop before the third)."""
    plan = short_plan()
    on_event, dropping = drops_after_the_first_point_settles(simulated_rig)
    result = run_sweep(plan, simulated_rig, tmp_path, on_event=on_event)
    assert result.status == "completed"
    assert dropping.wait(timeout=30)
    tailed = load_recording(result.run_directories[0])
    gaps = tailed.counter_gaps()
    assert sum(gap.missing_samples for gap in gaps) >= 25  # samples were really lost on the link
    frame = tailed.set_points_frame()
    first_point = frame.iloc[0]
    assert first_point["retakes"] >= 1
    assert (frame["samples_missing_in_record"] == 0).all()
    # No kept record spans a gap: every gap lies outside every point's rows.
    for gap in gaps:
        inside = (frame["first_sample_index"] < gap.row_index) & (
            gap.row_index <= frame["last_sample_index"]
        )
        assert not inside.any()
    measurements = [point for point in plan.set_points if point.kind == "measurement"]
    assert len(cycle_averaged_table(result.run_directories)) == len(measurements)


def test_unplugged_balance_fails_the_run_naming_it_and_keeps_what_was_recorded(
    simulated_rig, tmp_path
):
    plan = short_plan()

    documents, done = counting_documents()

    def on_event(event):
        if event.stage == "recorded" and done[-1] == 2:
            threading.Timer(0.05, simulated_rig.simulators.daq_board.unplug).start()

    result = run_sweep(plan, simulated_rig, tmp_path, on_event=on_event, documents=documents)
    assert result.status == "failed"
    assert simulated_rig.balance.name in result.message and "failed" in result.message
    recording = load_recording(result.run_directories[0])
    assert recording.status == "failed"
    assert len(recording.set_points_frame()) == 2
    assert recording.sample_count >= 2 * RECORD_ROWS
    assert motor_spins_down(simulated_rig)
    simulated_rig.close(
        raise_errors=False
    )  # the balance is gone; the fixture's close would report it again


def test_a_balance_that_goes_silent_fails_the_run_naming_it_instead_of_waiting_for_ever(
    simulated_rig, tmp_path, monkeypatch
):
    """The board's firmware hangs after two points: its port stays open, nothing more arrives. The next record
    gives up after ROWS_STALLED_S of rig time without a row (3 s here, 0.15 s of wall time at the fixture's time
    scale of 20), the run fails naming the balance, keeps what was recorded and leaves the motor spinning down.
    Without the deadline the sweep waits for its rows until pytest's timeout."""
    monkeypatch.setattr(set_point_recording, "ROWS_STALLED_S", 3.0)
    documents, done = counting_documents()

    def on_event(event):
        if event.stage == "recorded" and done[-1] == 2:
            simulated_rig.simulators.daq_board.freeze()

    result = run_sweep(
        short_plan(), simulated_rig, tmp_path, on_event=on_event, documents=documents
    )
    assert result.status == "failed"
    assert simulated_rig.balance.name in result.message and "no samples arrived" in result.message
    recording = load_recording(result.run_directories[0])
    assert recording.status == "failed"
    assert len(recording.set_points_frame()) == 2
    assert motor_spins_down(simulated_rig)
    simulated_rig.close(
        raise_errors=False
    )  # the board no longer answers; closing it would report that again


def test_records_longer_than_the_remembered_blocks_are_checked_whole(
    simulated_rig, tmp_path, monkeypatch
):
    """Where a point begins is found among the last few blocks, but its gaps are known for the whole record: with
    only 5 blocks remembered (about 0.05 s), 0.6 s records still complete, whole and checked."""
    monkeypatch.setattr(live_balance, "RECENT_BLOCKS_KEPT", 5)
    result = run_sweep(short_plan(), simulated_rig, tmp_path)
    assert result.status == "completed"
    frame = load_recording(result.run_directories[0]).set_points_frame()
    assert (frame["last_sample_index"] - frame["first_sample_index"] + 1 == RECORD_ROWS).all()
    assert (frame["samples_missing_in_record"] == 0).all()


def test_a_record_kept_with_a_gap_is_journalled_and_refused_by_processing(
    simulated_rig, tmp_path, monkeypatch
):
    """With no retakes allowed the first measurement keeps its gap: the journal says how many samples it lost, the
    sweep ends incomplete naming it, and processing names the run and the set point instead of timing cycles
    across the gap."""
    monkeypatch.setattr(set_point_recording, "MAX_RETAKES", 0)
    on_event, dropping = drops_after_the_first_point_settles(simulated_rig, kind="measurement")
    result = run_sweep(short_plan(), simulated_rig, tmp_path, on_event=on_event)
    assert result.status == "incomplete" and dropping.wait(timeout=30)
    tailed = result.run_directories[0]
    frame = load_recording(tailed).set_points_frame()
    first_measurement = frame[frame["kind"] == "measurement"].iloc[0]
    assert (
        first_measurement["retakes"] == 0 and first_measurement["samples_missing_in_record"] >= 25
    )
    assert int(first_measurement["plan_point_index"]) in result.incomplete_points
    with pytest.raises(UserInputError, match="samples lost inside the record") as refused:
        cycle_averaged_table(result.run_directories)
    assert str(tailed) in str(refused.value)
