"""`ornitail sweep` killed, signalled and unplugged with the simulated instruments in a process of their own.

The instruments outlive the sweep process as hardware would (``rig_simulator_server``): after a kill -9 the board
is still streaming and the fan and motor still turning. These are small versions of ``benchmarks/crash_harness.py``
(which they reuse): every wait is on observable state (journal lines, process exit, the simulator's state) with
generous deadlines, and nothing is asserted about timing.
"""

from __future__ import annotations

import json
import random
import sys
from pathlib import Path

import crash_harness as harness
import pytest

from ornitail.acquisition.recording_reader import load_recording

REPOSITORY = Path(__file__).resolve().parents[2]
ORNITAIL = str(Path(sys.executable).parent / "ornitail")
DEADLINE_S = 240.0


# One run of three points: a wind-off tare, the steady state, one velocity offset.
PLAN = """
[plan]
name = "crash-test"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[sweeps]
v_m_s = [0.2]
[protocol]
steady_state_repeats = 1
tailless_points = "none"
record_s = 0.5
sample_rate_hz = 1000
[settle]
stable_for_s = 0.3
"""
POINTS = 3
TIME_SCALE = 10.0
"""The instruments' clock: 10 x real time with the board at 1 kHz keeps the pty at 10 k frames/s."""
INSTRUMENT_NAMES = {"fan": "tunnel fan", "motor": "flapping motor", "strut": "strut pitch actuator"}


