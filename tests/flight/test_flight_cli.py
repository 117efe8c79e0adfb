"""``ornitail flight identify`` through click and through the installed console script."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from ornitail.app.commands.flight import flight_group
from ornitail.core.errors import UserInputError

CSV_PATH = str(Path(__file__).parents[1] / "data" / "twin-otter" / "twin_otter_020213f1_019.csv")


def test_identify_json_is_exactly_the_documented_object():
    result = CliRunner().invoke(
        flight_group,
        ["identify", "--model", "twin_otter_short_period", "--data", CSV_PATH, "--json"],
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert set(data) == {"parameters", "fit", "eigenvalues", "input_hold", "warnings"}
    assert set(data["parameters"]["Ma"]) == {"value", "sigma", "sigma_colored", "unit"}
    assert data["parameters"]["Ma"]["value"] == pytest.approx(-9.45, abs=0.05)
    assert set(data["fit"]) == {"alpha", "q", "a_z"} and min(data["fit"].values()) > 0.9
    assert len(data["eigenvalues"]) == 2 and all(len(pair) == 2 for pair in data["eigenvalues"])


def test_identify_text_table_and_equation_error():
    result = CliRunner().invoke(
        flight_group,
        [
            "identify",
            "--model",
            "twin_otter_short_period",
            "--data",
            CSV_PATH,
            "--method",
            "equation_error",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "sigma_colored" in result.output and "damping ratio" in result.output
    assert "method equation_error" in result.output


def test_a_log_without_the_models_columns_is_a_user_error(tmp_path):
    log = tmp_path / "log.csv"
    log.write_text("time_s,q_rad_s\n0,0\n0.1,0\n")
    result = CliRunner().invoke(
        flight_group, ["identify", "--model", "delfly_longitudinal", "--data", str(log)]
    )
    assert isinstance(result.exception, UserInputError)
    assert "u_m_s" in str(result.exception) and "elevator_rad" in str(result.exception)


def test_console_script_runs_identify():
    script = shutil.which("ornitail") or str(Path(sys.executable).parent / "ornitail")
    completed = subprocess.run(
        [
            script,
            "flight",
            "identify",
            "--model",
            "twin_otter_short_period",
            "--data",
            CSV_PATH,
            "--json",
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert completed.returncode == 0, completed.stderr
    assert set(json.loads(completed.stdout)) == {
        "parameters",
        "fit",
        "eigenvalues",
        "input_hold",
        "warnings",
    }
    missing = subprocess.run(
        [script, "flight", "identify", "--model", "delfly_longitudinal", "--data", CSV_PATH],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert missing.returncode == 2 and "missing column(s)" in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1
