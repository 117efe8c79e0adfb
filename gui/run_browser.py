"""A recorded run in the Runs tab: its set points as a table with units, and its raw signals by set point.

Opening a run reads its samples and draws them in physical units (``balance/run_signal_plots.py``: forces in N,
moments in N m relative to the run's first tare, hot-wire bridge voltage, temperature in degC, flapping frequency
per Hall cycle in Hz, pitch in deg) in the background; choosing a set point in the table zooms every panel to
its record.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from PySide6 import QtWidgets

from ornitail.acquisition.recording_reader import Recording, load_recording
from ornitail.balance.run_signal_plots import RunSignals, run_signals, run_signals_figure
from ornitail.gui.background_job import BackgroundJobs
from ornitail.gui.picture_label import PictureView

SET_POINT_COLUMNS = (
    "#",
    "kind",
    "sweep",
    "theta (deg)",
    "V (m/s)",
    "f (Hz)",
    "tail",
    "samples",
    "lost samples",
)
ZOOM_MARGIN_FRACTION = 0.1
"""Shown either side of a set point's record, as a fraction of its length."""


@dataclass(frozen=True)
class OpenedRun:
    """A run read for the browser: its recording and its signals binned for display."""

    recording: Recording
    signals: RunSignals


def open_run(run_directory: Path) -> OpenedRun:
    """Read a run and its signals (slow: every sample is read; run off the GUI thread)."""
    recording = load_recording(run_directory)
    return OpenedRun(recording, run_signals(recording))


def signals_png(signals: RunSignals, span_s: tuple[float, float] | None = None) -> bytes:
    """The run's signals as PNG bytes, every panel limited to ``span_s`` (s) when given."""
    import matplotlib.pyplot as plt

    figure = run_signals_figure(signals)
    if span_s is not None:
        for axis in figure.axes:
            axis.set_xlim(*span_s)
            axis.relim(visible_only=True)
            axis.autoscale_view(scalex=False)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=80, bbox_inches="tight")
    plt.close(figure)
    return buffer.getvalue()


def set_point_rows(recording: Recording) -> list[tuple[str, ...]]:
    """One row of :data:`SET_POINT_COLUMNS` per set point (degrees at this edge)."""
    rows = []
    for record in recording.set_points:
        rows.append(
            (
                str(record.plan_point_index),
                record.kind,
                str(record.extra.get("sweep", "-")),
                f"{math.degrees(record.pitch_rad):.2f}",
                f"{record.tunnel_velocity_m_s:.3f}",
                f"{record.flapping_frequency_hz:.2f}",
                "on" if record.tail_attached else "off",
                str(record.last_sample_index - record.first_sample_index + 1),
                str(record.samples_missing_in_record or 0),
            )
        )
    return rows


class RunBrowser(QtWidgets.QWidget):
    """Set-point table over the run's signals picture."""

    def __init__(
        self, on_problem: Callable[[str, str], None], parent: QtWidgets.QWidget | None = None
    ) -> None:
        super().__init__(parent)
        self.jobs = BackgroundJobs(on_problem, self)
        self.opened: OpenedRun | None = None
        layout = QtWidgets.QVBoxLayout(self)
        self.summary = QtWidgets.QLabel("open a run to see its set points and signals")
        self.summary.setWordWrap(True)
        layout.addWidget(self.summary)
        splitter = QtWidgets.QSplitter()
        self.table = QtWidgets.QTableWidget(0, len(SET_POINT_COLUMNS))
        self.table.setHorizontalHeaderLabels(SET_POINT_COLUMNS)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.itemSelectionChanged.connect(self._zoom_to_selected)
        self.picture = PictureView("signals appear here")
        splitter.addWidget(self.table)
        splitter.addWidget(self.picture)
        splitter.setStretchFactor(1, 2)
        layout.addWidget(splitter, 1)

    def open(self, run_directory: Path) -> None:
        """Read ``run_directory`` in the background, then show it."""
        self.summary.setText(f"reading {run_directory} ...")
        self.picture.clear("drawing the run's signals ...")
        self.jobs.run(open_run, self._show, Path(run_directory))

    def _show(self, opened: OpenedRun) -> None:
        self.opened = opened
        metadata = opened.recording.metadata
        failure = metadata.get("failure_reason")
        self.summary.setText(
            f"run {opened.recording.run_id}: {metadata.get('exit_status')}"
            + (f" ({failure})" if failure else "")
            + f", {metadata.get('sample_count')} samples at {opened.recording.sample_rate_hz:g} Hz, "
            f"{len(opened.recording.set_points)} set points; choose one to zoom the signals to its record"
        )
        rows = set_point_rows(opened.recording)
        self.table.setRowCount(len(rows))
        for row, values in enumerate(rows):
            for column, text in enumerate(values):
                self.table.setItem(row, column, QtWidgets.QTableWidgetItem(text))
        self.table.resizeColumnsToContents()
        self.jobs.run(signals_png, self.picture.show_png, opened.signals)

    def _zoom_to_selected(self) -> None:
        rows = self.table.selectionModel().selectedRows()
        if self.opened is None or not rows:
            return
        spans = self.opened.signals.set_points
        row = rows[0].row()
        if row >= len(spans):
            return
        span = spans[row]
        margin = ZOOM_MARGIN_FRACTION * (span.end_s - span.start_s)
        self.jobs.run(
            signals_png,
            self.picture.show_png,
            self.opened.signals,
            (span.start_s - margin, span.end_s + margin),
        )
