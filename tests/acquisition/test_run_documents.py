"""Run documents: the dispatcher, a recorder's run framed by start and stop, a run the engine opens (documents
and catalog row), a plan the engine runs step by step, the CLI's progress and warnings taken from them, and the
documents of sweeps on the simulated rig (completed, aborted, failed), with a subscriber that raises on every
document."""

import io
import json
from contextlib import contextmanager

import numpy as np
import pytest

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    RUN_METADATA_FILE_NAME,
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.recording_plan import (
    ChangeTail,
    MoveAndSettle,
    RecordSetPoint,
    StartRun,
    StopRun,
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_documents import (
    DocumentDispatcher,
    PlanProgress,
    RunStart,
    RunStop,
    SetPointDocument,
    documented_run,
)
from ornitail.acquisition.run_engine import open_run, run_plan
from ornitail.acquisition.sweep import SweepStop, run_sweep
from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.app.progress import Progress
from ornitail.app.sweep_session import ProgressFromDocuments

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


@pytest.fixture
def simulated_time_scale():
    # As tests/acquisition/test_sweep.py: the plan's 2 kHz x 10, 20 k frames/s on the pty. At 10 kHz x 5 (50 k
    # frames/s) a loaded host lost samples in a record after every retake and the sweep ended incomplete (stop 43).
    return 10.0


def failing(name, document):
    raise RuntimeError(f"subscriber broken on {name}")


def collecting_dispatcher():
    """A dispatcher whose first subscriber always raises and whose second keeps every (name, document)."""
    dispatcher = DocumentDispatcher()
    received = []
    dispatcher.subscribe(failing)
    dispatcher.subscribe(lambda name, document: received.append((name, document)))
    return dispatcher, received


def runs_of(received):
    """The documents split per run, in the order received: one list of (name, document) per start."""
    runs = []
    for name, document in received:
        if name == "start":
            runs.append([])
        runs[-1].append((name, document))
    return runs


def assert_framed_run(documents, directory):
    """start, one set point document per journalled set point (in journal order), stop as in run.json."""
    names = [name for name, _ in documents]
    assert names == ["start"] + ["set_point"] * (len(names) - 2) + ["stop"]
    start, stop = documents[0][1], documents[-1][1]
    recording = load_recording(directory)
    assert isinstance(start, RunStart) and isinstance(stop, RunStop)
    assert start.run_id == stop.run_id == recording.run_id
    assert start.run_directory == str(directory)
    assert stop.exit_status == recording.status
    set_points = [document for _, document in documents[1:-1]]
    assert all(isinstance(document, SetPointDocument) for document in set_points)
    assert [document.sequence for document in set_points] == list(range(1, len(set_points) + 1))
    journal = recording.set_points_frame()
    assert [document.plan_point_index for document in set_points] == [
        int(index) for index in journal["plan_point_index"]
    ]
    assert [document.first_sample_index for document in set_points] == [
        int(index) for index in journal["first_sample_index"]
    ]
    assert stop.set_points_recorded == len(set_points)
    return start, set_points, stop


def test_a_raising_subscriber_is_counted_and_the_others_still_receive():
    dispatcher, received = collecting_dispatcher()
    stop = RunStop("r", "completed", None, 0, "2026-01-01T00:00:00+00:00")
    dispatcher.emit("stop", stop)
    assert received == [("stop", stop)]
    assert dispatcher.subscriber_failures == 1


def test_an_unsubscribed_subscriber_receives_nothing_more():
    dispatcher = DocumentDispatcher()
    received = []
    token = dispatcher.subscribe(lambda name, document: received.append(name))
    stop = RunStop("r", "completed", None, 0, "2026-01-01T00:00:00+00:00")
    dispatcher.emit("stop", stop)
    dispatcher.unsubscribe(token)
    dispatcher.unsubscribe(token)
    dispatcher.emit("stop", stop)
    assert received == ["stop"]


@pytest.mark.parametrize(
    ("error", "status"),
    [(RuntimeError("disk on fire"), "failed"), (KeyboardInterrupt(), "aborted")],
)
def test_a_run_that_raises_still_emits_its_stop_document(tmp_path, error, status):
    dispatcher, received = collecting_dispatcher()
    recorder = Recorder(
        tmp_path,
        RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="manual"),
        StreamLayout([ChannelSpec("gauge_0", "V")], sample_rate_hz=1000.0),
    )
    with pytest.raises(type(error)), documented_run(recorder, dispatcher, set_points_planned=1):
        raise error
    assert [name for name, _ in received] == ["start", "stop"]
    stop = received[-1][1]
    assert stop.exit_status == status == load_recording(recorder.run_directory).status
    assert stop.set_points_recorded == 0


