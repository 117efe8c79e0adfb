"""Runs copied to another machine still process: calibration files travel in the run folder, found by content hash.

One short sweep is recorded on the simulated rig with a rig file whose calibration file and tunnel table live in a
temporary "lab" folder; each test copies the run folders elsewhere and hides files before processing them.
"""

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from ornitail.acquisition.calibration_copies import calibration_copy_names
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.acquisition.sweep import run_sweep
from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.app.cli import main
from ornitail.app.progress import PROGRESS_LINE

PLAN = {
    "plan": {"name": "portable"},
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
TIME_SCALE = 10.0
"""As in tests/acquisition/test_sweep.py: the plan's 2 kHz x 10, 20 k frames/s on the pty."""


def process(*arguments):
    """``ornitail process ... --json`` in-process."""
    return CliRunner().invoke(main, ["process", *map(str, arguments), "--json"])


def _messages(stderr: str) -> list[str]:
    """stderr's lines without the progress lines (stderr is not a terminal here)."""
    return [line for line in stderr.splitlines() if not PROGRESS_LINE.match(line)]


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """``(lab folder, run directories, reference cycle-averages table)`` of one sweep processed where it was
    recorded."""
    lab = tmp_path_factory.mktemp("lab")
    shutil.copy(DEFAULT_RIG_FILE, lab / "rig.toml")
    (lab / "calibration").mkdir()
    for name in ("calibration/FT8884.cal", "tunnel_table.csv"):
        shutil.copy(DEFAULT_RIG_FILE.parent / name, lab / name)
    with Rig.from_file(lab / "rig.toml", time_scale=TIME_SCALE) as rig:
        result = run_sweep(plan_from_document(PLAN, "portable.toml"), rig, lab / "data")
    assert result.status == "completed"
    processed = process(*result.run_directories, "--out", lab / "out")
    assert processed.exit_code == 0, processed.stderr
    assert not _messages(processed.stderr)
    return lab, result.run_directories, pd.read_csv(lab / "out" / "cycle-averages.csv")


@pytest.fixture
def moved_runs(lab, tmp_path):
    """The runs copied to ``tmp_path/desk`` while the lab's calibration file is renamed (restored after)."""
    lab_folder, runs, _ = lab
    copies = [shutil.copytree(run, tmp_path / "desk" / run.name) for run in runs]
    original = lab_folder / "calibration" / "FT8884.cal"
    hidden = original.rename(original.with_suffix(".moved"))
    yield copies
    hidden.rename(original)


def test_each_calibration_file_is_copied_into_the_run_folder_with_its_hash(lab):
    lab_folder, runs, _ = lab
    for run in runs:
        files = json.loads((run / "run.json").read_text())["calibration_files"]
        assert set(files) == {"balance", "tunnel_table"}
        for entry in files.values():
            copy = run / entry["copy"]
            assert copy.parent == run / "calibration"
            assert copy.read_bytes() == Path(entry["path"]).read_bytes()
            assert Path(entry["path"]).is_relative_to(lab_folder)


def test_copied_runs_process_identically_without_the_original_calibration_file(
    lab, moved_runs, tmp_path
):
    result = process(*moved_runs, "--out", tmp_path / "out")
    assert result.exit_code == 0, result.stderr
    sources = json.loads(result.stdout)["calibration_files"]
    assert {entry["source"] for entry in sources.values()} == {"run folder copy"}
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "out" / "cycle-averages.csv"), lab[2])


def test_without_any_copy_the_file_is_found_by_content_in_the_search_path(
    lab, moved_runs, tmp_path
):
    for run in moved_runs:
        shutil.rmtree(run / "calibration")
    failed = process(*moved_runs, "--out", tmp_path / "bad")
    assert failed.exit_code == 2
    (line,) = failed.stderr.strip().splitlines()
    recorded_hash = json.loads((moved_runs[0] / "run.json").read_text())["calibration_files"][
        "balance"
    ]["hash"]
    assert "run.json: calibration_files.balance" in line and recorded_hash in line
    assert "FT8884.cal (file not found)" in line and "no search folders given" in line
    assert "--search-path" not in line  # the library names files and keys, not command-line options

    stick = tmp_path / "stick"
    stick.mkdir()
    (stick / "notes.txt").write_text("not a calibration\n")
    shutil.copy(lab[0] / "calibration" / "FT8884.moved", stick / "nano17-2024.cal")
    result = process(
        *moved_runs, "--search-path", tmp_path, "--search-path", stick, "--out", tmp_path / "out"
    )
    assert result.exit_code == 0, result.stderr
    sources = json.loads(result.stdout)["calibration_files"]
    assert {entry["path"] for entry in sources.values()} == {str(stick / "nano17-2024.cal")}
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "out" / "cycle-averages.csv"), lab[2])


def test_an_override_is_used_and_one_with_other_content_only_with_a_warning(
    lab, moved_runs, tmp_path
):
    same = shutil.copy(lab[0] / "calibration" / "FT8884.moved", tmp_path / "same.cal")
    result = process(*moved_runs, "--cal", same, "--out", tmp_path / "same")
    assert result.exit_code == 0 and not _messages(result.stderr), result.stderr
    assert {
        entry["source"] for entry in json.loads(result.stdout)["calibration_files"].values()
    } == {"override"}

    other = tmp_path / "other.cal"
    other.write_bytes(same.read_bytes() + b"\n")  # other bytes, same matrix
    result = process(*moved_runs, "--cal", other, "--out", tmp_path / "other")
    assert result.exit_code == 0, result.stderr
    warnings = _messages(result.stderr)
    assert len(warnings) == len(moved_runs)
    assert all(line.startswith(f"warning: {other}: used as balance file") for line in warnings)
    assert all("differs from the file the run was recorded with" in line for line in warnings)
    assert json.loads(result.stdout)["warnings"] == warnings
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "other" / "cycle-averages.csv"), lab[2])

    missing = process(*moved_runs, "--cal", tmp_path / "none.cal", "--out", tmp_path / "bad")
    assert missing.exit_code == 2
    assert missing.stderr.strip() == f"ornitail: error: {tmp_path / 'none.cal'}: file not found"


def test_a_run_recorded_before_copies_were_made_processes_from_its_recorded_path(lab, tmp_path):
    _, runs, reference = lab
    old_runs = [shutil.copytree(run, tmp_path / "old" / run.name) for run in runs]
    for run in old_runs:
        shutil.rmtree(run / "calibration")
        metadata = json.loads((run / "run.json").read_text())
        for entry in metadata["calibration_files"].values():
            del entry["copy"]
        (run / "run.json").write_text(json.dumps(metadata))
    result = process(*old_runs, "--out", tmp_path / "out")
    assert result.exit_code == 0, result.stderr
    sources = json.loads(result.stdout)["calibration_files"]
    assert {entry["source"] for entry in sources.values()} == {"recorded path"}
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "out" / "cycle-averages.csv"), reference)


def test_copies_of_files_with_the_same_name_get_the_label_in_front():
    names = calibration_copy_names(
        {"balance": Path("a/table.csv"), "tunnel_table": Path("b/table.csv"), "x": Path("c.cal")}
    )
    assert names == {
        "balance": "calibration/balance-table.csv",
        "tunnel_table": "calibration/tunnel_table-table.csv",
        "x": "calibration/c.cal",
    }
