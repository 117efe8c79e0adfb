"""``ornitail sim trim --out DIR``: the pole map, PNG and PDF, listed in text and JSON, axes with units."""

import json

from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.sim.trim_plots import pole_map_figure


def test_trim_out_writes_the_pole_map_and_lists_it(tmp_path) -> None:
    out = tmp_path / "trim"
    arguments = ["sim", "trim", "--tail", "S3", "--out", str(out)]
    result = CliRunner().invoke(main, [*arguments, "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["written"] == [str(out / "trim_poles.png"), str(out / "trim_poles.pdf")]
    assert all((out / name).stat().st_size > 0 for name in ("trim_poles.png", "trim_poles.pdf"))
    text = CliRunner().invoke(main, arguments)
    assert text.exit_code == 0 and f"wrote {out / 'trim_poles.png'}" in text.output


def test_trim_without_out_writes_nothing(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["sim", "trim", "--tail", "S3", "--json"])
    assert result.exit_code == 0 and "written" not in json.loads(result.output)
    assert not list(tmp_path.iterdir())


def test_pole_map_axes_carry_units_and_the_title_names_the_mode() -> None:
    figure = pole_map_figure([-1 + 2j, -1 - 2j, -5.0, -0.2], 0.447, 2.236, "tail S3 at x_h 98 mm")
    (axis,) = figure.axes
    assert axis.get_xlabel() == "real part (1/s), negative: decaying"
    assert axis.get_ylabel() == "imaginary part, damped frequency (rad/s)"
    assert "tail S3 at x_h 98 mm" in axis.get_title() and "zeta 0.447" in axis.get_title()


def test_an_out_path_that_is_a_file_is_one_line(tmp_path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    result = CliRunner().invoke(main, ["sim", "trim", "--tail", "S3", "--out", str(blocker)])
    assert result.exit_code == 2
    assert "a-file" in result.stderr and len(result.stderr.strip().splitlines()) == 1