def test_a_run_the_engine_opens_carries_its_metadata_and_keeps_its_catalog_row_when_it_fails(
    tmp_path,
):
    dispatcher, received = collecting_dispatcher()
    recorder = Recorder(
        tmp_path,
        RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="manual"),
        StreamLayout([ChannelSpec("gauge_0", "V")], sample_rate_hz=1000.0),
        rig_description={"balance": "simulated"},
    )
    with (
        pytest.raises(RuntimeError),
        open_run(recorder, dispatcher, set_points_planned=2) as run,
    ):
        recorder.put_block(np.arange(100), np.zeros((100, 1)))
        record = SetPointRecord(0, "tare", 0, 99, 0.26, 0.0, 0.0, True)
        recorder.complete_set_point(record)
        run.documents.set_point(record)
        raise RuntimeError("disk on fire")
    start, set_point, stop = (document for _, document in received)
    assert (start.plan_name, start.rig, start.set_points_planned) == (
        "manual",
        {"balance": "simulated"},
        2,
    )
    assert start.run_metadata["exit_status"] == "running"
    assert (set_point.kind, stop.exit_status, stop.reason) == (
        "tare",
        "failed",
        "RuntimeError: disk on fire",
    )
    run_json = json.loads((recorder.run_directory / RUN_METADATA_FILE_NAME).read_text())
    assert stop.run_metadata == run_json and run_json["set_point_count"] == 1
    assert run.catalog.synced is True and run.catalog.errors == []
    entry = RunCatalog(tmp_path).get_run(recorder.run_id)
    assert (entry.exit_status, entry.set_point_count) == ("failed", 1)


class FakePerformer:
    """A plan performer without a rig: notes each call; its record writes 100 rows and journals them."""

    def __init__(self, data_root, fail_on_move=False):
        self.data_root, self.fail_on_move, self.calls = data_root, fail_on_move, []

    def change_tail(self, tail_attached):
        self.calls.append(("change_tail", tail_attached))

    def recorder(self, step):
        self.calls.append(("recorder", step.tailed))
        return Recorder(
            self.data_root,
            RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=step.tailed, plan_name="fake"),
            StreamLayout([ChannelSpec("gauge_0", "V")], sample_rate_hz=1000.0),
        )

    def progress(self):
        return PlanProgress(0, 1, 10.0)

    @contextmanager
    def recording_into(self, run):
        self.calls.append(("recording_into", run.recorder.run_id))
        yield
        self.calls.append(("recorded_into", run.recorder.run_id))

    def move_and_settle(self, point):
        self.calls.append(("move_and_settle", point.index))
        if self.fail_on_move:
            raise RuntimeError("strut jammed")
        return 1.5

    def record(self, run, point, settle_s):
        self.calls.append(("record", point.index, settle_s))
        run.recorder.put_block(np.arange(100), np.zeros((100, 1)))
        record = SetPointRecord(point.index, point.kind, 0, 99, point.pitch_rad, 0.0, 0.0, True)
        run.recorder.complete_set_point(record)
        run.documents.set_point(record, PlanProgress(1, 1, 0.0))

    def run_stopped(self):
        self.calls.append(("run_stopped",))


def test_the_engine_runs_a_plan_step_by_step_opening_and_closing_its_run(tmp_path):
    point = plan_from_document(SHORT_PLAN, "short.toml").set_points[0]
    dispatcher, received = collecting_dispatcher()
    performer = FakePerformer(tmp_path)
    steps = (
        ChangeTail(True),
        StartRun(True, 1),
        MoveAndSettle(point),
        RecordSetPoint(point),
        StopRun(),
    )
    run_plan(steps, performer, dispatcher)
    (documents,) = runs_of(received)
    start, (set_point,), stop = assert_framed_run(
        documents, tmp_path / "runs" / received[0][1].run_id
    )
    run_id = start.run_id
    assert performer.calls == [
        ("change_tail", True),
        ("recorder", True),
        ("recording_into", run_id),
        ("move_and_settle", point.index),
        ("record", point.index, 1.5),
        ("recorded_into", run_id),
        ("run_stopped",),
    ]
    assert (start.set_points_planned, start.progress) == (1, PlanProgress(0, 1, 10.0))
    assert set_point.progress == PlanProgress(1, 1, 0.0) and stop.exit_status == "completed"


def test_a_plan_that_fails_mid_run_closes_its_run_as_failed(tmp_path):
    point = plan_from_document(SHORT_PLAN, "short.toml").set_points[0]
    dispatcher, received = collecting_dispatcher()
    performer = FakePerformer(tmp_path, fail_on_move=True)
    steps = (StartRun(True, 1), MoveAndSettle(point), RecordSetPoint(point), StopRun())
    with pytest.raises(RuntimeError, match="strut jammed"):
        run_plan(steps, performer, dispatcher)
    assert [name for name, _ in received] == ["start", "stop"]
    stop = received[-1][1]
    assert (stop.exit_status, stop.reason) == ("failed", "RuntimeError: strut jammed")
    assert ("record", point.index, 1.5) not in performer.calls
    assert ("run_stopped",) not in performer.calls


