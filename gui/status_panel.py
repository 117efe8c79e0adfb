"""The always-visible status strip: instruments, link health, saturation, recording, redraw rate."""

from __future__ import annotations

from PySide6 import QtWidgets

from ornitail.acquisition.live_balance import LinkHealth
from ornitail.gui.rig_session import RigSession

OK_STYLE = "color: #1a7f37;"
WARN_STYLE = "color: white; background: #cf222e; font-weight: bold; padding: 0 4px;"


def link_health_text(health: LinkHealth) -> tuple[str, bool]:
    """The link label's text and whether it is a warning.

    Lost samples are those of the current (or last) recording, counted as ``ornitail runs`` and the sweep
    report count them: the samples its counters say are missing in its file, each once.
    """
    where = "" if health.recording_run_id is None else f" in {health.recording_run_id}"
    text = (
        f"link: lost samples {health.recording_lost_samples}{where}, CRC errors {health.crc_errors}, "
        f"garbage bytes {health.garbage_bytes} in {health.resyncs} resyncs, "
        f"dropped blocks {health.driver_dropped_blocks}"
    )
    bad = bool(
        health.recording_lost_samples
        or health.link_lost_samples
        or health.recorder_lost_samples
        or health.crc_errors
        or health.garbage_bytes
        or health.driver_dropped_blocks
    )
    return text, bad


def saturation_text(health: LinkHealth) -> tuple[str, bool]:
    """The saturation label's text (channels at the ADC limit, rows over the rated load) and whether it warns."""
    saturated = health.saturated_channels
    parts = []
    if saturated:
        parts.append("SATURATED: " + ", ".join(saturated))
    if health.over_range_samples:
        parts.append(f"OVER RATED LOAD: {health.over_range_samples} samples")
    if not parts and health.saturated_samples:
        parts.append(f"SATURATED: {health.saturated_samples} samples (board over-range flag)")
    return ("; ".join(parts), True) if parts else ("no saturation", False)


class StatusPanel(QtWidgets.QWidget):
    """Labels updated by :meth:`refresh` at every redraw."""

    def __init__(self, session: RigSession, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.session = session
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(4, 0, 4, 0)
        self.instruments = QtWidgets.QLabel()
        self.link = QtWidgets.QLabel()
        self.saturation = QtWidgets.QLabel()
        self.recording = QtWidgets.QLabel()
        self.frame_rate = QtWidgets.QLabel()
        for label, name in (
            (self.instruments, "instrumentStatus"),
            (self.link, "linkHealth"),
            (self.saturation, "saturation"),
            (self.recording, "recordingStatus"),
            (self.frame_rate, "frameRate"),
        ):
            label.setObjectName(name)
            # long texts are cut, never widen the window (the whole text is the tooltip)
            label.setSizePolicy(
                QtWidgets.QSizePolicy.Policy.Ignored, QtWidgets.QSizePolicy.Policy.Preferred
            )
            layout.addWidget(label, 0 if label is self.frame_rate else 1)

    def refresh(self, frames_per_s: float) -> None:
        """Show the session's current state."""
        session = self.session
        live = session.live
        if session.rig is None:
            self.instruments.setText("rig: not connected")
            self.instruments.setStyleSheet("")
        else:
            streaming = (
                "sweep owns the balance"
                if session.sweep_running
                else (
                    "balance streaming" if live is not None and live.running else "balance stopped"
                )
            )
            failure = live.error if live is not None else None
            fault = session.fault_text()
            text = f"rig: {session.rig.description.name}, fan/strut/motor connected, {streaming}"
            if failure is not None:
                text = f"balance failed: {failure}"
            elif fault is not None:
                text = f"INSTRUMENT FAULT: {fault}"
            self.instruments.setText(text)
            self.instruments.setStyleSheet(
                OK_STYLE if failure is None and fault is None else WARN_STYLE
            )
        health = live.health() if live is not None else None
        self._show_health(health)
        recording = session.recording
        if session.sweep_running:
            self.recording.setText("SWEEP RUNNING")
        elif recording is not None:
            self.recording.setText(
                f"RECORDING {recording.recorder.run_id} ({recording.points} points)"
            )
        else:
            self.recording.setText("not recording")
        self.recording.setStyleSheet(WARN_STYLE if recording or session.sweep_running else "")
        self.frame_rate.setText(f"{frames_per_s:.0f} fps")
        for label in (self.instruments, self.link, self.saturation, self.recording):
            if label.toolTip() != label.text():
                label.setToolTip(label.text())

    def _show_health(self, health: LinkHealth | None) -> None:
        if health is None:
            self.link.setText("link: -")
            self.saturation.setText("saturation: -")
            return
        text, bad = link_health_text(health)
        self.link.setText(text)
        self.link.setStyleSheet(WARN_STYLE if bad else OK_STYLE)
        text, saturated = saturation_text(health)
        self.saturation.setText(text)
        self.saturation.setStyleSheet(WARN_STYLE if saturated else OK_STYLE)
