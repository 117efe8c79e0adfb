"""The tunnel controls: connect a rig file, set pitch / tunnel speed / flapping frequency within the rig's limits,
wind-off tare, and manual recording with its metadata form (tail id, x_h, tailed)."""

from __future__ import annotations

import math

from PySide6 import QtWidgets

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.gui.form_widgets import FilePicker, spin_box
from ornitail.gui.rig_session import RigSession


class ControlsPanel(QtWidgets.QWidget):
    """Buttons that call :class:`RigSession`; the set-point ranges follow the connected rig's limits."""

    def __init__(self, session: RigSession, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.session = session
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self._connection_box())
        layout.addWidget(self._set_point_box())
        layout.addWidget(self._recording_box())
        layout.addStretch(1)
        self.set_rig_limits()

    # -- connection -------------------------------------------------------------------------
    def _connection_box(self) -> QtWidgets.QGroupBox:
        box = QtWidgets.QGroupBox("Rig")
        form = QtWidgets.QFormLayout(box)
        self.rig_file = FilePicker(DEFAULT_RIG_FILE, "Rig file", "Rig files (*.toml)")
        self.time_scale = spin_box(0.1, 50.0, 1.0, 1, "x")
        self.time_scale.setToolTip("Simulated rigs only: simulated seconds per wall second")
        self.connect_button = QtWidgets.QPushButton("Connect")
        self.disconnect_button = QtWidgets.QPushButton("Disconnect")
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(self.connect_button)
        buttons.addWidget(self.disconnect_button)
        form.addRow("rig file", self.rig_file)
        form.addRow("simulated time scale", self.time_scale)
        form.addRow(buttons)
        self.connect_button.clicked.connect(
            lambda: self.session.connect(self.rig_file.path, self.time_scale.value())
        )
        self.disconnect_button.clicked.connect(self.session.disconnect)
        return box

    # -- set points -------------------------------------------------------------------------
    def _set_point_box(self) -> QtWidgets.QGroupBox:
        box = QtWidgets.QGroupBox("Set points (within the rig's limits)")
        grid = QtWidgets.QGridLayout(box)
        self.pitch = spin_box(-10.0, 45.0, 25.0, 2, "deg")
        self.velocity = spin_box(0.0, 6.0, 0.8, 3, "m/s")
        self.frequency = spin_box(0.0, 16.0, 13.5, 2, "Hz")
        self.set_buttons = {}
        rows = (
            ("pitch", self.pitch, self.session.set_pitch_deg),
            ("tunnel speed", self.velocity, self.session.set_tunnel_velocity),
            ("flapping frequency", self.frequency, self.session.set_flapping_frequency),
        )
        for row, (name, box_widget, action) in enumerate(rows):
            button = QtWidgets.QPushButton(f"Set {name}")
            button.clicked.connect(lambda _=False, b=box_widget, a=action: a(b.value()))
            grid.addWidget(QtWidgets.QLabel(name), row, 0)
            grid.addWidget(box_widget, row, 1)
            grid.addWidget(button, row, 2)
            self.set_buttons[name] = button
        self.record_s = spin_box(0.1, 60.0, 2.0, 1, "s")
        self.tare_button = QtWidgets.QPushButton("Wind-off tare at current pitch")
        self.tare_button.setToolTip("Stops fan and motor, waits for rest, averages the gauges")
        self.tare_button.clicked.connect(lambda: self.session.tare(self.record_s.value()))
        grid.addWidget(QtWidgets.QLabel("record length"), 3, 0)
        grid.addWidget(self.record_s, 3, 1)
        grid.addWidget(self.tare_button, 4, 0, 1, 3)
        return box

    def set_rig_limits(self) -> None:
        """Limit the spin boxes to the connected rig's limits (or the defaults before connecting)."""
        rig = self.session.rig
        if rig is None:
            return
        limits = rig.description.limits
        self.pitch.setRange(math.degrees(limits.pitch_min_rad), math.degrees(limits.pitch_max_rad))
        self.velocity.setRange(limits.velocity_min_m_s, limits.velocity_max_m_s)
        self.frequency.setRange(limits.flapping_frequency_min_hz, limits.flapping_frequency_max_hz)

    # -- recording --------------------------------------------------------------------------
    def _recording_box(self) -> QtWidgets.QGroupBox:
        box = QtWidgets.QGroupBox("Manual recording")
        form = QtWidgets.QFormLayout(box)
        self.tail_id = QtWidgets.QLineEdit("S3")
        self.x_h_mm = spin_box(1.0, 500.0, 98.0, 1, "mm")
        self.tailed = QtWidgets.QCheckBox("tail fitted")
        self.tailed.setChecked(True)
        self.start_button = QtWidgets.QPushButton("Start recording")
        self.point_button = QtWidgets.QPushButton("Record point")
        self.stop_button = QtWidgets.QPushButton("Stop recording")
        form.addRow("tail id", self.tail_id)
        form.addRow("x_h", self.x_h_mm)
        form.addRow("", self.tailed)
        buttons = QtWidgets.QHBoxLayout()
        for button in (self.start_button, self.point_button, self.stop_button):
            buttons.addWidget(button)
        form.addRow(buttons)
        self.start_button.clicked.connect(
            lambda: self.session.start_recording(
                self.tail_id.text(), self.x_h_mm.value(), self.tailed.isChecked()
            )
        )
        self.point_button.clicked.connect(lambda: self.session.record_point(self.record_s.value()))
        self.stop_button.clicked.connect(self.session.stop_recording)
        return box
