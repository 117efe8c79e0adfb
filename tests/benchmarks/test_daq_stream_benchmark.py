"""The DAQ streaming benchmark script: its output fields and the consistency of its numbers.

No timing assertions: the CPU numbers depend on the machine; only their bookkeeping is checked.
"""

import contextlib
import importlib
import io
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "daq_stream.py"


def load_script():
    """The benchmark script as a module (``benchmarks/`` is on the tests' path)."""
    return importlib.import_module("daq_stream")


@pytest.fixture(scope="module")
def two_second_run():
    """One 2 s run at 10 kHz with a 1 s baseline (0.5 s before, 0.5 s after): exit code, result."""
    module = load_script()
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exit_code = module.main(
            ["--duration-s", "2", "--rate-hz", "10000", "--baseline-s", "1", "--json"]
        )
    (line,) = printed.getvalue().strip().splitlines()  # --json: exactly one JSON object
    return exit_code, json.loads(line), module.render_table(json.loads(line))


def test_exit_code_says_whether_every_target_was_met(two_second_run):
    exit_code, result, _ = two_second_run
    assert exit_code == (0 if result["all_targets_met"] else 1)
    assert result["all_targets_met"] == all(result["targets"].values())


def test_every_sample_the_board_took_is_recorded_or_counted_lost(two_second_run):
    _, result, _ = two_second_run
    samples = result["samples"]
    assert samples["recorded"] + samples["lost"] == samples["board_taken"]
    assert samples["lost"] == samples["lost_on_link"] + samples["lost_in_recorder_queue"]
    assert result["targets"]["accounting_balanced"]
    assert result["targets"]["recording_completed"]
    # The board takes int(elapsed * rate) samples between handling START and STOP; those commands
    # are handled within one board loop (5 ms select timeout) of the host's clock readings, plus
    # scheduling delay on a busy 2-core machine: 0.05 s x rate covers that ten times over.
    tolerance = 0.05 * result["requested_rate_hz"]
    assert abs(samples["board_taken"] - samples["expected_at_requested_rate"]) <= tolerance
    assert result["achieved_over_requested_rate"] == pytest.approx(
        samples["recorded"] / samples["expected_at_requested_rate"], rel=1e-12
    )


def test_a_pty_link_has_no_crc_errors_or_garbage(two_second_run):
    # No faults are injected and a pty neither corrupts nor loses bytes: these counts are exact.
    _, result, _ = two_second_run
    assert result["link"] == {"crc_errors": 0, "truncated_frames": 0, "garbage_bytes": 0}


def test_link_ceiling_is_baud_over_250_bits(two_second_run):
    _, result, _ = two_second_run
    assert result["link_ceiling_hz"] == 4_000_000 / 250
    assert result["link_utilisation"] == pytest.approx(10_000 / 16_000)


def test_cpu_figures_are_per_second_of_recorded_data_and_ratios_use_the_baseline(two_second_run):
    _, result, _ = two_second_run
    data_s = result["samples"]["recorded"] / result["requested_rate_hz"]
    cpu, per_s = result["cpu_s"], result["cpu_s_per_s_of_data"]
    assert cpu["driver_reader_thread"] > 0 and cpu["recorder_writer_thread"] > 0
    # The process time includes both threads (and the simulated board).
    assert cpu["whole_process"] >= cpu["driver_reader_thread"] + cpu["recorder_writer_thread"]
    assert per_s["driver_and_recorder"] == pytest.approx(
        (cpu["driver_reader_thread"] + cpu["recorder_writer_thread"]) / data_s
    )
    baseline = result["baseline_raw_pty_read"]
    assert len(baseline["runs"]) == 2
    for run in baseline["runs"]:
        # The raw reader saw the stream: about 10 kHz of 25-byte frames (half a second each, so
        # start-up latency of a few ms leaves it well above half the rate).
        assert run["frames_per_s"] > 0.5 * result["requested_rate_hz"]
        assert run["cpu_s_per_s_of_data"] > 0
    assert result["ratio_to_baseline"]["driver_and_recorder"] == pytest.approx(
        per_s["driver_and_recorder"] / baseline["cpu_s_per_s_of_data"]
    )
    expected_target = per_s["driver_and_recorder"] < 0.2
    assert result["targets"]["driver_and_recorder_cpu_below_target"] == expected_target


def test_table_names_every_reported_quantity(two_second_run):
    _, _, table = two_second_run
    for label in (
        "samples lost",
        "CRC errors",
        "achieved / requested rate",
        "link ceiling",
        "driver + recorder",
        "baseline raw read",
        "ratio driver + recorder / baseline",
    ):
        assert label in table


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--duration-s", "0", "must be > 0"),
        ("--duration-s", "nan", "not a finite number"),
        ("--rate-hz", "20000", "outside 100..16000 Hz"),
        ("--baseline-s", "-1", "must be > 0"),
    ],
)
def test_bad_values_give_one_line_and_exit_code_2(option, value, message):
    completed = subprocess.run(
        [sys.executable, str(SCRIPT), option, value], capture_output=True, text=True, timeout=60
    )
    assert completed.returncode == 2
    assert completed.stdout == ""
    error_lines = completed.stderr.strip().splitlines()
    assert len(error_lines) == 1
    assert option in error_lines[0] and message in error_lines[0]
