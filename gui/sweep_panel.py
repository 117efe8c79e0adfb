"""Sweep controls: a plan file, Run / Pause / Resume / Abort, progress with ETA (from the run documents) and the
current set point."""

from __future__ import annotations

from pathlib import Path

from PySide6 import QtWidgets

from ornitail.acquisition.run_documents import PlanProgress
from ornitail.acquisition.sweep import SweepEvent, SweepResult
from ornitail.gui.form_widgets import FilePicker
from ornitail.gui.rig_session import RigSession

STUDY_PLAN = Path(__file__).resolve().parents[1] / "acquisition" / "data" / "study_tunnel_plan.toml"


def format_eta(seconds: float, time_scale: float) -> str:
    """Wall-clock time left as ``m:ss`` (rig seconds divided by the simulated time scale)."""
    wall = max(0.0, seconds / time_scale)
    return f"{int(wall // 60)}:{int(wall % 60):02d}"


class SweepPanel(QtWidgets.QGroupBox):
    """Runs a plan through :class:`RigSession`; :meth:`show_progress` (from the run documents),
    :meth:`show_event` (the point under way) and :meth:`show_done` update what it shows."""

    def __init__(self, session: RigSession, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__("Sweep plan", parent)
        self.session = session
        form = QtWidgets.QFormLayout(self)
        self.plan_file = FilePicker(STUDY_PLAN, "Sweep plan", "Plans (*.toml)")
        self.run_button = QtWidgets.QPushButton("Run")
        self.pause_button = QtWidgets.QPushButton("Pause")
        self.pause_button.setToolTip("Finish the current set point, then stop; Resume continues")
        self.resume_button = QtWidgets.QPushButton("Resume")
        self.abort_button = QtWidgets.QPushButton("Abort")
        self.abort_button.setToolTip("Stop now; recorded set points stay, Resume continues")
        buttons = QtWidgets.QHBoxLayout()
        for button in (self.run_button, self.pause_button, self.resume_button, self.abort_button):
            buttons.addWidget(button)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setFormat("%v / %m set points")
        self.eta = QtWidgets.QLabel("ETA -")
        self.current = QtWidgets.QLabel("-")
        self.current.setWordWrap(True)
        form.addRow("plan", self.plan_file)
        form.addRow(buttons)
        form.addRow(self.progress)
        form.addRow(self.eta)
        form.addRow(self.current)
        self.run_button.clicked.connect(lambda: session.start_sweep(self.plan_file.path))
        self.resume_button.clicked.connect(lambda: session.start_sweep(self.plan_file.path, True))
        self.pause_button.clicked.connect(session.pause_sweep)
        self.abort_button.clicked.connect(session.abort_sweep)
        self.last_result: SweepResult | None = None

    def show_progress(self, progress: PlanProgress) -> None:
        """Progress bar and ETA as a run document of the sweep says them."""
        self.progress.setRange(0, progress.total)
        self.progress.setValue(progress.done)
        rig = self.session.rig
        scale = rig.time_scale if rig is not None else 1.0
        self.eta.setText(f"ETA {format_eta(progress.eta_s, scale)} (m:ss)")

    def show_event(self, event: SweepEvent) -> None:
        """The point being worked on (moving, settled, recorded) or the tail change."""
        if event.set_point is not None:
            self.current.setText(f"{event.stage}: {event.set_point.label}")
        else:
            self.current.setText(event.stage.replace("_", " "))

    def show_done(self, result: SweepResult) -> None:
        """The sweep's end: status and how far it got."""
        self.last_result = result
        self.progress.setRange(0, max(1, result.total_points))
        self.progress.setValue(result.completed_points)
        self.eta.setText("ETA -")
        self.current.setText(f"{result.status}: {result.message}")

    def refresh(self) -> None:
        """Enable the buttons that make sense now."""
        running = self.session.sweep_running
        connected = self.session.connected
        self.run_button.setEnabled(connected and not running)
        self.resume_button.setEnabled(connected and not running)
        self.pause_button.setEnabled(running)
        self.abort_button.setEnabled(running)
