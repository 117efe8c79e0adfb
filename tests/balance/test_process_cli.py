"""``ornitail process`` end to end: a short sweep recorded on the simulated rig, processed by the command."""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from ornitail.acquisition.sweep import run_sweep_to_completion
from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.app.cli import main

SHORT_PLAN = {
    "plan": {"name": "short-process"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "sweeps": {"theta_deg": [3.0], "v_m_s": [0.2], "f_hz": [1.0]},
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
    # As in tests/acquisition/test_sweep.py: the plan's 2 kHz x 10, 20 k frames/s on the pty.
    return 10.0


@pytest.fixture
def cli():
    """The ``ornitail`` group, run in-process."""
    return lambda *arguments: CliRunner().invoke(main, [str(argument) for argument in arguments])


@pytest.fixture
def recorded_sweep(simulated_rig, tmp_path):
    data_root = tmp_path / "data"
    data_root.mkdir()
    # resumed where a busy host lost samples through a record's retakes
    result = run_sweep_to_completion(
        plan_from_document(SHORT_PLAN, "short.toml"), simulated_rig, data_root
    )
    assert result.status == "completed"
    return data_root, result.run_directories


def test_process_writes_tables_figures_and_one_json_object(recorded_sweep, cli, tmp_path):
    data_root, runs = recorded_sweep
    out = tmp_path / "out"
    result = cli("process", *runs, "--out", out, "--json")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)  # exactly one JSON object
    # stderr is not a terminal here: progress comes as timestamped lines, not a bar.
    assert re.search(
        r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ process: 5/5 set points$", result.stderr, re.MULTILINE
    ), result.stderr
    assert record["runs"] == [str(path) for path in runs]
    table = pd.read_csv(out / "cycle-averages.csv")
    assert len(table) == 5  # tailed: steady state + 3 one-point sweeps; tailless: steady state
    # The simulated motor's rpm and the Hall line agree within the 2 % cross-check tolerance (the rpm is one
    # reading at the end of the point, the Hall frequency a mean over 8 cycles of a 0.2 % wandering speed).
    assert not table["f_disagrees"].any(), table[["f_hall_hz", "f_motor_hz"]]
    assert table["f_motor_hz"].notna().all()
    (configuration,) = record["configurations"]
    derivatives = configuration["derivatives"]["derivatives"]
    for name in ("Xu", "Xw", "Xf", "Zu", "Zw", "Zf", "Mu", "Mw", "Mf"):
        assert derivatives[name]["sigma"] > 0
    assert derivatives["Mq"]["value"] is None  # not measurable clamped
    assert derivatives["Zf"]["value"] < 0  # faster flapping: more thrust along -z_b
    assert configuration["tail_contribution"][0]["x_n"] > 0  # the tail adds drag along +x_b
    # This plan takes one tare per pitch: the drift after it is not corrected, and the output says so.
    assert configuration["drift_statement"].startswith(
        "Balance drift NOT corrected for 5 of 5 points"
    )
    written = [Path(path) for path in record["written"]]
    suffixes = sorted(path.suffix for path in written)
    assert suffixes.count(".png") == suffixes.count(".pdf") == 3
    assert {".csv", ".json"} <= set(suffixes)
    assert all(path.is_file() and path.stat().st_size > 0 for path in written)
    saved = json.loads((out / "S3-xh98mm-derivatives.json").read_text())
    assert saved["derivatives"]["Zf"]["value"] == pytest.approx(derivatives["Zf"]["value"])
    derivative_table = pd.read_csv(out / "S3-xh98mm-derivatives.csv")
    assert {"name", "value", "sigma", "unit", "configuration"} <= set(derivative_table.columns)
    phase_table = pd.read_csv(out / "S3-xh98mm-phase-average.csv")
    assert set(phase_table["tailed"]) == {True, False}
    assert {"phase", "cycles", "f_hall_hz", "x_n", "x_n_std", "m_n_m", "m_n_m_std"} <= set(
        phase_table.columns
    )
    assert phase_table["phase"].between(0, 1).all() and phase_table["x_n_std"].gt(0).all()

    by_plan = cli(
        "process",
        "--plan",
        "short-process",
        "--data-root",
        data_root,
        "--out",
        tmp_path / "o2",
        "--json",
    )
    assert by_plan.exit_code == 0, by_plan.stderr
    assert json.loads(by_plan.stdout)["runs"] == [str(path) for path in runs]

    # Bad input, each one line and exit code 2.
    not_a_recording = tmp_path / "empty"
    not_a_recording.mkdir()
    without_tares = shutil.copytree(runs[0], tmp_path / "no-tares")
    journal = without_tares / "journal.jsonl"
    kept = [line for line in journal.read_text().splitlines() if '"kind": "tare"' not in line]
    journal.write_text("\n".join(kept) + "\n")
    missing_calibration = shutil.copytree(runs[0], tmp_path / "no-cal")
    # Neither the run folder's copy of the calibration file nor the original is there.
    shutil.rmtree(missing_calibration / "calibration")
    metadata = json.loads((missing_calibration / "run.json").read_text())
    metadata["calibration_files"]["balance"]["path"] = str(tmp_path / "gone.cal")
    (missing_calibration / "run.json").write_text(json.dumps(metadata))
    cases = [
        ((), "no run directories given"),
        ((not_a_recording,), "run.json"),
        ((without_tares,), "no wind-off tare"),
        ((missing_calibration,), "gone.cal"),
        (("--plan", "no-such-plan", "--data-root", data_root), "no runs of plan"),
    ]
    for arguments, message in cases:
        failed = cli("process", *arguments, "--out", tmp_path / "bad")
        assert failed.exit_code == 2, (arguments, failed.output)
        assert message in failed.stderr and len(failed.stderr.strip().splitlines()) == 1

    # Once through a real process, with the console script.
    console_script = Path(sys.executable).parent / "ornitail"
    completed = subprocess.run(
        [str(console_script), "process", "--plan", "short-process", "--data-root", str(data_root),
         "--out", str(tmp_path / "o3"), "--json"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert completed.returncode == 0, completed.stderr
    assert json.loads(completed.stdout)["table_csv"] == str(tmp_path / "o3" / "cycle-averages.csv")
