"""``ornitail export``: a processed table and a short recording to .mat, Parquet and NetCDF, read back with units."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import scipy.io
import xarray as xr
from click.testing import CliRunner

from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.app.cli import main
from ornitail.app.export import unit_from_column_name

CALIBRATION_FILE = Path(__file__).parent / "data" / "calibration" / "FT8884.cal"


@pytest.mark.parametrize(
    ("name", "unit"),
    [
        ("x_n", "N"),
        ("m_n_m", "N m"),
        ("m_n_m_tare_terms_se", "N m"),
        ("x_n_2sigma", "N"),
        ("v_measured_m_s_tailed", "m/s"),
        ("theta_deg", "deg"),
        ("pitch_rad", "rad"),
        ("f_set_hz", "Hz"),
        ("x_h_mm", "mm"),
        ("x_h_m", "m"),
        ("settle_time_s", "s"),
        ("mass_kg", "kg"),
        ("iyy_kg_m2", "kg m^2"),
        ("natural_frequency_rad_s", "rad/s"),
        ("pole0_real_1_s", "1/s"),
        ("motor_rpm_mean", "rpm"),
        ("x_n_phase_std", None),  # "phase" is not a unit-keeping qualifier: the name says no unit
        ("x_n_repeat_inflation_tailed", None),
        ("x_n_resolvable", None),
        ("cycles_tailed", None),
        ("tare_terms", None),
        ("run_id", None),
        ("s", None),  # a unit alone names no quantity
        ("Xu", None),
    ],
)
def test_unit_from_column_name(name, unit):
    assert unit_from_column_name(name) == unit


def small_processed_table(path: Path) -> pd.DataFrame:
    table = pd.DataFrame(
        {
            "run_id": ["r1", "r1", "r2"],
            "tailed": [True, True, False],
            "theta_deg": [25.0, 28.0, 25.0],
            "v_m_s": [0.8, 0.8, 0.8],
            "x_n": [0.0741, 0.0752, 0.0677],
            "m_n_m_2sigma": [1.2e-5, 1.3e-5, 1.1e-5],
            "drift_check": [
                "Drift fit (r1): 2 tares",
                "",
                "",
            ],  # empty cells, as ornitail process writes them
            "cycles": [26, 27, 25],
        }
    )
    table.to_csv(path, index=False)
    return table


def short_recording(data_root: Path) -> Path:
    channels = [ChannelSpec("gauge_0", "V"), ChannelSpec("hall_sensor", "V")]
    layout = StreamLayout(channels, sample_rate_hz=1000.0, counter_dtype="uint32")
    configuration = RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="export")
    with Recorder(
        data_root,
        configuration,
        layout,
        rig_description={"daq": "simulated"},
        calibration_files={"balance": CALIBRATION_FILE},
    ) as recorder:
        counters = np.arange(200, dtype=np.uint32)
        recorder.put_block(
            counters, np.column_stack([np.sin(counters * 0.1), np.cos(counters * 0.1)])
        )
        recorder.complete_set_point(
            SetPointRecord(0, "tare", 0, 99, math.radians(25.0), 0.0, 0.0, True)
        )
        recorder.complete_set_point(
            SetPointRecord(
                1, "measurement", 100, 199, math.radians(25.0), 0.8, 13.5, True, motor_rpm_mean=None
            )
        )
    return recorder.run_directory


def export(*arguments) -> list[Path]:
    result = CliRunner().invoke(main, ["export", *map(str, arguments), "--json"])
    assert result.exit_code == 0, result.output
    return [Path(path) for path in json.loads(result.stdout)["written"]]


@pytest.fixture
def inputs(tmp_path):
    table_path = tmp_path / "cycle-averages.csv"
    table = small_processed_table(table_path)
    run_directory = short_recording(tmp_path / "data")
    return table_path, table, run_directory


def test_mat_export_holds_the_values_and_a_units_struct(inputs, tmp_path):
    table_path, table, run_directory = inputs
    written = export(table_path, run_directory, "--format", "mat", "--out", tmp_path / "out")
    assert [path.name for path in written] == ["cycle-averages.mat", f"{run_directory.name}.mat"]
    loaded = scipy.io.loadmat(written[0], squeeze_me=True, simplify_cells=True)["cycle_averages"]
    np.testing.assert_array_equal(loaded["x_n"], table["x_n"])
    np.testing.assert_array_equal(loaded["cycles"], table["cycles"])
    assert list(loaded["run_id"]) == ["r1", "r1", "r2"]
    assert loaded["units"]["x_n"] == "N" and loaded["units"]["m_n_m_2sigma"] == "N m"
    assert len(loaded["units"]["cycles"]) == 0  # no unit in the name: empty text

    recording = scipy.io.loadmat(written[1], squeeze_me=True, simplify_cells=True)
    samples, set_points = recording["samples"], recording["set_points"]
    np.testing.assert_array_equal(samples["sample_counter"], np.arange(200))
    np.testing.assert_allclose(samples["gauge_0"], np.sin(np.arange(200) * 0.1), rtol=0, atol=0)
    assert samples["units"]["gauge_0"] == "V" and samples["units"]["time_s"] == "s"
    assert samples["attributes"]["sample_rate_hz"] == 1000.0
    np.testing.assert_array_equal(set_points["first_sample_index"], [0, 100])
    assert set_points["units"]["pitch_rad"] == "rad"
    assert np.isnan(set_points["motor_rpm_mean"]).all()


def test_parquet_export_holds_the_values_and_units_in_the_field_metadata(inputs, tmp_path):
    table_path, table, run_directory = inputs
    written = export(table_path, run_directory, "--format", "parquet", "--out", tmp_path / "out")
    assert [path.name for path in written] == [
        "cycle-averages.parquet",
        f"{run_directory.name}-samples.parquet",
        f"{run_directory.name}-set_points.parquet",
    ]
    read = pq.read_table(written[0])
    pd.testing.assert_frame_equal(read.to_pandas(), table.fillna(""), check_dtype=False)
    assert read.schema.field("v_m_s").metadata == {b"units": b"m/s"}
    assert read.schema.field("cycles").metadata is None
    samples = pq.read_table(written[1])
    np.testing.assert_array_equal(
        samples.column("hall_sensor").to_numpy(), np.cos(np.arange(200) * 0.1)
    )
    assert samples.schema.field("sample_counter").metadata == {b"units": b"count"}
    assert samples.schema.metadata[b"run_id"].decode() == run_directory.name
    set_points = pq.read_table(written[2])
    assert set_points.column("kind").to_pylist() == ["tare", "measurement"]
    assert set_points.schema.field("tunnel_velocity_m_s").metadata == {b"units": b"m/s"}


def test_netcdf_export_holds_the_values_and_units_as_attributes(inputs, tmp_path):
    table_path, table, run_directory = inputs
    written = export(table_path, run_directory, "--format", "netcdf", "--out", tmp_path / "out")
    with xr.open_dataset(written[0], engine="h5netcdf") as dataset:
        np.testing.assert_array_equal(dataset["x_n"].values, table["x_n"])
        np.testing.assert_array_equal(dataset["tailed"].values, table["tailed"])
        assert list(dataset["drift_check"].values) == ["Drift fit (r1): 2 tares", "", ""]
        assert dataset["theta_deg"].attrs["units"] == "deg"
        assert "units" not in dataset["cycles"].attrs
    with xr.open_dataset(written[1], engine="h5netcdf", group="samples") as samples:
        np.testing.assert_array_equal(samples["time_s"].values, np.arange(200) / 1000.0)
        assert samples["gauge_0"].attrs["units"] == "V"
        assert samples.attrs["run_id"] == run_directory.name
    with xr.open_dataset(written[1], engine="h5netcdf", group="set_points") as set_points:
        np.testing.assert_array_equal(set_points["last_sample_index"].values, [99, 199])
        assert set_points["flapping_frequency_hz"].attrs["units"] == "Hz"


def test_export_refuses_what_is_not_a_table_or_recording_in_one_line(tmp_path):
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "folder").mkdir()
    for bad, expected in (
        (tmp_path / "notes.txt", "not a run directory or a CSV table"),
        (tmp_path / "folder", "run.json: file not found"),
        (tmp_path / "missing.csv", "file not found"),
    ):
        result = CliRunner().invoke(
            main, ["export", str(bad), "--format", "mat", "--out", str(tmp_path / "o")]
        )
        assert result.exit_code == 2
        assert result.stderr.count("\n") == 1 and expected in result.stderr, result.stderr
