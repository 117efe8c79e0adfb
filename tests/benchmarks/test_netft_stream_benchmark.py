"""The Net F/T streaming benchmark script: its output and the bookkeeping of its numbers (no timing)."""

import contextlib
import importlib
import io
import json
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "netft_stream.py"


def load_script():
    """The benchmark script as a module (``benchmarks/`` is on the tests' path)."""
    return importlib.import_module("netft_stream")


def run(arguments: list[str]) -> tuple[int, str]:
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exit_code = load_script().main(arguments)
    return exit_code, printed.getvalue()


def test_a_short_run_prints_one_json_object_whose_numbers_add_up():
    exit_code, printed = run(["--duration-s", "2", "--json"])
    (line,) = printed.strip().splitlines()
    result = json.loads(line)
    records = result["records"]
    assert exit_code == (0 if result["all_targets_met"] else 1)
    assert result["all_targets_met"] == all(result["targets"].values())
    assert records["received"] > 0 and result["requested_rate_hz"] == 7000
    assert records["received"] + records["lost"] <= records["sent_by_device"]
    assert result["targets"]["accounting_balanced"] == (
        records["received"] + records["lost"] == records["sent_by_device"]
    )
    assert result["achieved_rate_hz"] == pytest.approx(records["received"] / result["duration_s"])
    assert result["targets"]["device_stopped"]
    assert "records lost (rdt_sequence gaps)" in load_script().render_table(result)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--rate-hz", "5000"], "--rate-hz: 5000 is not 7000 Hz divided"),
        (["--duration-s", "0"], "--duration-s"),
    ],
)
def test_bad_options_exit_2_with_one_line(arguments, message, capsys):
    exit_code, printed = run(arguments)
    assert exit_code == 2 and printed == ""
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert message in line
