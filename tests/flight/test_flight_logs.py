"""Flight logs from CSV, Parquet and .mat files (matrices, vectors, structs); missing columns named;
time columns accepted up to rounding and jitter, missing and doubled samples refused by row.
"""

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
from ornitail.flight.sampling import uniform_grid

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
    with pytest.raises(
        UserInputError, match=r"^data: column time_sec: sample\(s\) missing before row 51 "
    ):
        identify(load_model("twin_otter_short_period"), uneven)


RATE_HZ = 512.0
EXACT_TIME_S = np.arange(int(300 * RATE_HZ)) / RATE_HZ  # a 5-minute flight at 512 Hz


def _jittered(time_s: np.ndarray) -> np.ndarray:
    """Gaussian clock jitter of 5 % of the sample interval (seeded)."""
    return time_s + np.random.default_rng(7).normal(0.0, 0.05 / RATE_HZ, time_s.size)


@pytest.mark.parametrize(
    "stamped",
    [
        pytest.param(lambda t: np.round(t, 7), id="7 decimals"),
        pytest.param(lambda t: np.array([float(f"{v:.9g}") for v in t + 53603.56]), id="9g day"),
        pytest.param(lambda t: np.round(t, 3), id="milliseconds"),
        pytest.param(_jittered, id="jitter 5 %"),
        pytest.param(lambda t: np.round(_jittered(t), 7), id="jitter, 7 decimals"),
    ],
)
def test_rounded_or_jittered_time_is_a_uniform_grid(stamped):
    # "9g day": the simulator's CSV format (%.9g) on a clock of day rounds to 0.1 ms, 5 % of the
    # interval, and "milliseconds" to 26 %: both beyond the old 1 % rule
    time_s = stamped(EXACT_TIME_S)
    grid = uniform_grid(time_s, "log.csv: column time_s")
    # least-squares slope over N = 153600 samples: its error is sigma sqrt(12 / N^3), 3e-9 of the
    # interval for 5 % jitter and less for rounding; 1e-7 is > 30 standard errors
    assert grid.step_s == pytest.approx(1 / RATE_HZ, rel=1e-7)
    assert np.max(np.abs(grid.times_s() - time_s)) < 0.26 / RATE_HZ


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda t: np.delete(t, 1000), r"sample\(s\) missing before row 1001 \(t = 1\.955"),
        (lambda t: np.insert(t, 1000, t[999]), r"time does not increase at row 1001"),
        (
            lambda t: np.insert(t, 1000, t[999] + 0.2 / RATE_HZ),
            r"a doubled sample at row 1001 .* 0\.[0-9]+ sample intervals",
        ),
        (lambda t: t + np.where(t > 100.0, 0.3 / RATE_HZ, 0.0), r"row \d+ .* off the uniform"),
    ],
)
def test_a_dropped_or_doubled_sample_is_refused_naming_the_row(damage, message):
    with pytest.raises(UserInputError, match=rf"^log\.csv: column time_s: {message}"):
        uniform_grid(damage(np.round(_jittered(EXACT_TIME_S), 7)), "log.csv: column time_s")


def test_a_jittered_time_column_gives_the_same_model():
    log = read_flight_log(CSV_PATH)
    jittered = log.copy()
    jitter = np.random.default_rng(3).normal(0.0, 0.05 * 0.02, len(log))  # 5 % of 50 Hz
    jittered["time_sec"] = np.round(log["time_sec"] + jitter, 7)
    model = load_model("twin_otter_short_period")
    exact, from_jittered = identify(model, log), identify(model, jittered)
    for name, estimate in exact.parameters.items():
        # only the interval changes: by the slope's standard error over 376 samples, 2.4e-5 of
        # it (5 % x sqrt(12 / 376^3)); the estimates move by as much, far below 0.01 sigma
        assert from_jittered.parameters[name].value == pytest.approx(
            estimate.value, abs=0.01 * estimate.sigma
        )


def test_parquet_log_identifies_like_the_csv(tmp_path):
    log = read_flight_log(CSV_PATH)
    path = tmp_path / "flight.parquet"
    log.to_parquet(path)
    from_parquet = read_flight_log(path)
    pd.testing.assert_frame_equal(from_parquet, log)
    model = load_model("twin_otter_short_period")
    # the same float64 numbers in: the same estimates, to the last bit
    np.testing.assert_array_equal(
        identify(model, from_parquet).parameter_vector(), identify(model, log).parameter_vector()
    )


def test_mat_struct_of_channels_gives_the_csv_columns(tmp_path):
    log = read_flight_log(CSV_PATH)
    path = tmp_path / "struct.mat"
    channels = {name: log[name].to_numpy() for name in log.columns}
    scipy.io.savemat(path, {"log": {**channels, "tail": "S3", "mass_kg": 0.0234}})
    # float64 written and read back: exact; scalars and strings are not channels
    pd.testing.assert_frame_equal(read_flight_log(path), log)


def test_mat_struct_array_of_one_element_and_nested_structs(tmp_path):
    time_s = np.arange(6) / RATE_HZ
    record = np.empty((1, 1), dtype=[("time_s", object), ("imu", object), ("ekf", object)])
    record[0, 0]["time_s"] = time_s
    record[0, 0]["imu"] = {"q": np.full(6, 1.0), "ax_m_s2": np.full(6, 2.0)}
    record[0, 0]["ekf"] = {"q": np.full(6, 3.0), "theta_rad": np.full(6, 4.0), "note": "x"}
    path = tmp_path / "nested.mat"
    scipy.io.savemat(path, {"flight": record})
    log = read_flight_log(path)
    # field names, with the parent's name where a name occurs twice
    assert list(log.columns) == ["time_s", "imu_q", "ax_m_s2", "ekf_q", "theta_rad"]
    assert log["ekf_q"].tolist() == [3.0] * 6 and log["time_s"].tolist() == time_s.tolist()


@pytest.mark.parametrize(
    ("contents", "where", "problem"),
    [
        (
            {"log": np.array([{"q": np.ones(4)}, {"q": np.ones(4)}], dtype=object)},
            "log",
            "is a struct array of 2 elements",
        ),
        ({"log": {"a": {"b": {"q": np.ones(4)}}}}, "log.a.b", "nest more than 1 level deep"),
        (
            {"log": {"imu": {"q": np.ones(4)}}, "imu": {"q": np.ones(4)}},
            "log.imu.q and imu.q",
            "both become column imu_q",
        ),
        ({"log": {"tail": "S3", "mass_kg": 0.0234}}, "", "no fdata matrix and no numeric"),
    ],
)
def test_unusable_mat_structs_are_refused_naming_the_field(tmp_path, contents, where, problem):
    path = tmp_path / "bad.mat"
    scipy.io.savemat(path, contents)
    with pytest.raises(UserInputError, match=problem) as refusal:
        read_flight_log(path)
    assert refusal.value.where == (f"{path}: {where}" if where else str(path))
