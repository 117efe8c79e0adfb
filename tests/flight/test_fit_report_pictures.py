"""``ornitail flight identify --out``: measured vs model and residual pictures, named in the text, axes with
units (the log column's unit is in its name)."""

from pathlib import Path

import numpy as np
from click.testing import CliRunner

from ornitail.app.commands.flight import flight_group
from ornitail.flight.fit_report_files import compare_figure, residuals_figure

CSV_PATH = str(Path(__file__).parents[1] / "data" / "twin-otter" / "twin_otter_020213f1_019.csv")


def test_identify_text_names_every_written_file(tmp_path):
    arguments = ["identify", "--model", "twin_otter_short_period", "--data", CSV_PATH]
    result = CliRunner().invoke(flight_group, [*arguments, "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    for name in ("compare.png", "compare.pdf", "residuals.png", "residuals.pdf"):
        assert (tmp_path / name).stat().st_size > 0 and name in result.output


def test_compare_and_residual_figures_label_time_and_output_units():
    time_s = np.linspace(0.0, 10.0, 101)
    values = np.column_stack([np.sin(time_s), np.cos(time_s)])
    labels = {"alpha": "alpha (alpha_deg)", "q": "q (q_deg_s)"}
    figure = compare_figure(time_s, values, values * 0.9, labels, {"alpha": 0.9, "q": 0.8})
    assert [axis.get_ylabel() for axis in figure.axes] == list(labels.values())
    assert figure.axes[-1].get_xlabel() == "time from the log's start [s]"
    assert figure.axes[0].get_title().startswith("alpha: fit (1 - NRMSE) 0.900")
    residuals = residuals_figure(time_s, values * 0.1, labels)
    assert [axis.get_ylabel() for axis in residuals.axes] == list(labels.values())
    assert "measured - model" in residuals.texts[0].get_text()
