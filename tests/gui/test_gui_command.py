"""``ornitail gui`` without a screen: one line naming what is missing, exit code 2, no Qt abort."""

from click.testing import CliRunner

from ornitail.app.cli import main


def test_gui_without_a_display_says_so_in_one_line():
    no_screen = {"DISPLAY": None, "WAYLAND_DISPLAY": None, "QT_QPA_PLATFORM": None}
    result = CliRunner().invoke(main, ["gui"], env=no_screen)
    assert result.exit_code == 2
    (line,) = result.output.strip().splitlines()
    assert line.startswith("ornitail: error: display:") and "xvfb-run" in line
