"""Live view tab: six force/torque channels, hot-wire velocity, temperature, and the rig's set-point readings."""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6 import QtWidgets

from ornitail.gui.live_data import BALANCE_WINDOW_S, LiveData
from ornitail.gui.plot_style import YRangeFollower, curve, live_plot, thinned

READINGS_WINDOW_S = 60.0


class LiveView(QtWidgets.QWidget):
    """Plots of the newest seconds of data; :meth:`redraw` is called by the window's redraw timer."""

    def __init__(self, data: LiveData, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.data = data
        layout = QtWidgets.QVBoxLayout(self)
        self.readout = QtWidgets.QLabel("not connected")
        self.readout.setObjectName("liveReadout")
        self.readout.setWordWrap(True)  # a long line wraps instead of widening the window
        layout.addWidget(self.readout)
        self.plots = pg.GraphicsLayoutWidget()
        layout.addWidget(self.plots)
        window = BALANCE_WINDOW_S

        # One quantity per axis, each with its unit, in three rows of a six-column grid so that the window fits
        # 1366 x 768: the loads wide, then the flow, then the rig's set-point readings.
        def place(row: int, col: int, span: int, title: str, unit: str, seconds: float):
            return live_plot(self.plots, row, title, unit, seconds, col=col, colspan=span)

        forces = place(0, 0, 3, "Forces, body frame (decimated)", "mN", window)
        moments = place(0, 3, 3, "Moments about the reference point", "mN m", window)
        hotwire = place(1, 0, 2, "Hot-wire velocity", "m/s", window)
        temperature = place(1, 2, 2, "Flow temperature", "degC", window)
        pitch = place(1, 4, 2, "Strut pitch", "deg", READINGS_WINDOW_S)
        speed = place(2, 0, 3, "Tunnel speed (fan)", "m/s", READINGS_WINDOW_S)
        frequency = place(2, 3, 3, "Flapping frequency (motor)", "Hz", READINGS_WINDOW_S)
        for column in range(
            6
        ):  # equal columns, so that a plot spanning two is a third of the width
            self.plots.ci.layout.setColumnStretchFactor(column, 1)
            self.plots.ci.layout.setColumnPreferredWidth(column, 1)
        self.followers = [
            YRangeFollower(plot)
            for plot in (forces, moments, hotwire, temperature, pitch, speed, frequency)
        ]
        self.load_curves = [curve(forces, i, name) for i, name in enumerate(("X", "Y", "Z"))] + [
            curve(moments, i, name) for i, name in enumerate(("L", "M", "N"))
        ]
        self.hotwire_curve = curve(hotwire, 0, "hot-wire velocity (m/s)")
        self.temperature_curve = curve(temperature, 3, "temperature (degC)")
        self.rig_curves = [
            curve(pitch, 0, "pitch (deg)"),
            curve(speed, 1, "tunnel speed (m/s)"),
            curve(frequency, 2, "flapping frequency (Hz)"),
        ]

    def redraw(self) -> None:
        """One ``setData`` per curve from the rings (thinned to what the screen can show)."""
        volts = self.data.volts()
        if len(volts):
            time_s = (np.arange(len(volts)) - len(volts)) / self.data.display_rate_hz
            keep = thinned(len(volts))
            time_s, shown = time_s[keep], volts[keep]
            loads_milli = 1e3 * self.data.loads(shown)  # mN and mN m on the axes
            for index, item in enumerate(self.load_curves):
                item.setData(time_s, loads_milli[:, index])
            self.followers[0].follow(loads_milli[:, :3])
            self.followers[1].follow(loads_milli[:, 3:])
            velocity = self.data.hotwire_velocity_m_s(shown)
            temperature = self.data.temperature_c(shown)
            if velocity is not None:
                self.hotwire_curve.setData(time_s, velocity)
                self.followers[2].follow(velocity)
            self.temperature_curve.setData(time_s, temperature)
            self.followers[3].follow(temperature)
        history = self.data.instruments.latest()
        if len(history):
            time_s = history[:, 0] - history[-1, 0]
            values = (np.degrees(history[:, 1]), history[:, 2], history[:, 3])
            for item, follower, value in zip(
                self.rig_curves, self.followers[4:], values, strict=True
            ):
                item.setData(time_s, value)
                follower.follow(value)
        self.readout.setText(self.readout_text(volts))

    def readout_text(self, volts: np.ndarray) -> str:
        """One line of the latest values with units."""
        readings = self.data.session.readings
        if not math.isfinite(readings.time_s):
            return "not connected" if not self.data.session.connected else "waiting for readings"
        parts = [
            f"pitch {math.degrees(readings.pitch_rad):.2f} deg",
            f"tunnel {readings.tunnel_velocity_m_s:.3f} m/s",
            f"flapping {readings.flapping_frequency_hz:.2f} Hz",
        ]
        recent = volts[-int(max(1, 0.2 * self.data.display_rate_hz)) :] if len(volts) else volts
        if len(recent):
            velocity = self.data.hotwire_velocity_m_s(recent)
            if velocity is not None:
                parts.append(f"hot-wire {float(np.mean(velocity)):.3f} m/s")
            parts.append(f"T {float(np.mean(self.data.temperature_c(recent))):.1f} degC")
            x, _, z, _, m, _ = self.data.loads(recent).mean(axis=0)
            tare = "" if self.data.session.tare_volts is not None else " (no tare)"
            parts.append(f"X {x:+.4f} N  Z {z:+.4f} N  M {m:+.5f} N m{tare}")
        return "   ".join(parts)
