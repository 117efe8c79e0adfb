"""The window at the tunnel: emergency stop and status always visible, controls on the left, tabs on the right.

A ~30 Hz timer drives everything the display does: drain the session's messages, drain the balance's display
feed into the rings, one ``setData`` per curve, the status strip. Acquisition and recording run in their own
threads and never wait for it.

The window subscribes to the run documents of everything the session records (:attr:`RigSession.documents`):
they arrive in the recording thread, so the subscriber only queues each one among the session's messages, in
order with them, and the timer shows it. The sweep panel takes its progress and ETA from the documents, the log
the warnings they carry, and the Runs tab lists a run again when its stop document arrives.
"""

from __future__ import annotations

import time

from PySide6 import QtCore, QtGui, QtWidgets

from ornitail.acquisition.run_documents import Document, RunStop, SetPointDocument
from ornitail.gui.controls_panel import ControlsPanel
from ornitail.gui.cycle_view import CycleView
from ornitail.gui.design_tab import DesignTab
from ornitail.gui.live_data import LiveData
from ornitail.gui.live_view import LiveView
from ornitail.gui.main_thread_collector import MainThreadGarbageCollector
from ornitail.gui.message_log import MessageLog
from ornitail.gui.rig_session import RigSession, SessionMessage
from ornitail.gui.runs_tab import RunsTab
from ornitail.gui.status_panel import StatusPanel
from ornitail.gui.sweep_panel import SweepPanel

REDRAW_INTERVAL_MS = 30
ESTOP_STYLE = "QPushButton { background: #cf222e; color: white; font-weight: bold; font-size: 16px; padding: 8px; }"


class MainWindow(QtWidgets.QMainWindow):
    """The whole window for one :class:`RigSession`."""

    def __init__(self, session: RigSession) -> None:
        super().__init__()
        self.session = session
        self.setWindowTitle("ornitail - DelFly tail at the tunnel")
        self.data = LiveData(session)
        self.emergency_button = QtWidgets.QPushButton("EMERGENCY STOP  (Ctrl+E)")
        self.emergency_button.setStyleSheet(ESTOP_STYLE)
        self.emergency_button.setToolTip("Abort any sweep, motor off, fan to zero, strut halted")
        self.emergency_button.clicked.connect(self.emergency_stop)
        QtGui.QShortcut(QtGui.QKeySequence("Ctrl+E"), self, activated=self.emergency_stop)
        self.status = StatusPanel(session)
        self.controls = ControlsPanel(session)
        self.sweep_panel = SweepPanel(session)
        self.controls.layout().insertWidget(3, self.sweep_panel)
        self.live_view = LiveView(self.data)
        self.cycle_view = CycleView(self.data)
        self.runs_tab = RunsTab(session.data_root, self.report_problem)
        self.design_tab = DesignTab(self.runs_tab, self.report_problem)
        self.tabs = QtWidgets.QTabWidget()
        for widget, name in (
            (self.live_view, "Live"),
            (self.cycle_view, "Cycle"),
            (self.runs_tab, "Runs"),
            (self.design_tab, "Design"),
        ):
            self.tabs.addTab(widget, name)
        self.log = MessageLog()
        self.log.setMaximumHeight(140)
        self._build_layout()
        self.frames = 0
        self.frames_per_s = 0.0
        self._frame_clock = (time.monotonic(), 0)
        self.documents_token = session.documents.subscribe(
            lambda name, document: session.post("document", name, document)
        )
        self.timer = QtCore.QTimer(self)
        self.timer.setTimerType(QtCore.Qt.TimerType.PreciseTimer)
        self.timer.timeout.connect(self.tick)
        self.timer.start(REDRAW_INTERVAL_MS)
        self.garbage_collector = MainThreadGarbageCollector(self)
        self.garbage_collector.start()

    def _build_layout(self) -> None:
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.emergency_button)
        top.addWidget(self.status, 1)
        scroll = QtWidgets.QScrollArea()
        scroll.setWidget(self.controls)
        scroll.setWidgetResizable(True)
        scroll.setMinimumWidth(430)
        splitter = QtWidgets.QSplitter()
        splitter.addWidget(scroll)
        splitter.addWidget(self.tabs)
        splitter.setStretchFactor(1, 1)
        central = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(central)
        layout.addLayout(top)
        layout.addWidget(splitter, 1)
        layout.addWidget(self.log)
        self.setCentralWidget(central)

    # -- actions ----------------------------------------------------------------------------
    def emergency_stop(self) -> None:
        """Bring motor and tunnel to a safe state now (and abort any sweep)."""
        self.log.add("EMERGENCY STOP pressed")
        self.session.emergency_stop()

    def report_problem(self, title: str, text: str) -> None:
        """A message box and a log line (user mistakes and instrument errors)."""
        self.log.show_problem(title, text)

    # -- redraw -----------------------------------------------------------------------------
    def tick(self) -> None:
        """One redraw: messages, data, plots, status."""
        while not self.session.messages.empty():
            self.handle(self.session.messages.get_nowait())
        self.data.update()
        if self.tabs.currentWidget() is self.live_view:
            self.live_view.redraw()
        self.cycle_view.refresh()
        self.sweep_panel.refresh()
        self._count_frame()
        self.status.refresh(self.frames_per_s)

    def _count_frame(self) -> None:
        self.frames += 1
        started, frames = self._frame_clock
        now = time.monotonic()
        if now - started >= 1.0:
            self.frames_per_s = (self.frames - frames) / (now - started)
            self._frame_clock = (now, self.frames)

    def handle(self, message: SessionMessage) -> None:
        """Show one session message where it belongs."""
        if message.kind == "user_error":
            self.report_problem("Input problem", message.text)
        elif message.kind == "error":
            self.report_problem("Instrument problem", message.text)
        elif message.kind == "connected":
            self.data.reset_for_rig()
            self.controls.set_rig_limits()
            self.log.add(message.text)
        elif message.kind == "document":
            self.show_document(message.payload)
        elif message.kind == "sweep_event":
            self.sweep_panel.show_event(message.payload)
            if message.payload.stage == "tail_change":
                self.log.add(message.text)
        elif message.kind == "sweep_done":
            self.sweep_panel.show_done(message.payload)
            self.log.add(message.text)
        elif message.kind == "prompt":
            self._prompt(message.text, message.payload)
        else:
            self.log.add(message.text)

    def show_document(self, document: Document) -> None:
        """Show one run document: a plan's progress in the sweep panel, a set point of a plan and its warnings in
        the log, a stopped run in the Runs tab."""
        progress = getattr(document, "progress", None)
        if progress is not None:
            self.sweep_panel.show_progress(progress)
        if isinstance(document, SetPointDocument):
            if progress is not None:
                self.log.add(
                    f"recorded {document.kind} #{document.plan_point_index} "
                    f"({progress.done}/{progress.total})"
                )
            for line in document.warnings:
                self.log.add(line)
        elif isinstance(document, RunStop):
            self.runs_tab.run_stopped(document)

    def _prompt(self, instruction: str, done) -> None:
        box = QtWidgets.QMessageBox(
            QtWidgets.QMessageBox.Icon.Information,
            "Operator action",
            f"{instruction}\nPress OK when done.",
            parent=self,
        )
        box.finished.connect(lambda _result: done.set())
        box.open()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 - Qt override
        """Safe state and disconnect before the window goes."""
        self.timer.stop()
        self.session.shutdown()
        self.session.documents.unsubscribe(self.documents_token)
        self.garbage_collector.stop()  # once the session has disconnected
        super().closeEvent(event)
