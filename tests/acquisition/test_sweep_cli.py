"""The sweep as users run it: the `ornitail sweep` command and the shipped example script, as real processes."""

import json
import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from ornitail.acquisition.recording_reader import load_recording

REPOSITORY = Path(__file__).resolve().parents[2]
ORNITAIL = str(Path(sys.executable).parent / "ornitail")
FAST = "10"
"""Time scale of the sweeps that are not interrupted: the plan's 2 kHz x 10 = 20 k frames/s on the pty (the
interrupted sweep runs at 5 x, so that the second interrupt lands while a point is still being recorded)."""
SHORT_PLAN = """
[plan]
name = "cli-short"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[sweeps]
v_m_s = [-0.2, 0.2]
[protocol]
steady_state_repeats = 2
record_s = 0.6
sample_rate_hz = 2000.0
[settle]
stable_for_s = 0.3
"""


def write_plan(tmp_path, text=SHORT_PLAN):
    path = tmp_path / "plan.toml"
    path.write_text(text)
    tomllib.loads(text)
    return path


def run_ornitail(*arguments, **kwargs):
    return subprocess.run(
        [ORNITAIL, *arguments], capture_output=True, text=True, timeout=240, **kwargs
    )


def test_sweep_command_records_and_prints_one_json_object(tmp_path):
    plan = write_plan(tmp_path)
    completed = run_ornitail(
        "sweep", str(plan), "--data-root", str(tmp_path / "data"), "--time-scale", FAST, "--json"
    )
    assert completed.returncode == 0, completed.stderr
    result = json.loads(completed.stdout)
    assert result["status"] == "completed"
    # stderr is a pipe, not a terminal: progress comes as timestamped lines, the last at the end.
    assert re.search(
        r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ sweep cli-short: 8/8 set points(, .+)?$",
        completed.stderr,
        re.MULTILINE,
    ), completed.stderr
    # Tailed: tare, 2 steady states, 2 velocities; tailless: tare, 2 steady states.
    assert result["completed_points"] == result["total_points"] == 8
    assert len(result["run_directories"]) == 2
    # Link health per run, as the files say it: samples lost by counter gaps, and points recorded again.
    assert [health["run_directory"] for health in result["link_health"]] == result[
        "run_directories"
    ]
    for health in result["link_health"]:
        recording = load_recording(health["run_directory"])
        assert health["samples_lost"] == sum(
            gap.missing_samples for gap in recording.counter_gaps()
        )
        retaken = recording.set_points_frame()["retakes"] > 0
        assert health["set_points_retaken"] == int(retaken.sum())
    listing = json.loads(
        run_ornitail("runs", "--data-root", str(tmp_path / "data"), "--json").stdout
    )
    assert sorted(run["exit_status"] for run in listing["runs"]) == ["completed", "completed"]


def test_plan_outside_limits_is_one_line_and_exit_code_2(tmp_path):
    plan = write_plan(tmp_path, SHORT_PLAN.replace("f_hz = 13.5", "f_hz = 19.0"))
    completed = run_ornitail("sweep", str(plan), "--data-root", str(tmp_path / "data"))
    assert completed.returncode == 2
    lines = completed.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in completed.stderr
    assert "set point(s) outside the rig's limits" in lines[0] and "f = 19.000 Hz" in lines[0]


def test_two_interrupts_stop_at_once_with_the_run_aborted_and_its_data_kept(tmp_path):
    plan = write_plan(tmp_path)
    data_root = tmp_path / "data"
    process = subprocess.Popen(
        [
            ORNITAIL,
            "sweep",
            str(plan),
            "--data-root",
            str(data_root),
            "--time-scale",
            "5",
            "--json",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    runs = data_root / "runs"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(runs.glob("*/journal.jsonl")):
        time.sleep(0.1)  # wait until the first set point is journalled
    process.send_signal(signal.SIGINT)
    time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "finishing the current set point" in stderr and "stopped at once" in stderr
    (run_directory,) = runs.iterdir()
    recording = load_recording(run_directory)
    assert recording.status == "aborted"
    assert len(recording.set_points_frame()) >= 1
    resumed = run_ornitail(
        "sweep",
        str(plan),
        "--data-root",
        str(data_root),
        "--time-scale",
        FAST,
        "--resume",
        "--json",
    )
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads(resumed.stdout)["completed_points"] == 8


def test_example_headless_script_runs_a_sweep(tmp_path):
    plan = write_plan(tmp_path)
    completed = subprocess.run(
        [
            sys.executable,
            str(REPOSITORY / "examples" / "headless_sweep.py"),
            "--plan",
            str(plan),
            "--data-root",
            str(tmp_path / "data"),
            "--time-scale",
            FAST,
        ],
        capture_output=True,
        text=True,
        timeout=240,
        env={**os.environ},
    )
    assert completed.returncode == 0, completed.stderr
    assert "sweep completed: recorded 8 of 8 set points" in completed.stdout
    # Progress lines of the 4 steady-state records, then the 4 rows of the table.
    assert completed.stdout.count("steady_state") == 8


def test_example_headless_script_says_in_one_line_what_stopped_it(tmp_path):
    """A missing plan is exit 2, an absent instrument exit 3, each one line on stderr, no traceback."""
    script = str(REPOSITORY / "examples" / "headless_sweep.py")
    missing_plan = subprocess.run(
        [
            sys.executable,
            script,
            "--plan",
            str(tmp_path / "none.toml"),
            "--data-root",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert missing_plan.returncode == 2
    assert missing_plan.stderr.strip().splitlines() == [
        f"headless_sweep: error: {tmp_path / 'none.toml'}: file not found"
    ]
    rig = tmp_path / "rig.toml"
    rig.write_text(
        (REPOSITORY / "acquisition" / "data" / "simulated_rig.toml")
        .read_text()
        .replace("simulated = true", "simulated = false")
        .replace(
            '"calibration/FT8884.cal"',
            f'"{REPOSITORY / "acquisition/data/calibration/FT8884.cal"}"',
        )
        .replace('"tunnel_table.csv"', f'"{REPOSITORY / "acquisition/data/tunnel_table.csv"}"')
        .replace("/dev/ttyUSB0", str(tmp_path / "no-fan-port"))
    )
    absent = subprocess.run(
        [sys.executable, script, "--rig", str(rig), "--data-root", str(tmp_path / "data")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert absent.returncode == 3, absent.stderr
    (line,) = absent.stderr.strip().splitlines()
    assert (
        line.startswith("headless_sweep: error: tunnel fan: cannot open port")
        and "no-fan-port" in line
    )
