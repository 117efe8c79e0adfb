"""``ornitail sim`` commands through click and through the installed console script."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from ornitail.app.cli import main


def _console_script() -> str:
    found = shutil.which("ornitail")
    return found or str(Path(sys.executable).parent / "ornitail")


def test_trim_json_has_the_model() -> None:
    result = CliRunner().invoke(main, ["sim", "trim", "--tail", "S3", "--x-h-mm", "98", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert 15 < data["theta_deg"] < 30 and 0.5 < data["v_m_s"] < 1.0 and 13 < data["f_hz"] < 14.4
    assert len(data["eigenvalues_real"]) == 4 and 0 < data["damping_ratio"] < 1
    assert set(data["derivatives"]) >= {"Mq", "Mu", "Xu", "Mde"}


def test_trim_text_output() -> None:
    result = CliRunner().invoke(main, ["sim", "trim", "--tail", "T3", "--x-h-mm", "57"])
    assert result.exit_code == 0
    assert "theta_deg" in result.output and "damping ratio" in result.output


@pytest.mark.parametrize(
    ("arguments", "fragment"),
    [
        (["sim", "trim", "--tail", "S9"], "unknown tail 'S9'"),
        (["sim", "trim", "--tail", "S3", "--x-h-mm", "400"], "outside 20-300 mm"),
        (["sim", "flight", "--tail", "S3", "--duration-s", "0", "--out", "x.csv"], "--duration-s"),
    ],
)
def test_user_mistakes_give_one_line_and_exit_2(arguments, fragment) -> None:
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == 2
    assert fragment in result.output
    assert "Traceback" not in result.output


def test_flight_command_through_the_console_script(tmp_path) -> None:
    out = tmp_path / "log.csv"
    completed = subprocess.run(
        [
            _console_script(),
            "sim",
            "flight",
            "--tail",
            "S3",
            "--x-h-mm",
            "98",
            "--duration-s",
            "3",
            "--seed",
            "1",
            "--out",
            str(out),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert completed.returncode == 0, completed.stderr
    assert json.loads(completed.stdout)["rows"] == 3 * 512
    log = pd.read_csv(out)
    assert "q_rad_s" in log.columns and len(log) == 3 * 512


def test_unknown_tail_through_the_console_script() -> None:
    completed = subprocess.run(
        [_console_script(), "sim", "trim", "--tail", "Q1"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert completed.returncode == 2
    assert completed.stderr.strip().count("\n") == 0 and "unknown tail" in completed.stderr