@pytest.fixture(scope="module")
def plan(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("plan") / "plan.toml"
    path.write_text(PLAN)
    return path


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    running = harness.start_server(tmp_path_factory.mktemp("server"), time_scale=TIME_SCALE)
    yield running
    running.stop()


def error_lines(data_root: Path, name: str = "sweep.err") -> list[str]:
    text = (data_root / name).read_text(errors="replace").replace("\r", "\n")
    assert "Traceback" not in text
    return [line for line in text.splitlines() if line.startswith("ornitail:")]


def test_kill_9_mid_run_leaves_the_board_streaming_and_resume_records_every_point_once(
    server, plan, tmp_path
):
    trial = harness.run_trial(
        server,
        plan,
        tmp_path / "data",
        "kill9",
        after_points=1,
        total_points=POINTS,
        rng=random.Random(1),
        timeout_s=DEADLINE_S,
    )
    assert trial.exit_code == -9
    assert trial.run_statuses == ["crashed"]
    assert (
        trial.board_streaming_before_resume
    )  # the dead host left the board streaming into its port
    assert trial.resume_exit_code == 0 and trial.resume_status == "completed"
    assert trial.exactly_once
    assert all(trial.safe_after_resume.values())
    crashed, resumed = (load_recording(path) for path in harness.run_directories(tmp_path / "data"))
    assert resumed.metadata["configuration"]["resumed_from_run_id"] == crashed.run_id
    for recording in (
        crashed,
        resumed,
    ):  # every journalled point lies in rows that reached the file
        assert all(
            point.last_sample_index < recording.sample_count for point in recording.set_points
        )
    assert (
        trial.loss_samples is not None
    )  # reported by the harness; its size depends on the machine's load


@pytest.mark.parametrize(
    ("kind", "exit_code", "signal_name"), [("sigterm", 143, "SIGTERM"), ("sighup", 129, "SIGHUP")]
)
def test_sigterm_and_sighup_stop_at_once_with_a_stop_record_and_the_rig_safe(
    server, plan, tmp_path, kind, exit_code, signal_name
):
    data_root = tmp_path / "data"
    trial = harness.run_trial(
        server,
        plan,
        data_root,
        kind,
        after_points=2,  # mid-way through the last point: fan and motor turning
        total_points=POINTS,
        rng=random.Random(2),
        timeout_s=DEADLINE_S,
        resume=False,
    )
    assert trial.exit_code == exit_code
    assert trial.run_statuses == ["aborted"]
    assert trial.newest_reason == f"stopped at once by {signal_name}"
    assert not trial.safe_before_signal["motor"]
    assert trial.safe_after_exit == {"fan": True, "motor": True, "strut": True}
    (line,) = error_lines(data_root)
    assert signal_name in line and "safe state" in line
    summary = json.loads((data_root / "sweep.out").read_text())
    assert summary["status"] == "aborted" and summary["completed_points"] == 2


def test_faults_injected_by_the_server_reach_the_sweep_and_a_stalled_motor_fails_it_in_one_line(
    server, plan, tmp_path
):
    data_root = tmp_path / "data"
    process = harness.spawn_sweep(plan, server.rig_file, data_root)
    assert harness.wait_until(lambda: harness.journalled_points(data_root) >= 1, DEADLINE_S)
    server.control.request("garbage", bytes=500)
    server.control.request("crc", count=5)
    server.control.request("stall", instrument="motor", stalled=True)
    try:
        assert process.wait(timeout=DEADLINE_S) == 3
        assert server.control.state()["motor"]["stalled"]
    finally:
        server.control.request("stall", instrument="motor", stalled=False)
    (line,) = error_lines(data_root)
    assert "flapping motor: no reply to " in line and server.ports["motor"] in line
    summary = json.loads((data_root / "sweep.out").read_text())
    (health,) = summary["link_health"]
    assert health["exit_status"] == "failed"
    assert health["crc_errors"] >= 5 and health["garbage_bytes"] >= 500
    assert any(
        "flapping motor" in warning for warning in summary["warnings"]
    )  # its OFF went unanswered
    state = server.control.state()
    assert state["fan"]["safe"] and state["strut"]["safe"]


def test_an_absent_port_at_connect_is_one_line_exit_3_and_a_summary(plan, tmp_path):
    rig = (REPOSITORY / "acquisition" / "data" / "simulated_rig.toml").read_text()
    rig = rig.replace("simulated = true", "simulated = false")
    rig = rig.replace('"/dev/ttyUSB0"', f'"{tmp_path / "ttyABSENT0"}"')
    rig = rig.replace('calibration = "', f'calibration = "{REPOSITORY / "acquisition" / "data"}/')
    rig = rig.replace('table = "', f'table = "{REPOSITORY / "acquisition" / "data"}/')
    (tmp_path / "rig.toml").write_text(rig)
    data_root = tmp_path / "data"
    process = harness.spawn_sweep(plan, tmp_path / "rig.toml", data_root)
    assert process.wait(timeout=DEADLINE_S) == 3
    (line,) = error_lines(data_root)
    assert (
        f"tunnel fan: cannot open port {tmp_path / 'ttyABSENT0'}: No such file or directory" in line
    )
    summary = json.loads((data_root / "sweep.out").read_text())
    assert summary["status"] == "failed" and summary["completed_points"] == 0
    assert "nothing recorded" in summary["message"]


@pytest.mark.parametrize("instrument", ["fan", "motor", "strut"])
def test_an_instrument_unplugged_mid_run_and_at_connect_is_one_line_exit_3_and_the_rest_safe(
    plan, tmp_path, instrument
):
    server = harness.start_server(tmp_path / "server", time_scale=TIME_SCALE)
    try:
        name, port = INSTRUMENT_NAMES[instrument], server.ports[instrument]
        data_root = tmp_path / "data"
        process = harness.spawn_sweep(plan, server.rig_file, data_root)
        assert harness.wait_until(lambda: harness.journalled_points(data_root) >= 1, DEADLINE_S)
        server.control.request("unplug", instrument=instrument)
        assert process.wait(timeout=DEADLINE_S) == 3
        (line,) = error_lines(data_root)
        assert line.startswith(f"ornitail: error: {name}: ") and port in line
        summary = json.loads((data_root / "sweep.out").read_text())
        assert summary["status"] == "failed" and summary["completed_points"] >= 1
        assert [health["exit_status"] for health in summary["link_health"]] == ["failed"]
        state = server.control.state()
        assert all(state[other]["safe"] for other in INSTRUMENT_NAMES if other != instrument)
        # The next sweep finds the instrument still unplugged at connect.
        again = harness.spawn_sweep(plan, server.rig_file, tmp_path / "again")
        assert again.wait(timeout=DEADLINE_S) == 3
        (line,) = error_lines(tmp_path / "again")
        assert f"{name}: cannot open port {port}" in line
        summary = json.loads((tmp_path / "again" / "sweep.out").read_text())
        assert summary["status"] == "failed" and "nothing recorded" in summary["message"]
    finally:
        server.stop()
