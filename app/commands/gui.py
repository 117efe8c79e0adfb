"""``ornitail gui``: open the window at the tunnel."""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import click

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory


def check_gui_options(
    data_root: Path | None, rig_file: Path | None, time_scale: float | None
) -> None:
    """Refuse bad options before any window opens: time scale, data root folder, rig file."""
    from ornitail.acquisition.rig_file import read_rig_file  # numpy, pyserial: not for --help

    if time_scale is not None and not (math.isfinite(time_scale) and time_scale > 0):
        raise UserInputError("--time-scale", f"{time_scale!r} must be a finite number > 0")
    if data_root is not None:
        prepare_output_directory(data_root)
    if rig_file is not None:
        read_rig_file(rig_file)


@click.command("gui")
@click.option(
    "--data-root",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Where runs and the catalog go (default: ornitail's data root).",
)
@click.option(
    "--rig",
    "rig_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Connect this rig file at start (default: connect by hand; the simulated rig is preselected).",
)
@click.option(
    "--time-scale", type=float, default=None, help="Simulated rigs only: simulated s per wall s."
)
def gui_command(data_root: Path | None, rig_file: Path | None, time_scale: float | None) -> None:
    """Open the desktop window: live view, cycle view, controls, sweeps, runs and design."""
    check_gui_options(data_root, rig_file, time_scale)
    if sys.platform.startswith("linux") and not any(
        os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")
    ):
        raise UserInputError(
            "display",
            "no screen to open the window on: DISPLAY and WAYLAND_DISPLAY are unset "
            "(run it on the desktop, under xvfb-run, or with QT_QPA_PLATFORM=offscreen)",
        )
    try:
        from PySide6 import QtWidgets

        from ornitail.gui.main_window import MainWindow
        from ornitail.gui.rig_session import RigSession
    except ImportError as error:
        raise click.ClickException(
            f"the GUI needs its extra: pip install 'ornitail[gui]' ({error})"
        ) from None
    application = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv)
    window = MainWindow(RigSession(data_root))
    if rig_file is not None:
        window.controls.rig_file.edit.setText(str(rig_file))
        window.session.connect(rig_file, time_scale)
    if time_scale is not None:
        window.controls.time_scale.setValue(time_scale)
    window.resize(1500, 950)
    window.show()
    sys.exit(application.exec())
