"""``ornitail gap diagnose --out``: the flight overlay (data, baseline, corrected) and labelled bar charts."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.gap.plots import flight_overlay_figure, localisation_figure, ranking_figure


@pytest.fixture(scope="module")
def flight_report(write_gap_example, tmp_path_factory):
    # 8 manoeuvres: enough for the nested split (6 at least) and every picture, half the diagnosis time
    example = write_gap_example("flight", "added_mass", "--manoeuvres", "8")
    out = tmp_path_factory.mktemp("flight-report")
    arguments = ["gap", "diagnose", "--model", example["model"], "--data", example["data"]]
    result = CliRunner().invoke(main, [*arguments, "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    return out, json.loads(result.stdout), result.stderr


def test_flight_diagnosis_writes_and_lists_the_overlay(flight_report):
    out, report, _ = flight_report
    for name in ("flight_overlay", "localisation", "ranking", "residual_spectra"):
        for suffix in ("png", "pdf"):
            assert (out / f"{name}.{suffix}").stat().st_size > 0
            assert str(out / f"{name}.{suffix}") in report["written"]


def test_bar_charts_carry_axis_labels_with_units(flight_report):
    _, report, _ = flight_report
    for axis in localisation_figure(report["where"]).axes:
        assert axis.get_xlabel() and axis.get_ylabel().endswith("(-)")
    (axis,) = ranking_figure(report).axes
    assert axis.get_ylabel() == "candidate effect"
    assert axis.get_xlabel().endswith("(-)")
    # the detection rule's two bars, dashed for the closure and dotted for the lower bound
    rule = report["detection_rule"]
    bars = {
        line.get_linestyle(): line.get_xdata()[0]
        for line in axis.get_lines()
        if line.get_label()[0] != "_"
    }
    assert bars == {"--": rule["threshold"], ":": rule["lower_bound_threshold"]}
    # each candidate's simultaneous lower bound, the value held to the dotted bar, as a tick
    (ticks,) = axis.collections[-1:]
    np.testing.assert_allclose(
        ticks.get_offsets()[:, 0],
        [entry["simultaneous_lower_bound"] for entry in report["ranking"]],
    )


def test_a_diagnosis_in_a_log_ends_with_a_timestamped_progress_line(flight_report):
    # stderr is not a terminal here: progress comes as lines, the last one at the final step (issue 18)
    from ornitail.app.progress import PROGRESS_LINE

    _, _, stderr = flight_report
    lines = [line for line in stderr.splitlines() if PROGRESS_LINE.match(line)]
    assert lines and "gap diagnose:" in lines[-1] and "localised and reported" in lines[-1]
    done, total = lines[-1].split(": ", 1)[1].split(" ", 1)[0].split("/")
    assert done == total


def test_overlay_axes_name_quantity_and_unit_in_degrees_at_the_edge():
    import numpy as np

    time_s = np.linspace(0.0, 2.0, 50)
    states = np.zeros((50, 4))
    figure = flight_overlay_figure(time_s, states, states, states, "run 1", "added_mass")
    labels = [axis.get_ylabel() for axis in figure.axes]
    assert labels == [
        "pitch rate q (deg/s)",
        "body velocity u (m/s)",
        "body velocity w (m/s)",
        "pitch attitude theta (deg)",
    ]
    assert figure.axes[-1].get_xlabel() == "time from the run's start (s)"
    assert "run run 1" in figure.texts[0].get_text()
    handles = [line.get_label() for line in figure.axes[0].get_lines()]
    assert handles == ["data", "baseline", "corrected (+ added_mass)"]


def test_tunnel_localisation_names_the_configuration_axis():
    where = {
        "by_channel": {
            "X": {"energy_share": 0.5},
            "Z": {"energy_share": 0.3},
            "M": {"energy_share": 0.2},
        },
        "by_band": [],
        "by_configuration": {
            "x_h_mm": {"varies": True, "per_load": {"X": {"correlation": -0.4}}},
            "tail": {"varies": False, "per_load": {"X": {"correlation": 0.0}}},
        },
        "by_segment": {"theta_sweep": {"energy_share": 1.0}},
    }
    channel, configuration, segment = localisation_figure(where).axes
    assert configuration.get_xlabel() == "configuration variable"
    assert configuration.get_ylabel() == "largest |correlation| with a load (-)"
    assert channel.get_ylabel() == segment.get_ylabel() == "share of residual energy (-)"
