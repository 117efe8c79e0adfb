"""``ornitail runs --plot RUN --out DIR``: a run's signals in N, N m, m/s, degC, Hz and deg, PNG and PDF."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    ChannelSpec,
    RunConfiguration,
    SetPointRecord,
    StreamLayout,
)
from ornitail.acquisition.recording_reader import load_recording
from ornitail.app.cli import main
from ornitail.balance.run_signal_plots import binned, run_signals, run_signals_figure
from ornitail.calibration.signal_channels import TUNNEL_SIGNAL_CHANNELS
from ornitail.simulated_instruments.rig_instruments import simulated_hotwire_law

REPOSITORY = Path(__file__).resolve().parents[2]
CALIBRATION_FILE = REPOSITORY / "tests" / "data" / "calibration" / "FT8884.cal"
RATE_HZ = 2000.0
FLAP_HZ = 12.0


def _samples(counters: np.ndarray, flapping: bool) -> np.ndarray:
    time_s = counters / RATE_HZ
    columns = {
        name: 0.01 * np.sin(time_s + index) for index, name in enumerate(TUNNEL_SIGNAL_CHANNELS)
    }
    if flapping:
        columns["gauge_2_v"] = columns["gauge_2_v"] + 0.2 * np.sin(2 * np.pi * FLAP_HZ * time_s)
    columns["hotwire_bridge_v"] = np.full_like(time_s, 2.0 if flapping else 1.6)
    columns["thermocouple_v"] = np.full_like(time_s, 1.25 + 0.005 * 21.0)  # 21 degC
    phase = (FLAP_HZ * time_s) % 1.0
    columns["hall_v"] = np.where(flapping & (phase < 0.2), 3.3, 0.0)
    return np.column_stack([columns[name] for name in TUNNEL_SIGNAL_CHANNELS])


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory) -> tuple[Path, Path]:
    data_root = tmp_path_factory.mktemp("data")
    layout = StreamLayout([ChannelSpec(name, "V") for name in TUNNEL_SIGNAL_CHANNELS], RATE_HZ)
    configuration = RunConfiguration(tail_id="S3", x_h_m=0.098, tailed=True, plan_name="pictures")
    with Recorder(
        data_root,
        configuration,
        layout,
        calibration_files={"balance": CALIBRATION_FILE},
    ) as recorder:
        for block in range(6):  # 1 s of tare, then 2 s flapping
            counters = np.arange(block * 1000, (block + 1) * 1000)
            recorder.put_block(counters, _samples(counters, flapping=block >= 2))
        pitch = math.radians(25.0)
        recorder.complete_set_point(SetPointRecord(0, "tare", 0, 1999, pitch, 0.0, 0.0, True))
        recorder.complete_set_point(
            SetPointRecord(
                1,
                "measurement",
                2000,
                5999,
                pitch,
                0.8,
                FLAP_HZ,
                True,
                extra={"tunnel_velocity_mean_m_s": 0.79, "pitch_mean_rad": pitch},
            )
        )
    return data_root, recorder.run_directory


def test_runs_plot_writes_png_and_pdf_and_lists_them(recorded_run, tmp_path):
    data_root, run_directory = recorded_run
    run_id = run_directory.name
    arguments = ["runs", "--data-root", str(data_root), "--plot", run_id, "--out", str(tmp_path)]
    result = CliRunner().invoke(main, [*arguments, "--json"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    pictures = [tmp_path / f"signals_{run_id}.{suffix}" for suffix in ("png", "pdf")]
    assert record["written"] == [str(path) for path in pictures]
    assert record["set_points"] == 2 and all(path.stat().st_size > 0 for path in pictures)
    text = CliRunner().invoke(main, ["runs", "--plot", str(run_directory), "--out", str(tmp_path)])
    assert text.exit_code == 0, text.output
    assert f"wrote {pictures[0]}" in text.stdout


def test_the_figure_labels_every_quantity_with_its_unit(recorded_run):
    _, run_directory = recorded_run
    signals = run_signals(load_recording(run_directory))
    assert signals.tare_corrected and not signals.hotwire_in_m_s
    np.testing.assert_allclose(
        signals.cycle_frequency_hz, FLAP_HZ, rtol=5e-3
    )  # a step edge: +-1 sample
    np.testing.assert_allclose(signals.temperature_c.mean, 21.0, atol=1e-6)
    labels = [axis.get_ylabel() for axis in run_signals_figure(signals).axes]
    assert labels == [
        "force (N)",
        "moment (N m)",
        "flow velocity (m/s)",
        "hot-wire bridge (V)",
        "flow temperature (degC)",
        "flapping frequency (Hz)",
        "pitch theta (deg)",
    ]


def test_a_hotwire_law_draws_the_hot_wire_in_metres_per_second(recorded_run, tmp_path):
    _, run_directory = recorded_run
    signals = run_signals(load_recording(run_directory), hotwire_law=simulated_hotwire_law())
    figure = run_signals_figure(signals)
    assert "hot-wire velocity" in figure.axes[2].get_legend_handles_labels()[1]
    assert "hot-wire bridge (V)" not in [axis.get_ylabel() for axis in figure.axes]
    assert figure.axes[-1].get_xlabel() == "time from the run's first sample (s)"


def test_binning_keeps_the_extremes():
    time_s = np.arange(10_001) / 1000.0
    values = np.sin(2 * np.pi * 13.0 * time_s)
    trace = binned(time_s, values, bins=100)
    assert len(trace.mean) <= 101
    assert trace.high.max() == values.max() and trace.low.min() == values.min()


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--plot", "no-such-run", "--out", "{tmp}"], "--plot"),
        (["--plot", "x"], "--out"),
        (["--out", "{tmp}"], "--out"),
    ],
)
def test_bad_plot_options_are_one_line(recorded_run, tmp_path, extra, fragment):
    data_root, _ = recorded_run
    arguments = [item.replace("{tmp}", str(tmp_path)) for item in extra]
    result = CliRunner().invoke(main, ["runs", "--data-root", str(data_root), *arguments])
    assert result.exit_code == 2
    assert fragment in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_a_stretch_without_samples_breaks_the_line():
    from ornitail.balance.run_signal_plots import _with_gaps_broken

    time_s = np.concatenate([np.arange(100) / 100.0, 5.0 + np.arange(100) / 100.0])
    trace = _with_gaps_broken(binned(time_s, np.ones(200), bins=200))
    assert np.isnan(trace.mean).sum() == 1 and 0.99 < trace.time_s[100] < 5.0
