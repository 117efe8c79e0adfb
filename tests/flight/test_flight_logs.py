"""Flight logs from CSV, Parquet and .mat files; missing columns named."""

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io

from ornitail.core.errors import UserInputError
from ornitail.flight.flight_logs import column_names_from_labels, read_flight_log
from ornitail.flight.identify import identify
from ornitail.flight.model_file import load_model

TWIN_OTTER = Path(__file__).parents[1] / "data" / "twin-otter"
CSV_PATH = TWIN_OTTER / "twin_otter_020213f1_019.csv"
MAT_PATH = TWIN_OTTER / "twin_otter_020213f1_019.mat"


def test_mat_fdata_labels_give_the_same_columns_as_the_csv():
    from_csv, from_mat = read_flight_log(CSV_PATH), read_flight_log(MAT_PATH)
    assert list(from_mat.columns) == list(from_csv.columns)
    # The CSV was written with 10 significant digits: agreement to 1e-7 absolute at most.
    np.testing.assert_allclose(from_mat.to_numpy(), from_csv.to_numpy(), rtol=1e-8, atol=1e-7)


def test_label_rules():
    labels = [
        "* alpha      (deg)     ",
        "*                      ",
        "* qbar       (lbf/ft2) ",
        "* Ixx        (slug-ft2)",
        "  Cl                   ",
        "  CL                   ",
    ]
    assert column_names_from_labels(labels, 7) == [
        "alpha_deg",
        "ch2",
        "qbar_lbf_ft2",
        "ixx_slug_ft2",
        "cl",
        "cl_b",
        "ch7",
    ]


def test_mat_with_one_vector_per_column(tmp_path):
    path = tmp_path / "log.mat"
    scipy.io.savemat(path, {"time_s": np.arange(5.0), "q_rad_s": np.ones((5, 1)), "note": "x"})
    log = read_flight_log(path)
    assert list(log.columns) == ["time_s", "q_rad_s"] and log.q_rad_s.tolist() == [1.0] * 5


def test_parquet_round_trip_or_a_clear_message_without_pyarrow(tmp_path):
    frame = pd.DataFrame({"time_s": np.arange(4.0), "q_rad_s": np.linspace(0, 1, 4)})
    path = tmp_path / "log.parquet"
    if (
        importlib.util.find_spec("pyarrow") is None
        and importlib.util.find_spec("fastparquet") is None
    ):
        path.write_bytes(b"PAR1 not really")
        with pytest.raises(UserInputError, match="pyarrow"):
            read_flight_log(path)
    else:
        frame.to_parquet(path)
        pd.testing.assert_frame_equal(read_flight_log(path), frame)


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("log.txt", "a,b\n1,2\n", "unknown log type"),
        ("log.csv", "a,b\n1,x\n", "is not numeric"),
        ("log.csv", "", "not a readable CSV"),
        ("log.mat", "not a mat file", "not a readable MATLAB"),
    ],
)
def test_bad_logs_are_refused(tmp_path, name, content, problem):
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(UserInputError, match=problem):
        read_flight_log(path)
    with pytest.raises(UserInputError, match="not found"):
        read_flight_log(tmp_path / "absent.csv")


def test_missing_columns_are_all_named():
    log = read_flight_log(CSV_PATH).drop(columns=["q_deg_sec", "airspeed_ft_sec"])
    with pytest.raises(UserInputError) as error:
        identify(load_model("twin_otter_short_period"), log, where="flight.csv")
    assert error.value.where == "flight.csv"
    assert "airspeed_ft_sec, q_deg_sec" in error.value.problem


def test_nan_and_uneven_time_are_refused():
    log = read_flight_log(CSV_PATH)
    holed = log.copy()
    holed.loc[10, "alpha_deg"] = np.nan
    with pytest.raises(UserInputError, match="non-finite value at row 11"):
        identify(load_model("twin_otter_short_period"), holed)
    uneven = log.drop(index=[50, 51]).reset_index(drop=True)
    with pytest.raises(UserInputError, match="even steps"):
        identify(load_model("twin_otter_short_period"), uneven)
