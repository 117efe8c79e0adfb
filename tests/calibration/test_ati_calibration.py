"""ATI calibration files: parsing, SI conversion, bias, inverse, tool transforms."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ornitail.calibration.ati_cal_file import read_ati_cal_file
from ornitail.calibration.ati_calibration import (
    AtiCalibration,
    basic_matrix_with_basic_transform_si,
)
from ornitail.calibration.ati_units import (
    newton_metres_per_torque_unit,
    newtons_per_force_unit,
)
from ornitail.calibration.data_files import DEFAULT_BALANCE_CALIBRATION_PATH
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_file

# Values copied by hand from the three real files.
FILE_FACTS = {
    "FT8884": dict(
        body_style="Nano17",
        part_number="SI-50-0.5",
        calibration_date="12/12/2008",
        file_format_version="1.0",
        force_units="N",
        torque_units="N-mm",
        distance_units="mm",
        ranges_si=[50, 50, 70, 0.5, 0.5, 0.5],
    ),
    "FT8885": dict(
        body_style="Nano17",
        part_number="SI-25-0.25",
        calibration_date="12/12/2008",
        file_format_version="1.0",
        force_units="N",
        torque_units="N-mm",
        distance_units="mm",
        ranges_si=[25, 25, 35, 0.25, 0.25, 0.25],
    ),
    "FT18766": dict(
        body_style="Delta IP60",
        part_number="SI-660-60",
        calibration_date="5/17/2016",
        file_format_version="1.1",
        force_units="N",
        torque_units="N-m",
        distance_units="m",
        ranges_si=[660, 660, 1980, 60, 60, 60],
    ),
}


@pytest.mark.parametrize("serial", sorted(FILE_FACTS))
def test_real_files_parse_with_the_values_written_in_them(serial, cal_file_path):
    path = cal_file_path(serial)
    calibration = AtiCalibration.from_file(path)
    facts = FILE_FACTS[serial]
    assert calibration.serial == serial
    for name, value in facts.items():
        if name == "ranges_si":
            np.testing.assert_allclose(calibration.ranges_si, value, rtol=1e-15)
        else:
            assert getattr(calibration, name) == value
    assert calibration.matrix_si.shape == (6, 6)
    assert calibration.content_hash == content_hash_of_file(path)
    assert calibration.path == path


# Hand-checked entries, N or N m per volt. FT8884/5 are format 1.0: Axis value / scale, torque
# rows N-mm -> N m (x 1e-3), and the BasicTransform Dz (mm) adds Dz * Fy to Tx (T' = T - d x F
# with d = (0, 0, Dz) gives Tx' = Tx + Dz Fy, Ty' = Ty - Dz Fx, Tz' = Tz).
HAND_CHECKED_ENTRIES = [
    ("FT8884", 0, 0, 0.01075 / 5.41651440383645),
    ("FT8884", 2, 4, 22.26496 / 3.07423790488014),
    ("FT8884", 5, 0, 0.73856 / 0.733492329139973 * 1e-3),
    ("FT8884", 3, 0, (-1.16519 / 0.965832440764422 + 6.096 * 2.42238 / 5.41651440383645) * 1e-3),
    ("FT8884", 4, 1, (-0.62919 / 0.965832440764422 - 6.096 * -0.45445 / 5.41651440383645) * 1e-3),
    ("FT8885", 1, 1, -88.78580 / 10.8855050171773),
    ("FT8885", 5, 5, -43.67274 / 1.47409086981454 * 1e-3),
    # format 1.1: UserAxis rows are the matrix, already in N and N-m.
    ("FT18766", 0, 0, -1.81382),
    ("FT18766", 2, 0, 120.12303),
    ("FT18766", 3, 1, 1.54285),
    ("FT18766", 5, 5, -2.55019),
]


@pytest.mark.parametrize(("serial", "row", "column", "expected"), HAND_CHECKED_ENTRIES)
def test_matrix_entries_checked_by_hand(serial, row, column, expected, cal_file_path):
    matrix = AtiCalibration.from_file(cal_file_path(serial)).matrix_si
    # Only float64 rounding separates the two computations: a few ulp.
    assert matrix[row, column] == pytest.approx(expected, rel=1e-13, abs=1e-16)


def test_format_1_1_user_axis_rows_equal_axis_scale_and_basic_transform(cal_file_path):
    path = cal_file_path("FT18766")
    contents, _ = read_ati_cal_file(path)
    from_axis_rows = basic_matrix_with_basic_transform_si(contents, str(path))
    user_axis = AtiCalibration.from_file(path).matrix_si
    # Both sides are printed with 5 decimals, so each differs from ATI's exact numbers by up to
    # 0.5e-5. The UserAxis entry carries that directly; an Axis entry carries it divided by its
    # scale, and the torque rows add Dz times the force-row error. That worst case is the bound:
    scales = np.array(
        [0.498178167356047] * 2 + [0.164640629289319] + [8.27567584790681] * 2 + [7.47971806962217]
    )
    axis_rounding = 0.5e-5 / scales
    propagated = axis_rounding.copy()
    propagated[3] += 0.0191262 * axis_rounding[1]
    propagated[4] += 0.0191262 * axis_rounding[0]
    bound = 0.5e-5 + propagated[:, None]
    assert np.all(np.abs(from_axis_rows - user_axis) <= bound)
    # ...and the bound is tight enough to catch a sign error in the BasicTransform: flipping Dz
    # changes the Tx row by 2 Dz Fy, about 3 N m/V.
    contents_flipped = dataclasses.replace(
        contents, basic_transform_distances=-contents.basic_transform_distances
    )
    flipped = basic_matrix_with_basic_transform_si(contents_flipped, str(path))
    assert not np.all(np.abs(flipped - user_axis) <= bound)


def test_bias_is_subtracted_before_the_matrix(cal_file_path):
    calibration = AtiCalibration.from_file(cal_file_path("FT8884"))
    rng = np.random.default_rng(1)
    volts = rng.uniform(-5, 5, size=(7, 6))
    bias = rng.uniform(-0.5, 0.5, size=6)
    expected = (calibration.matrix_si @ (volts - bias).T).T
    np.testing.assert_allclose(calibration.forces_from_voltages(volts, bias), expected, rtol=1e-12)
    # Reading the bias voltages themselves gives zero load.
    np.testing.assert_array_equal(calibration.forces_from_voltages(bias, bias), np.zeros(6))


@pytest.mark.parametrize("serial", sorted(FILE_FACTS))
def test_voltages_from_forces_inverts_forces_from_voltages(serial, cal_file_path):
    calibration = AtiCalibration.from_file(cal_file_path(serial)).with_tool_transform(
        ToolTransform.from_mm_deg(3.0, -2.0, 40.0, 10.0, -20.0, 90.0)
    )
    rng = np.random.default_rng(2)
    wrench = rng.uniform(-1, 1, size=(50, 6)) * calibration.ranges_si
    bias = rng.uniform(-0.2, 0.2, size=6)
    volts = calibration.voltages_from_forces(wrench, bias)
    # The matrices have condition numbers below 1e3, so a round trip loses < 1e3 * 1e-16.
    assert np.linalg.cond(calibration.matrix_si) < 1e3
    np.testing.assert_allclose(
        calibration.forces_from_voltages(volts, bias), wrench, rtol=0, atol=1e-11 * np.max(wrench)
    )


def test_ati_unit_factors_match_ati_library_figures():
    # ATI's library gives 0.112984829028 N-m per lbf-in and 4.44822161526 N per lbf.
    assert newton_metres_per_torque_unit("lbf-in", "t") == pytest.approx(0.112984829028, rel=1e-11)
    assert newtons_per_force_unit("lbf", "f") == pytest.approx(4.44822161526, rel=1e-11)
    assert newton_metres_per_torque_unit("kgf-cm", "t") == pytest.approx(0.0980665, rel=1e-15)
    assert newton_metres_per_torque_unit("N-mm", "t") == 1e-3


def test_imperial_units_are_converted_to_si(cal_file_path, tmp_path):
    text = cal_file_path("FT8884").read_text()
    imperial = (
        text.replace('ForceUnits="N"', 'ForceUnits="lbf"')
        .replace('TorqueUnits="N-mm"', 'TorqueUnits="lbf-in"')
        .replace('DistUnits="mm"', 'DistUnits="in"')
        .replace('Dz="6.096"', 'Dz="0.24"')  # 0.24 in = 6.096 mm exactly
    )
    path = tmp_path / "imperial.cal"
    path.write_text(imperial)
    metric = AtiCalibration.from_file(cal_file_path("FT8884"))
    converted = AtiCalibration.from_file(path)
    newtons, newton_metres = 4.4482216152605, 4.4482216152605 * 0.0254
    # The same numbers read as lbf and lbf-in: force rows scale by N/lbf; the torque rows are
    # (Axis torque in lbf-in + Dz(in) * Fy(lbf)) -> both terms in lbf-in, times N m per lbf-in.
    np.testing.assert_allclose(converted.matrix_si[:3], metric.matrix_si[:3] * newtons, rtol=1e-12)
    np.testing.assert_allclose(
        converted.matrix_si[5], metric.matrix_si[5] * 1e3 * newton_metres, rtol=1e-12
    )
    np.testing.assert_allclose(converted.ranges_si[3], 500 * newton_metres, rtol=1e-12)


def test_default_balance_calibration_is_the_real_ft8884(cal_file_path):
    shipped = AtiCalibration.from_file(DEFAULT_BALANCE_CALIBRATION_PATH)
    assert shipped.serial == "FT8884"
    assert shipped.content_hash == content_hash_of_file(cal_file_path("FT8884"))


def _edited_copy(source_text: str, tmp_path, old: str, new: str, count: int = 1):
    assert old in source_text
    path = tmp_path / "edited.cal"
    path.write_text(source_text.replace(old, new, count))
    return path


@pytest.mark.parametrize(
    ("old", "new", "expected_words"),
    [
        ('TorqueUnits="N-mm"', 'TorqueUnits="furlong-oz"', "unknown torque unit 'furlong-oz'"),
        ('ForceUnits="N"', 'ForceUnits="dyn"', "unknown force unit 'dyn'"),
        ('DistUnits="mm"', 'DistUnits="league"', "unknown distance unit"),
        ('NumGages="6"', 'NumGages="7"', "six-gauge"),
        ('CalFileVersion="1.0"', 'CalFileVersion="2.0"', "unsupported format"),
        ("-0.45445", "-0.45x45", "is not a number"),
        ("-0.45445", "nan", "not a finite number"),
        ("  0.01075  -0.45445", "  -0.45445", "expected 6 values"),
        ('Name="Fy"', 'Name="Fq"', "should be 'Fy'"),
        ('scale="3.07423790488014"', 'scale="0"', "scale must be positive"),
        ("</FTSensor>", "", "not a valid XML"),
    ],
)
def test_bad_files_raise_user_input_error(cal_file_path, tmp_path, old, new, expected_words):
    path = _edited_copy(cal_file_path("FT8884").read_text(), tmp_path, old, new)
    with pytest.raises(UserInputError) as raised:
        AtiCalibration.from_file(path)
    assert str(path) in str(raised.value)
    assert expected_words in str(raised.value)


def test_format_1_1_without_user_axis_rows_is_refused(cal_file_path, tmp_path):
    text = cal_file_path("FT18766").read_text()
    lines = [
        line for line in text.splitlines() if not ("<UserAxis" in line and 'Name="Tz"' in line)
    ]
    path = tmp_path / "five_user_rows.cal"
    path.write_text("\n".join(lines))
    with pytest.raises(UserInputError, match=r"<UserAxis>: expected 6 rows, found 5"):
        AtiCalibration.from_file(path)


def test_missing_file_is_a_user_error(tmp_path):
    with pytest.raises(UserInputError, match="absent.cal: file not found"):
        AtiCalibration.from_file(tmp_path / "absent.cal")
