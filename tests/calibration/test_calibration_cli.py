"""``ornitail calibration ...``: JSON shapes, text tables, one-line errors with exit code 2."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.data_files import (
    EXAMPLE_HOTWIRE_POINTS_PATH,
    EXAMPLE_TUNNEL_TABLE_PATH,
)
from ornitail.calibration.hotwire_laws import load_hotwire_law
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.hashing import content_hash_of_file

VOLTS = "0.1,-0.2,0.3,0.05,-0.1,0.2"
BIAS = "0.01,0.02,-0.01,0.0,0.03,-0.02"


def test_convert_json_equals_the_library_result(run_ornitail, cal_file_path):
    path = cal_file_path("FT8884")
    result = run_ornitail(
        "calibration",
        "convert",
        "--cal",
        path,
        "--volts",
        VOLTS,
        "--bias",
        BIAS,
        "--tool-transform",
        "1,2,30,0,0,90",
        "--json",
    )
    assert result.exit_code == 0, result.output
    values = json.loads(result.stdout)
    assert list(values) == ["fx_n", "fy_n", "fz_n", "tx_n_m", "ty_n_m", "tz_n_m"]
    calibration = AtiCalibration.from_file(path).with_tool_transform(
        ToolTransform.from_mm_deg(1, 2, 30, 0, 0, 90)
    )
    expected = calibration.forces_from_voltages(
        np.array(VOLTS.split(","), dtype=float), np.array(BIAS.split(","), dtype=float)
    )
    # json.dumps writes floats with repr: exact.
    np.testing.assert_array_equal(list(values.values()), expected)


def test_convert_defaults_to_zero_bias_and_no_tool_transform(run_ornitail, cal_file_path):
    path = cal_file_path("FT18766")
    result = run_ornitail("calibration", "convert", "--cal", path, "--volts", VOLTS, "--json")
    expected = AtiCalibration.from_file(path).matrix_si @ np.array(VOLTS.split(","), dtype=float)
    np.testing.assert_allclose(list(json.loads(result.stdout).values()), expected, rtol=1e-15)


def test_convert_text_output_names_units(run_ornitail, cal_file_path):
    result = run_ornitail(
        "calibration", "convert", "--cal", cal_file_path("FT8884"), "--volts", VOLTS
    )
    assert result.exit_code == 0
    lines = result.stdout.strip().splitlines()
    assert [line.split()[0] for line in lines] == ["fx", "fy", "fz", "tx", "ty", "tz"]
    assert [line.split()[-1] for line in lines] == ["N"] * 3 + ["m"] * 3
    assert all(" N m" in line for line in lines[3:])


def test_show_json(run_ornitail, cal_file_path):
    path = cal_file_path("FT8884")
    result = run_ornitail("calibration", "show", "--cal", path, "--json")
    assert result.exit_code == 0
    values = json.loads(result.stdout)
    assert values["serial"] == "FT8884"
    assert values["file_units"] == {"force": "N", "torque": "N-mm", "distance": "mm"}
    assert values["rated_ranges"] == {
        "fx_n": 50.0,
        "fy_n": 50.0,
        "fz_n": 70.0,
        "tx_n_m": 0.5,
        "ty_n_m": 0.5,
        "tz_n_m": 0.5,
    }
    assert values["matrix_si_per_volt"][0][0] == pytest.approx(
        0.01075 / 5.41651440383645, rel=1e-15
    )
    assert values["content_hash"] == content_hash_of_file(path)


def test_show_text(run_ornitail, cal_file_path):
    result = run_ornitail("calibration", "show", "--cal", cal_file_path("FT18766"))
    assert result.exit_code == 0
    assert "FT18766" in result.stdout and "N m per V" in result.stdout
    assert "tz  60 N m" in result.stdout


@pytest.mark.parametrize("law", ["king", "polynomial"])
def test_hotwire_fit_json_and_saved_law(run_ornitail, tmp_path, law):
    out = tmp_path / f"{law}.toml"
    result = run_ornitail(
        "calibration",
        "hotwire-fit",
        "--points",
        EXAMPLE_HOTWIRE_POINTS_PATH,
        "--law",
        law,
        "--out",
        out,
        "--json",
    )
    assert result.exit_code == 0, result.output
    values = json.loads(result.stdout)
    assert values["law"] == law
    assert len(values["points"]) == 15
    residuals = np.array([point["residual_m_s"] for point in values["points"]])
    assert values["rms_residual_m_s"] == pytest.approx(np.sqrt(np.mean(residuals**2)), rel=1e-12)
    # 2 mV of noise is 0.005-0.03 m/s of velocity across the range: RMS must be of that order.
    assert 0.003 < values["rms_residual_m_s"] < 0.04
    assert values["content_hash"] == content_hash_of_file(out)
    assert load_hotwire_law(out).content_hash == values["content_hash"]
    if law == "king":
        assert set(values["coefficients"]) == {"a_v2", "b", "exponent_n"}
    else:
        assert len(values["coefficients"]["coefficients"]) == 5


def test_hotwire_fit_text_names_units(run_ornitail):
    result = run_ornitail("calibration", "hotwire-fit", "--points", EXAMPLE_HOTWIRE_POINTS_PATH)
    assert result.exit_code == 0
    assert "RMS residual" in result.stdout and "m/s" in result.stdout


@pytest.mark.parametrize(
    ("option", "value", "expected_rpm", "expected_velocity"),
    [("--rpm", "650", 650.0, 1.075), ("--velocity-m-s", "1.075", 650.0, 1.075)],
)
def test_tunnel_json(run_ornitail, option, value, expected_rpm, expected_velocity):
    result = run_ornitail(
        "calibration", "tunnel", "--table", EXAMPLE_TUNNEL_TABLE_PATH, option, value, "--json"
    )
    assert result.exit_code == 0
    values = json.loads(result.stdout)
    # Linear between (600, 0.95) and (700, 1.20).
    assert values["fan_rpm"] == pytest.approx(expected_rpm, rel=1e-12)
    assert values["velocity_m_s"] == pytest.approx(expected_velocity, rel=1e-12)
    assert values["table_content_hash"] == content_hash_of_file(EXAMPLE_TUNNEL_TABLE_PATH)


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _edited_ft8884(tmp_path, old, new):
    source = Path(__file__).resolve().parents[1] / "data" / "calibration" / "FT8884.cal"
    return _write(tmp_path, "edited.cal", source.read_text().replace(old, new, 1))


BAD_INPUTS = {
    "missing cal file": (
        lambda t: ["convert", "--cal", t / "absent.cal", "--volts", VOLTS],
        ["absent.cal", "file not found"],
    ),
    "malformed xml": (
        lambda t: ["show", "--cal", _write(t, "bad.cal", "<FTSensor><Calib")],
        ["bad.cal", "not a valid XML"],
    ),
    "wrong gauge count": (
        lambda t: ["show", "--cal", _edited_ft8884(t, 'NumGages="6"', 'NumGages="8"')],
        ["NumGages", "'8' gauges"],
    ),
    "five values in a row": (
        lambda t: ["show", "--cal", _edited_ft8884(t, "2.42238 ", "")],
        ["Name='Fy'", "expected 6 values"],
    ),
    "non-numeric value": (
        lambda t: ["show", "--cal", _edited_ft8884(t, "21.68095", "2l.68")],
        ["Name='Fz'", "'2l.68' is not a number"],
    ),
    "unknown units": (
        lambda t: ["show", "--cal", _edited_ft8884(t, '"N-mm"', '"ozf-in"')],
        ["TorqueUnits", "unknown torque unit 'ozf-in'"],
    ),
    "nan in volts": (
        lambda t: ["convert", "--cal", _edited_ft8884(t, "", ""), "--volts", "0,0,nan,0,0,0"],
        ["--volts", "item 3"],
    ),
    "five bias values": (
        lambda t: [
            "convert",
            "--cal",
            _edited_ft8884(t, "", ""),
            "--volts",
            VOLTS,
            "--bias",
            "0,0,0,0,0",
        ],
        ["--bias", "expected 6 comma-separated numbers, got 5"],
    ),
    "text in tool transform": (
        lambda t: [
            "convert",
            "--cal",
            _edited_ft8884(t, "", ""),
            "--volts",
            VOLTS,
            "--tool-transform",
            "0,0,x,0,0,0",
        ],
        ["--tool-transform", "item 3"],
    ),
    "nan in points csv": (
        lambda t: [
            "hotwire-fit",
            "--points",
            _write(
                t,
                "p.csv",
                "velocity_m_s,voltage_v,temperature_c\n0.2,1.4,20\n0.4,nan,20\n"
                "0.6,1.5,20\n0.8,1.6,20\n",
            ),
        ],
        ["p.csv: line 3, column voltage_v"],
    ),
    "missing points column": (
        lambda t: [
            "hotwire-fit",
            "--points",
            _write(t, "p.csv", "velocity_m_s,voltage_v\n0.2,1.4\n"),
        ],
        ["p.csv", "temperature_c"],
    ),
    "negative velocity": (
        lambda t: [
            "hotwire-fit",
            "--points",
            _write(
                t,
                "p.csv",
                "velocity_m_s,voltage_v,temperature_c\n0.2,1.4,20\n-0.4,1.45,20\n"
                "0.6,1.5,20\n0.8,1.6,20\n",
            ),
        ],
        ["line 3, column velocity_m_s"],
    ),
    "bad out suffix": (
        lambda t: ["hotwire-fit", "--points", EXAMPLE_HOTWIRE_POINTS_PATH, "--out", t / "law.yaml"],
        ["--out", ".toml or .json"],
    ),
    "non-monotonic table": (
        lambda t: [
            "tunnel",
            "--table",
            _write(t, "t.csv", "fan_rpm,velocity_m_s\n0,0\n500,1\n450,1.2\n"),
            "--rpm",
            "100",
        ],
        ["t.csv: line 4, column fan_rpm", "strictly increasing"],
    ),
    "extrapolation": (
        lambda t: ["tunnel", "--table", EXAMPLE_TUNNEL_TABLE_PATH, "--rpm", "5000"],
        ["5000", "range 0 to 1420"],
    ),
    "both rpm and velocity": (
        lambda t: [
            "tunnel",
            "--table",
            EXAMPLE_TUNNEL_TABLE_PATH,
            "--rpm",
            "5",
            "--velocity-m-s",
            "1",
        ],
        ["exactly one"],
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_is_one_line_and_exit_code_2(run_ornitail, tmp_path, case):
    make_arguments, expected_words = BAD_INPUTS[case]
    result = run_ornitail("calibration", *make_arguments(tmp_path))
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    for words in expected_words:
        assert str(words) in lines[0]


def _console_script() -> str:
    found = shutil.which("ornitail")
    return found if found else str(Path(sys.executable).parent / "ornitail")


def test_real_console_script_converts_and_refuses(cal_file_path):
    ok = subprocess.run(
        [
            _console_script(),
            "calibration",
            "convert",
            "--cal",
            str(cal_file_path("FT8885")),
            "--volts",
            VOLTS,
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    assert set(json.loads(ok.stdout)) == {"fx_n", "fy_n", "fz_n", "tx_n_m", "ty_n_m", "tz_n_m"}
    bad = subprocess.run(
        [
            _console_script(),
            "calibration",
            "convert",
            "--cal",
            str(cal_file_path("FT8885")),
            "--volts",
            "1,2,3",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "--volts" in bad.stderr
    assert "Traceback" not in bad.stderr