def test_a_completed_sweep_emits_start_set_points_and_stop_per_run_despite_a_raising_subscriber(
    simulated_rig, tmp_path
):
    plan = plan_from_document(SHORT_PLAN, "short.toml")
    dispatcher, received = collecting_dispatcher()
    result = run_sweep(plan, simulated_rig, tmp_path, documents=dispatcher)
    assert result.status == "completed"
    runs = runs_of(received)
    assert len(runs) == len(result.run_directories) == 2
    for documents, directory in zip(runs, result.run_directories, strict=True):
        start, _, stop = assert_framed_run(documents, directory)
        assert stop.exit_status == "completed" and stop.reason is None
        assert start.plan_name == "short"
    tailed, tailless = (documents[0][1] for documents in runs)
    assert tailed.configuration["tailed"] and not tailless.configuration["tailed"]
    assert tailless.configuration["resumed_from_run_id"] == tailed.run_id
    assert tailed.set_points_planned + tailless.set_points_planned == len(plan.set_points)
    assert sum(len(documents) - 2 for documents in runs) == len(plan.set_points)
    assert dispatcher.subscriber_failures == len(received)
    # Each start and set point document says where the sweep stands: points of the chain done, time left.
    assert (tailed.progress.done, tailless.progress.done) == (0, tailed.set_points_planned)
    set_points = [document for name, document in received if name == "set_point"]
    assert [document.progress.done for document in set_points] == list(
        range(1, len(plan.set_points) + 1)
    )
    assert {document.progress.total for document in set_points} == {len(plan.set_points)}
    assert all(document.progress.eta_s > 0 for document in set_points[:-1])
    assert set_points[-1].progress.eta_s == 0.0
    assert all(document.warnings == () for document in set_points)  # every record clean


def test_the_cli_takes_progress_and_warnings_from_the_documents():
    stream = io.StringIO()
    progress = Progress("sweep short", 4, "set points", stream=stream, clock=lambda: 0.0)
    from_documents = ProgressFromDocuments(progress)
    record = SetPointRecord(
        2,
        "measurement",
        100,
        1299,
        0.44,
        0.8,
        13.5,
        True,
        saturated_samples=1200,
        over_range_samples=1200,
    )
    line = "warning: set point #2 (measurement): 1200 of 1200 samples saturated"
    from_documents(
        "set_point",
        SetPointDocument.of_record(
            "r", 1, record, "2026-01-01T00:00:00+00:00", {}, PlanProgress(3, 4, 12.0), [line]
        ),
    )
    assert (progress.done, from_documents.eta_s) == (3, 12.0)
    assert stream.getvalue().splitlines() == [line]
    from_documents.point_under_way("#3 (measurement)")  # the count stays the documents'
    assert progress.done == 3


def test_an_aborted_sweep_ends_its_run_with_an_aborted_stop_document(simulated_rig, tmp_path):
    plan = plan_from_document(SHORT_PLAN, "short.toml")
    stop = SweepStop()
    dispatcher, received = collecting_dispatcher()

    def stop_after_two(name, document):  # the first Ctrl-C, as the second point is journalled
        if name == "set_point" and document.sequence == 2:
            stop.request()

    dispatcher.subscribe(stop_after_two)
    result = run_sweep(plan, simulated_rig, tmp_path, stop=stop, documents=dispatcher)
    assert result.status == "aborted"
    (documents,) = runs_of(received)
    _, set_points, stop_document = assert_framed_run(documents, result.run_directories[0])
    assert len(set_points) == 2
    assert stop_document.exit_status == "aborted"
    assert "stopped by the operator" in stop_document.reason


def test_a_failed_sweep_ends_its_run_with_a_failed_stop_document(simulated_rig, tmp_path):
    plan = plan_from_document(SHORT_PLAN, "short.toml")
    dispatcher, received = collecting_dispatcher()

    def unplug_the_fan(name, document):
        if name == "set_point" and document.sequence == 2:
            simulated_rig.simulators.fan.unplug()

    dispatcher.subscribe(unplug_the_fan)
    result = run_sweep(plan, simulated_rig, tmp_path, documents=dispatcher)
    assert result.status == "failed"
    (documents,) = runs_of(received)
    _, set_points, stop_document = assert_framed_run(documents, result.run_directories[0])
    assert len(set_points) == 2
    assert stop_document.exit_status == "failed" and "fan" in stop_document.reason.lower()
    simulated_rig.close(
        raise_errors=False
    )  # the fan is gone; the fixture's close would report it again
