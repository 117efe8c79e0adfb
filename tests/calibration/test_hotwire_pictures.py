"""``ornitail calibration hotwire-fit --out LAW``: the fit's picture beside the law, axes with units."""

import json
from pathlib import Path

from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.calibration.hotwire_fit import fit_kings_law
from ornitail.calibration.hotwire_plots import hotwire_fit_figure
from ornitail.calibration.hotwire_points import read_hotwire_points

POINTS = Path(__file__).resolve().parents[2] / "calibration" / "data" / "example_hotwire_points.csv"


def test_out_writes_the_law_and_its_picture_and_lists_them(tmp_path) -> None:
    law = tmp_path / "probe.toml"
    arguments = ["calibration", "hotwire-fit", "--points", str(POINTS), "--out", str(law)]
    result = CliRunner().invoke(main, [*arguments, "--json"])
    assert result.exit_code == 0, result.output
    values = json.loads(result.stdout)
    pictures = [tmp_path / "probe_fit.png", tmp_path / "probe_fit.pdf"]
    assert values["written"] == [str(law), *map(str, pictures)]
    assert all(path.stat().st_size > 0 for path in pictures)
    text = CliRunner().invoke(main, [*arguments, "--law", "polynomial"])
    assert text.exit_code == 0 and f"picture: {pictures[0]}" in text.stdout


def test_without_out_nothing_is_written(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(
        main, ["calibration", "hotwire-fit", "--points", str(POINTS), "--json"]
    )
    assert result.exit_code == 0 and json.loads(result.stdout)["written"] == []
    assert not list(tmp_path.iterdir())


def test_the_figure_labels_velocity_voltage_and_residual_units() -> None:
    points = read_hotwire_points(POINTS)
    figure = hotwire_fit_figure(fit_kings_law(points, 250.0 + 273.15), points)
    law_axis, residual_axis = figure.axes
    assert law_axis.get_ylabel() == "flow velocity U (m/s)"
    assert law_axis.get_xlabel().endswith("E_corr (V)") and "degC" in law_axis.get_xlabel()
    assert residual_axis.get_xlabel() == "measured velocity U (m/s)"
    assert residual_axis.get_ylabel() == "residual, fitted - measured (m/s)"
    assert "king law" in figure.texts[0].get_text()
